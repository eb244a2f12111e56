"""Stone Soup interoperability (optional extra ``stonesoup``; imported lazily).

- :func:`detection_reader` — a Stone Soup ``DetectionReader`` yielding ``Detection``s from a
  products file: ``contacts`` with ``CartesianToBearingRangeRate2D`` placed at the ownship
  pose, ``bearings`` with ``Cartesian2DToBearing`` (both members of a line array's
  port/starboard pair as detections), ``positions`` with a linear position model.
- :func:`tracks_to_rows` / :func:`write_tracks` — Stone Soup tracks back to our ``tracks``
  kind (docs/formats.md).
- :func:`gnn_tracker` — the GNN tracker assembled from Stone Soup components equivalent to
  :func:`arrayproc.track.multi.contacts_manager` (CV model, EKF, Mahalanobis gate, 2-D
  assignment, multi-measurement initiation, deletion after missed updates); the reference of
  ``scripts/bench_multi.py`` and of the agreement test.

Frames: Stone Soup's state is [x, ẋ, y, ẏ] and its bearing φ = atan2(y, x) counter-clockwise
from east; ours is [x, y, ẋ, ẏ] and β = atan2(x, y) clockwise from north, so φ = π/2 − β.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Iterable
from functools import lru_cache
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError, FormatError

EPOCH = dt.datetime(2000, 1, 1)
#: our [x, y, ẋ, ẏ] index of each Stone Soup [x, ẋ, y, ẏ] component
SS_ORDER = np.array([0, 2, 1, 3])


def _require() -> None:
    try:
        import stonesoup  # noqa: F401
    except ImportError:
        raise ArrayprocError("Stone Soup is not installed: pip install 'arrayproc[stonesoup]'"
                             ) from None


def to_ss_bearing(beta_rad: np.ndarray | float) -> np.ndarray:
    """Our bearing (rad, clockwise from north) as Stone Soup's φ (rad, from east)."""
    return (math.pi / 2 - np.asarray(beta_rad, float) + math.pi) % (2 * math.pi) - math.pi


def _start(path: str) -> dt.datetime:
    """Absolute start of the recording a products file names, else :data:`EPOCH`."""
    from arrayproc.io.exports import _recording_info
    from arrayproc.io.products import read_products
    _src, _dur, iso, _ = _recording_info(read_products(path)["/"], path)
    if not iso:
        return EPOCH
    t = dt.datetime.fromisoformat(iso.replace("Z", "+00:00"))
    return t.replace(tzinfo=None)


@lru_cache(maxsize=1)
def _reader_class() -> type:
    from stonesoup.base import Property
    from stonesoup.buffered_generator import BufferedGenerator
    from stonesoup.reader.base import DetectionReader

    class ProductsDetectionReader(DetectionReader):
        """Detections from an arrayproc products file (see :mod:`arrayproc.interop.stonesoup`).
        """

        path: str = Property(doc="products file")
        kind: str = Property(default=None, doc="contacts, bearings or positions "
                                                "(default: the first found)")
        sigma_bearing_deg: float = Property(default=1.0, doc="bearing noise, deg")
        sigma_range_m: float = Property(default=20.0, doc="range noise, m")
        sigma_range_rate_mps: float = Property(default=0.3, doc="range-rate noise, m/s")
        start: dt.datetime = Property(default=None, doc="time of t = 0 (default: the "
                                                        "recording's start)")

        @BufferedGenerator.generator_method
        def detections_gen(self):
            yield from _detections(self)

    return ProductsDetectionReader


def detection_reader(path: str, kind: str | None = None, **kw: Any) -> Any:
    """A Stone Soup ``DetectionReader`` over a products file (keyword arguments:
    ``sigma_bearing_deg``, ``sigma_range_m``, ``sigma_range_rate_mps``, ``start``)."""
    _require()
    return _reader_class()(path=path, kind=kind, **kw)


