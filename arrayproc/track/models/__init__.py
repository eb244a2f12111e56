"""Motion and measurement models as objects (L-R paper eqs. (1)-(8); SPL paper eqs. (31)-(33);
thesis eqs. (3.37)-(3.40)). One file per measurement type; numba kernels in ``_kernels.py``."""

from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.level_bearing import LevelBearing
from arrayproc.track.models.mirrored_bearing import MirroredBearing
from arrayproc.track.models.motion import (
    Q1_PAPER,
    Q2_PAPER,
    ConstantTurn,
    ConstantVelocity,
    make_model,
)
from arrayproc.track.models.tdoa import TDOA

__all__ = ["MotionModel", "MeasurementModel", "ConstantVelocity", "ConstantTurn", "Bearing",
           "MirroredBearing", "LevelBearing", "TDOA", "Q1_PAPER", "Q2_PAPER", "make_model"]
