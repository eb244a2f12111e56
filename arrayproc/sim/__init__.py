"""Scenario (TOML) → simulated hydrophone recording with ground truth.

Entry point: :func:`arrayproc.sim.run.simulate_file` (``arrayproc simulate``).
"""

import os

# The simulator alternates numba parallel kernels with numpy/FFTW work in the main thread.
# GNU OpenMP's default lets idle workers spin after each parallel region, which steals the
# cores that work needs (3x slower on a shared 2-core machine, docs/performance.md). Sleep
# instead, unless the user chose otherwise. Read when the OpenMP runtime starts.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