def _detections(r: Any) -> Iterable[tuple[dt.datetime, set]]:
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing
    from stonesoup.types.detection import Detection

    from arrayproc.io.exports import _recording_info
    from arrayproc.io.products import read_products
    from arrayproc.io.recording import Recording
    from arrayproc.track.single import ownship_states

    prod = read_products(r.path)
    kind = r.kind or next((k for k in ("contacts", "bearings", "positions") if prod.groups(k)),
                          None)
    found = list(prod.groups(kind).values()) if kind else []
    if not found:
        raise FormatError(f"{r.path}: no {kind or 'contacts, bearings or positions'} group")
    g = found[-1]  # the last group of the kind
    start = r.start or _start(r.path)
    t = np.asarray(g["time"], float)
    src, _d, _s, _n = _recording_info(prod["/"], r.path)
    nav = None
    if kind != "positions":
        try:
            with Recording(src, require_geometry=False) as rec:
                nav = rec.nav
        except (OSError, FormatError):
            raise FormatError(f"{r.path}: recording {src!r} with the ownship navigation "
                              "cannot be opened") from None
    sb = math.radians(r.sigma_bearing_deg)
    if kind == "contacts":
        yield from _contact_detections(r, g, nav, start, src, sb)
        return
    for tk in np.unique(t):
        rows = np.flatnonzero(t == tk)
        when = start + dt.timedelta(seconds=float(tk))
        dets = set()
        if nav is not None:
            own, _ = ownship_states(nav, np.array([tk]))
            o = own[0]
        for i in rows:
            if kind == "bearings":
                mm = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                          noise_covar=np.array([[sb ** 2]]),
                                          translation_offset=np.array([[o[0]], [o[1]]]))
                for col in ("bearing_port_deg", "bearing_stbd_deg"):
                    z = np.array([[to_ss_bearing(math.radians(float(g[col][i])))]])
                    dets.add(Detection(z, timestamp=when, measurement_model=mm,
                                       metadata={"row": int(i), "member": col}))
            else:
                mm = LinearGaussian(ndim_state=6, mapping=(0, 2, 4),
                                    noise_covar=np.asarray(g["cov"][i], float))
                z = np.array([[g["x"][i]], [g["y"][i]], [g["z"][i]]], float)
                dets.add(Detection(z, timestamp=when, measurement_model=mm,
                                   metadata={"row": int(i)}))
        yield when, dets


def _contact_detections(r: Any, g: dict, nav: Any, start: dt.datetime, src: str,
                        sb: float) -> Iterable[tuple[dt.datetime, set]]:
    """Detections of a ``contacts`` group, one scan per ping at its transmission time with the
    ranges carried back to it, exactly as the package's own contacts tracker sees them
    (:func:`arrayproc.track.multi.contact_scans`): the active chain stamps each contact with
    its echo's reception time, so grouping by time would make one scan per contact."""
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRangeRate2D
    from stonesoup.types.detection import Detection

    from arrayproc.io.recording import DEFAULT_SOUND_SPEED, Recording
    from arrayproc.track.multi import contact_scans

    c = {k: np.asarray(g[k], float) for k in ("time", "range_m", "bearing_port_deg",
                                              "bearing_stbd_deg", "range_rate_mps")}
    if "ping" in g:
        c["ping"] = np.asarray(g["ping"], np.int64)
    try:
        with Recording(src, require_geometry=False) as rec:
            c_sound = float(rec.sound_speed)
    except (OSError, FormatError):
        c_sound = DEFAULT_SOUND_SPEED
    for ts, Z, rows, o in contact_scans(c, nav, mirror=True, sound_speed=c_sound):
        when = start + dt.timedelta(seconds=float(ts))
        mm = CartesianToBearingRangeRate2D(
            ndim_state=4, mapping=(0, 2), velocity_mapping=(1, 3),
            noise_covar=np.diag([sb ** 2, r.sigma_range_m ** 2, r.sigma_range_rate_mps ** 2]),
            translation_offset=np.array([[o[0]], [o[1]]]),
            velocity=np.array([[o[2]], [o[3]]]))
        dets = set()
        for z, i in zip(Z, rows):
            dets.add(Detection(np.array([[to_ss_bearing(z[0])], [z[1]], [z[2]]], float),
                               timestamp=when, measurement_model=mm,
                               metadata={"row": int(i)}))
        yield when, dets


def tracks_to_rows(tracks: Iterable[Any], start: dt.datetime = EPOCH
                   ) -> dict[str, np.ndarray]:
    """Stone Soup tracks (2-D CV states [x, ẋ, y, ẏ]) as columns of our ``tracks`` kind:
    ``time`` (s since ``start``), ``track_id`` (order of the tracks), ``x``, ``y``, ``vx``,
    ``vy``, ``cov`` (n, 4, 4) in our [x, y, ẋ, ẏ] order, ``status`` (1: confirmed),
    ``own_x``, ``own_y`` (NaN: not known to Stone Soup)."""
    cols: dict[str, list] = {k: [] for k in ("time", "track_id", "x", "y", "vx", "vy", "cov")}
    for k, tr in enumerate(tracks):
        for st in tr.states:
            v = np.asarray(st.state_vector, float).reshape(-1)
            if v.size != 4:
                raise FormatError("stonesoup: only 2-D constant-velocity states convert")
            P = np.asarray(st.covar, float)[np.ix_(SS_ORDER, SS_ORDER)]
            cols["time"].append((st.timestamp - start).total_seconds())
            cols["track_id"].append(k)
            cols["x"].append(v[0])
            cols["vx"].append(v[1])
            cols["y"].append(v[2])
            cols["vy"].append(v[3])
            cols["cov"].append(P)
    out = {k: np.asarray(v, float) for k, v in cols.items()}
    out["track_id"] = out["track_id"].astype(np.int64)
    out["cov"] = out["cov"].reshape(-1, 4, 4)
    out["status"] = np.ones(out["time"].size, np.int8)  # io.schema: 1 confirmed
    out["own_x"] = np.full(out["time"].size, np.nan)  # the ownship is not in Stone Soup tracks
    out["own_y"] = np.full(out["time"].size, np.nan)
    return out


