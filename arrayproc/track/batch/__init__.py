"""Batch maximum-likelihood TMA and its Cramér-Rao bounds (thesis section 3.3, appendix C;
compact-array paper eqs. (1)-(5)).

- :mod:`.bo_tma`: bearings-only TMA (Farina's MLE, thesis eqs. (3.41)-(3.47)).
- :mod:`.td_tma`: time-delay TMA (eqs. (3.48)-(3.52)).
- :mod:`.compact`: stationary compact-array TMA with a speed prior and correlated errors.
- :mod:`.fim`: Fisher information, CRLB, condition number (3.53)-(3.55).
- :mod:`.run`: the ``arrayproc tma`` driver (products in, products ``tma`` out).
"""

from .bo_tma import solve_bearings, solve_line_bearings
from .compact import solve_compact
from .cross_fix import solve_cross_fix
from .result import TmaSolution
from .td_tma import solve_delays

__all__ = ["TmaSolution", "solve_bearings", "solve_line_bearings", "solve_delays",
           "solve_compact", "solve_cross_fix"]
