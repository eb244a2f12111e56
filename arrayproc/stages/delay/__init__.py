"""Delay stages (thesis section 3.2.2.1): transient detection, time delays between hydrophones
(generalised cross-correlation, phase-unwrapping LLS) and TDOA localisation.

Algorithm modules: :mod:`.gcc`, :mod:`.unwrap`, :mod:`.bounds`, :mod:`.detect`,
:mod:`.localise` (numba kernels in :mod:`._kernels`); stage classes: :mod:`.transients`,
:mod:`.tde`, :mod:`.localise_stage`.
"""
