"""Shared simulation for the manager tests: targets in 2-D with position measurements."""

from __future__ import annotations

import math

import numpy as np

from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import RecordingWriter


def simulate_cv(n_targets: int, n_scans: int, seed: int, dt: float = 1.0, sigma: float = 5.0,
                pd: float = 1.0, clutter: int = 0, area: float = 2000.0,
                spacing: float = 300.0) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Straight-line targets (truth (n_targets, n_scans, 4)) and per-scan position
    measurements with labels (−1: clutter)."""
    rng = np.random.default_rng(seed)
    x0 = np.stack([np.arange(n_targets) * spacing - area / 2,
                   rng.uniform(-area / 4, area / 4, n_targets),
                   rng.uniform(-5, 5, n_targets), rng.uniform(-5, 5, n_targets)], 1)
    t = np.arange(n_scans) * dt
    truth = np.empty((n_targets, n_scans, 4))
    truth[..., :2] = x0[:, None, :2] + t[None, :, None] * x0[:, None, 2:]
    truth[..., 2:] = x0[:, None, 2:]
    Zs, labels = [], []
    for k in range(n_scans):
        det = rng.random(n_targets) < pd
        z = truth[det, k, :2] + sigma * rng.standard_normal((det.sum(), 2))
        c = rng.uniform(-area, area, (rng.poisson(clutter) if clutter else 0, 2))
        Zs.append(np.vstack([z, c]))
        labels.append(np.concatenate([np.flatnonzero(det), -np.ones(len(c), int)]))
    return truth, Zs, labels


SIG = (1.0, 15.0, 0.2)


def contact_files(tmp_path, seed=4):
    """A static observer's recording and a contacts products file of two CV targets; returns
    (recording, products, final true positions (2, 2))."""
    rng = np.random.default_rng(seed)
    rec = tmp_path / "rec.h5"
    with RecordingWriter(rec, 100.0, 1, start_time="2026-01-01T00:00:00Z") as w:
        w.append(np.zeros((100, 1), np.float32))
        w.set_nav(np.array([0.0, 1000.0]), np.array([[0.0, 0.0], [0.0, 0.0]]),
                  np.array([0.0, 0.0]))
    x0 = np.array([[4000.0, 3000.0, -4.0, 1.0], [-2000.0, 6000.0, 3.0, -3.0]])
    t = np.arange(40) * 10.0
    rows = {k: [] for k in ("time", "range_m", "cone_deg", "bearing_port_deg",
                            "bearing_stbd_deg", "range_rate_mps", "ping",
                            "absolute_doppler_mps", "snr_db", "moving")}
    truth = x0[:, None, :2] + t[None, :, None] * x0[:, None, 2:]
    c = 1500.0   # the recording's sound speed (the format's default)
    for k, tk in enumerate(t):
        for s in range(2):
            # as the active chain writes them: the echo of the ping sent at tk, scattered at
            # t_sc (|d(t_sc)| = c (t_sc - tk)) and stamped with its reception time
            v = x0[s, 2:]
            t_sc = tk
            for _ in range(30):
                t_sc = tk + float(np.hypot(*(x0[s, :2] + t_sc * v))) / c
            d = x0[s, :2] + t_sc * v
            r = float(np.hypot(*d))
            b = math.degrees(math.atan2(d[0], d[1])) + SIG[0] * rng.standard_normal()
            rows["time"].append(t_sc + r / c)
            rows["range_m"].append(r + SIG[1] * rng.standard_normal())
            rows["cone_deg"].append(b % 360)
            rows["bearing_port_deg"].append(b % 360)
            rows["bearing_stbd_deg"].append(b % 360)
            rows["range_rate_mps"].append(float(d @ v) / r + SIG[2] * rng.standard_normal())
            rows["ping"].append(k)
            rows["absolute_doppler_mps"].append(rows["range_rate_mps"][-1])
            rows["snr_db"].append(20.0)
            rows["moving"].append(True)
    prod = tmp_path / "prod.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("contacts", "contacts").append(
            **{k: np.array(v) for k, v in rows.items()},
            waveform=np.array([b"cw"] * len(rows["time"])))
    return str(rec), str(prod), truth[:, -1]