def write_tracks(tracks: Iterable[Any], out: str, source: str = "",
                 start: dt.datetime = EPOCH) -> int:
    """Write Stone Soup tracks as a ``tracks`` file; returns the rows written."""
    from arrayproc.io.products import ProductsWriter
    rows = tracks_to_rows(tracks, start)
    with ProductsWriter(out, source=source) as w:
        g = w.group("tracks", "tracks", stage="stonesoup")
        if rows["time"].size:
            g.append(**rows)
    return int(rows["time"].size)


@lru_cache(maxsize=1)
def _polar_initiator_class() -> type:
    from stonesoup.base import Property
    from stonesoup.initiator.base import GaussianInitiator
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.types.update import GaussianStateUpdate

    from arrayproc.track.models.bearing_range_rate import BearingRangeRate

    class PolarInitiator(GaussianInitiator):
        """One-point initiation from a bearing-range-range-rate detection, the same as
        :meth:`BearingRangeRate.inverse` (Stone Soup 1.9's ``CartesianToBearingRangeRate2D``
        is not reversible, so its ``SimpleMeasurementInitiator`` refuses it)."""

        prior_state: GaussianState = Property(doc="unused: the state comes from the detection")
        sigma_speed: float = Property(default=5.0, doc="unobserved tangential speed σ, m/s")

        def initiate(self, detections, timestamp, **kwargs):
            tracks = set()
            for d in detections:
                mm = d.measurement_model
                R = np.asarray(mm.covar(), float)
                model = BearingRangeRate(sigma_bearing=math.sqrt(R[0, 0]),
                                         sigma_range=math.sqrt(R[1, 1]),
                                         sigma_range_rate=math.sqrt(R[2, 2]))
                z = np.asarray(d.state_vector, float).reshape(-1)
                own = np.r_[np.asarray(mm.translation_offset, float).reshape(-1),
                            np.asarray(mm.velocity, float).reshape(-1)]
                beta = math.pi / 2 - z[0]
                x, P = model.inverse(np.array([beta, z[1], z[2]]), own, self.sigma_speed)
                xs = x[SS_ORDER].reshape(4, 1)
                Ps = P[np.ix_(SS_ORDER, SS_ORDER)]
                tracks.add(Track([GaussianStateUpdate(
                    xs, Ps, SingleHypothesis(None, d), timestamp=d.timestamp)]))
            return tracks

    return PolarInitiator


def gnn_tracker(detector: Any, q: float, gate_prob: float = 0.999, min_points: int = 3,
                max_misses: int = 5, sigma_speed_mps: float = 5.0,
                measurement_model: Any = None) -> Any:
    """Stone Soup ``MultiTargetTracker``: CV (``q`` m²/s³) ``KalmanPredictor``,
    ``ExtendedKalmanUpdater``, ``DistanceHypothesiser`` with the Mahalanobis distance gated at
    the χ² quantile of ``gate_prob``, ``GNNWith2DAssignment``, ``MultiMeasurementInitiator``
    (``min_points``) and ``UpdateTimeStepsDeleter`` (``max_misses``)."""
    _require()
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantVelocity,
    )
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetTracker
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater

    from arrayproc.track.manage.associate import gate_threshold

    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    predictor = KalmanPredictor(tm)
    updater = ExtendedKalmanUpdater(measurement_model)
    gate = math.sqrt(gate_threshold(gate_prob, 3))
    hyp = DistanceHypothesiser(predictor, updater, Mahalanobis(), missed_distance=gate)
    assoc = GNNWith2DAssignment(hyp)
    deleter = UpdateTimeStepsDeleter(max_misses + 1)
    s2 = sigma_speed_mps ** 2
    prior = GaussianState(np.zeros((4, 1)), np.diag([1e6, s2, 1e6, s2]))
    init = MultiMeasurementInitiator(prior, deleter, assoc, updater,
                                     measurement_model=measurement_model,
                                     min_points=min_points,
                                     initiator=_polar_initiator_class()(
                                         prior_state=prior, sigma_speed=sigma_speed_mps))
    return MultiTargetTracker(initiator=init, deleter=deleter, detector=detector,
                              data_associator=assoc, updater=updater)


__all__ = ["detection_reader", "tracks_to_rows", "write_tracks", "gnn_tracker",
           "to_ss_bearing", "EPOCH"]
