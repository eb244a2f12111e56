"""Tolerances for comparing two code paths that compute the same numbers (docs/testing.md).

Bit equality is kept only where the same code runs twice (determinism, the same seed, a
segmented run against one run, bytes stored and read back) or where every element is a copy or
one IEEE-754 basic operation (+, −, ×, ÷, √ are correctly rounded on every machine). Two
different implementations of the same mathematics get one of the checks below instead, each
with its reason.
"""

from __future__ import annotations

import numpy as np

#: ulps allowed between two implementations of one elementary function (atan2, exp, log, ...).
#: numba and CPython's ``math`` call the platform libm, while numpy on an AVX-512 CPU runs its
#: own SIMD loops (Intel SVML): on an AVX-512 AMD EPYC, numpy 2.4.6 against numba 0.68.1 gave
#: atan2 1 ulp apart for 7.7 % of 2e6 random inputs (exp: 4.6 %, log: 5e-5 %), never more;
#: on a CPU without those loops they may agree bit for bit. 4 ulps leaves room for other
#: libms (macOS, musl, Windows) and is still 1e-15 relative: an error in the code is far larger.
LIBM_ULP = 4

#: Relative difference (to the array's largest magnitude) allowed between two code paths of one
#: filter recursion (a fused numba kernel and the per-step objects). Measured: jittering every
#: bearing of a 31-step L-R run by up to 4 ulps moves its states, covariances and weights by at
#: most 2e-13 of their scale (EKF, UKF, CKF, GHF, SRF), while a change of the process noise by
#: one part in 1e6 moves them by 1.5e-9 or more and a 1e-7 rad bias of the bearings by 1e-7.
RECURSION_REL = 1e-10


def assert_libm_close(actual, desired, maxulp: int = LIBM_ULP) -> None:
    """Elementwise within ``maxulp`` units in the last place (:data:`LIBM_ULP`)."""
    np.testing.assert_array_max_ulp(np.asarray(actual, dtype=float),
                                    np.asarray(desired, dtype=float), maxulp=maxulp)


def assert_close_to_scale(actual, desired, rel: float = RECURSION_REL, err_msg: str = "") -> None:
    """``|actual − desired| ≤ rel · max|desired|`` elementwise: the rounding of a long
    computation is relative to the magnitudes it carried, not to each (possibly near-zero)
    element (:data:`RECURSION_REL`)."""
    desired = np.asarray(desired, dtype=float)
    scale = float(np.max(np.abs(desired))) if desired.size else 0.0
    np.testing.assert_allclose(actual, desired, rtol=0.0, atol=rel * scale, err_msg=err_msg)
