"""Narrowband EKF bearing/frequency tracker on DFT-filtered hydrophone samples (thesis 3.2.1):
measurement model (:mod:`.model`), numba kernel (:mod:`._kernels`), re-initialised dual filter
(:mod:`.ekf`), amplitude compensation (:mod:`.amplitude`), automatic start values
(:mod:`.initial`), the per-sample CBF baseline of thesis 3.2.1.1 (:mod:`.cbf_baseline`) and the
``nb_ekf`` stage (:mod:`.nb_ekf`)."""
