"""A measurement-level two-target towed-array scenario for the per-track TMA: the end-fire
crossing in a turn (:func:`arrayproc.track.batch.scenarios.endfire_turn_track`, source ``a``
3.6 km on the starboard bow, tonal 300 Hz, carried through forward end-fire to port) and a
second source ``b`` 2.5 km on the starboard beam heading west at 3 m/s (tonal 180 Hz; its
cone angle stays in 77°-132°), one bearings row per source every 5 s (σ 0.5°, 0.05 Hz),
tracked by the shipped multi-target tracker."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from arrayproc.data import data_path
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.synthetic import Source, with_measurements, write_line_array_scenario
from arrayproc.track.runner import run_tracker

B_STATE = np.array([2500.0, 0.0, -3.0, 0.0])
SOURCES = {"a": Source(S.ENDFIRE_SOURCE, 300.0), "b": Source(B_STATE, 180.0)}
#: [x, y, vx, vy, f0] of each source, in SOURCES' order
TRUTH = [np.append(s.state, s.f0_hz) for s in SOURCES.values()]
SIG_DEG, SIG_HZ = 0.5, 0.05


def build(folder: Path, seed: int) -> dict[str, Path | dict]:
    """Recording, products and tracks in ``folder``: ``tracks``, the bearings tracks;
    ``tracks_f``, the same tracks holding each point's measurement with its line frequency, as
    the lines+bearings tracker writes them (:func:`with_measurements`)."""
    folder.mkdir(parents=True, exist_ok=True)
    nav, _ = S.endfire_turn_track(n=626, dt=1.0)
    rec, prod, rows = write_line_array_scenario(str(folder), nav, SOURCES,
                                                np.arange(0.0, 626.0, 5.0), SIG_DEG, SIG_HZ,
                                                seed=seed)
    tracks = folder / "tracks.h5"
    run_tracker(prod, str(Path(data_path("trackers")) / "multi_target.toml"), str(tracks))
    tracks_f = folder / "tracks_f.h5"
    with_measurements(tracks, tracks_f, prod, rows["freq_hz"])
    return {"rec": Path(rec), "prod": Path(prod), "tracks": tracks, "tracks_f": tracks_f,
            "rows": rows}


def source_of(tracks: Path, rows: dict, track_id: int) -> int:
    """The source whose rows a track used most."""
    with h5py.File(tracks, "r") as f:
        ids, r = f["tracks/track_id"][()], f["tracks/row"][()]
    used = r[(ids == track_id) & (r >= 0)]
    return int(np.bincount(rows["source"][used]).argmax())


def truth_at(src: int, t0: float) -> np.ndarray:
    """[x, y, vx, vy, f0] of a source at ``t0``."""
    x = TRUTH[src].copy()
    x[:2] += t0 * x[2:4]
    return x


def nees(state: np.ndarray, crlb: np.ndarray, src: int, t0: float) -> float:
    """``eᵀ CRLB⁻¹ e`` over the state's dimension, against the source's state at ``t0``."""
    e = state - truth_at(src, t0)[:state.size]
    return float(e @ np.linalg.solve(crlb, e))
