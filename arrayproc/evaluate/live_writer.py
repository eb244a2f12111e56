"""A live recorder for the ``--follow`` tests and benchmark: writes a recording in SWMR
mode, appending seeded noise plus a tone in chunks with a flush and a pause after each, and
logs the wall time of every flush. Run as ``python -m arrayproc.evaluate.live_writer OUT.h5
LOG SECONDS CHUNK_S PAUSE_S [HOLD_S [WAIT_FOR]]``; logs ``ready`` (stderr) once the file can
be opened by a follower. ``HOLD_S``: keep the file open that long after the last append (a
recorder that went quiet). ``WAIT_FOR``: a products file; after the first second of samples
the writer waits until that file holds rows (the follower is up and running) before it goes
on. An eighth argument ``nav``: the array moves (east at 2 m/s, turning at 3 deg/s) and
``/nav`` grows with the samples, one row at the end of each chunk."""

from __future__ import annotations

import json
import logging
import sys
import time

import h5py
import numpy as np

from arrayproc.io.recording import RecordingWriter

_log = logging.getLogger(__name__)

FS = 1000.0
N_CH = 8


def samples(seconds: float, seed: int = 3) -> np.ndarray:
    """The whole recording's samples (the same for every run)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    t = np.arange(n) / FS
    delay = -np.arange(N_CH) * 0.5 * np.cos(np.deg2rad(60.0)) / 1500.0
    x = 0.3 * rng.standard_normal((n, N_CH))
    x += np.sin(2 * np.pi * 120.0 * (t[:, None] - delay[None, :]))
    return x.astype(np.float32)


def grow_nav(g, t: float) -> None:
    """Append the track's row at time t (s) to the ``/nav`` datasets, ``time`` written last
    (a follower counts a row once its time is written)."""
    n = g["time"].shape[0]
    for k in ("time", "position", "heading"):
        g[k].resize(n + 1, axis=0)
    g["position"][n] = (2.0 * t, 0.0)
    g["heading"][n] = (90.0 + 3.0 * t) % 360.0
    g["time"][n] = t


def has_rows(path: str) -> bool:
    """Whether a products file being written live holds any rows yet."""
    found = []
    try:
        with h5py.File(path, "r", libver="latest", swmr=True) as f:
            f.visititems(lambda k, v: found.append(isinstance(v, h5py.Dataset)
                                                   and v.ndim > 0 and v.shape[0] > 0))
    except (OSError, FileNotFoundError):
        return False
    return any(found)


def main() -> None:
    out, log, seconds, chunk_s, pause_s = sys.argv[1:6]
    hold = float(sys.argv[6]) if len(sys.argv) > 6 else 0.0
    wait_for = sys.argv[7] if len(sys.argv) > 7 and sys.argv[7] != "-" else None
    nav = len(sys.argv) > 8 and sys.argv[8] == "nav"
    x = samples(float(seconds))
    pos = np.zeros((N_CH, 3))
    pos[:, 0] = -np.arange(N_CH) * 0.5
    step = int(float(chunk_s) * FS)
    times = []
    with RecordingWriter(out, FS, N_CH, positions=pos, live=True, chunk_samples=256) as w:
        if nav:
            track = w._f.create_group("nav")
            for k, shape in (("time", ()), ("position", (2,)), ("heading", ())):
                track.create_dataset(k, shape=(0,) + shape, maxshape=(None,) + shape,
                                     dtype=float, chunks=(64,) + shape, fillvalue=np.nan)
            grow_nav(track, 0.0)
        w.flush()
        _log.info("ready")  # the follower may open the file now
        for a in range(0, x.shape[0], step):
            w.append(x[a:a + step])
            if nav:
                grow_nav(track, min(a + step, x.shape[0]) / FS)
            w.flush()
            times.append([int(min(a + step, x.shape[0])), time.time()])
            if wait_for and a < FS <= a + step:
                t0 = time.monotonic()
                while not has_rows(wait_for) and time.monotonic() - t0 < 300:
                    time.sleep(0.05)
            time.sleep(float(pause_s))
        time.sleep(hold)
    with open(log, "w") as f:
        json.dump(times, f)


def wait_ready(proc) -> bool:
    """Read a recorder's stderr (a ``subprocess.Popen`` with ``stderr=PIPE``, text) up to its
    ``ready`` line; False when it ended first."""
    for line in proc.stderr:
        if line.strip() == "ready":
            return True
    return False


if __name__ == "__main__":
    # the readiness line on stderr, which the follower's side waits for
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    main()
