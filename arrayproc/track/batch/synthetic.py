"""Measurement-level files of a towed line array and constant-velocity sources: a recording
(navigation, element positions, truth) and a products file of the cone angles (and the tonal
frequencies) the array measures, for checking the TMA and the per-track TMA end to end
against truth.

Each row is what a moving line array measures of a source at a snapshot time ``t``: the
source at its emission time (``t − s``, ``|p(t) − v s − o| = c s`` solved in closed form),
the cone angle of that emission point seen from the array's phase centre and made apparent by
the array's motion along its axis (:mod:`.motion`, eq. (M3)), plus Gaussian noise; the
received frequency ``f0 (1 − ṙ/c)`` of that emission point (:func:`.bf_tma.doppler_factor`,
eq. (BF1)) plus noise.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass

import h5py
import numpy as np

from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import Recording
from arrayproc.io.recording_writer import RecordingWriter

from .bf_tma import doppler_factor
from .motion import axial_speed, nav_velocity
from .scenarios import OwnTrack

__all__ = ["Source", "emission_lag", "write_line_array_scenario", "with_measurements"]


@dataclass(frozen=True)
class Source:
    """A constant-velocity source: ``state`` [x, y, vx, vy] at t = 0 (m, m/s), the rest
    frequency ``f0_hz`` of its tonal (None: broadband only) and its detection probability."""

    state: np.ndarray
    f0_hz: float | None = None
    p_detect: float = 1.0


def emission_lag(p_rx: np.ndarray, v: np.ndarray, obs: np.ndarray, c: float) -> np.ndarray:
    """``s > 0`` with ``|p_rx − v s − obs| = c s`` (rows of (n, 2) arrays): the travel time of
    what arrives at ``obs`` from a source at ``p_rx`` moving at ``v`` (a quadratic in ``s``)."""
    g = p_rx - obs
    a = np.sum(v * v, axis=-1) - c * c
    b = -2.0 * np.sum(g * v, axis=-1)
    return (-b - np.sqrt(b * b - 4 * a * np.sum(g * g, axis=-1))) / (2 * a)


def write_line_array_scenario(folder: str, nav: OwnTrack, sources: dict[str, Source],
                              times: np.ndarray, sigma_cone_deg: float, sigma_freq_hz: float,
                              seed: int, n_elements: int = 16, spacing_m: float = 0.75,
                              sound_speed: float = 1500.0, lines: bool = False
                              ) -> tuple[str, str, dict[str, np.ndarray]]:
    """Write ``rec.h5`` and ``prod.h5`` in ``folder`` (module doc).

    Parameters
    ----------
    folder : str
        Output directory.
    nav : OwnTrack
        Ownship samples, fine enough that interpolation is exact (e.g. 1 s).
    sources : dict
        Name → :class:`Source`.
    times : (B,) array_like
        Snapshot times (s), each with one bearings row per detected source.
    sigma_cone_deg, sigma_freq_hz : float
        Noise σ of the cone angles and of the frequencies.
    seed : int
        Seed of the noise and of the detections.
    n_elements, spacing_m : int, float
        The line array trailing the ownship position.
    sound_speed : float
        m/s.
    lines : bool
        Also write a ``lines`` group (the rows of the sources with a tonal, with
        ``freq_hz``).

    Returns
    -------
    rec_path, products_path : str
    rows : dict
        Per bearings row: ``source`` (index into ``sources``' order), ``freq_hz`` (NaN for a
        source without a tonal), ``time``.
    """
    rng = np.random.default_rng(seed)
    pos = np.zeros((n_elements, 3))
    pos[:, 0] = -np.arange(n_elements) * spacing_m
    rec = os.path.join(folder, "rec.h5")
    with RecordingWriter(rec, 100.0, n_elements, positions=pos,
                         start_time="2026-01-01T00:00:00Z") as w:
        w.append(np.zeros((10, n_elements), np.float32))
        w.set_nav(nav.time, nav.position, np.rad2deg(nav.heading) % 360.0)
        for name, s in sources.items():
            st = np.asarray(s.state, float)
            w.write_group(f"truth/sources/{name}",
                          {"time": nav.time, "position": st[None, :2] + nav.time[:, None]
                           * st[None, 2:]}, attrs={"kind": "source"})
    t = np.asarray(times, float)
    with Recording(rec) as r:
        poses = r.poses(t)
        vel = nav_velocity(r.nav, t)
    centre = np.stack([p.elements[:, :2].mean(0) for p in poses])
    hd = np.deg2rad([p.heading for p in poses])
    v_ax = axial_speed(vel, hd)
    c = float(sound_speed)
    cols: dict[str, list] = {k: [] for k in ("time", "cone", "hd", "src", "freq")}
    for i, s in enumerate(sources.values()):
        st = np.asarray(s.state, float)
        p_rx = st[None, :2] + t[:, None] * st[None, 2:]
        d = p_rx - emission_lag(p_rx, st[None, 2:], centre, c)[:, None] * st[None, 2:] - centre
        rel = np.angle(np.exp(1j * (np.arctan2(d[:, 0], d[:, 1]) - hd)))
        ct = np.cos(np.abs(rel))
        cone = np.arccos(np.clip(ct / (1 + v_ax / c * ct), -1.0, 1.0)) \
            + rng.normal(0, np.deg2rad(sigma_cone_deg), t.size)
        f = (np.full(t.size, np.nan) if s.f0_hz is None else
             s.f0_hz * doppler_factor(st, t, centre, vel, c, retarded=True)
             + rng.normal(0, sigma_freq_hz, t.size))
        det = rng.random(t.size) < s.p_detect
        for k, v in (("time", t), ("cone", np.abs(cone)), ("hd", hd), ("src", np.full(t.size, i)),
                     ("freq", f)):
            cols[k].append(v[det])
    a = {k: np.concatenate(v) for k, v in cols.items()}
    order = np.lexsort((a["src"], a["time"]))
    a = {k: v[order] for k, v in a.items()}
    n = a["time"].size
    cone_deg = np.rad2deg(a["cone"])
    port = np.rad2deg(a["hd"] - a["cone"]) % 360
    stbd = np.rad2deg(a["hd"] + a["cone"]) % 360
    prod = os.path.join(folder, "prod.h5")
    with ProductsWriter(prod, source=rec) as w:
        w.group("bearings", "bearings").append(
            time=a["time"], cone_deg=cone_deg, bearing_port_deg=port, bearing_stbd_deg=stbd,
            level_db=np.full(n, 90.0), snr_db=np.full(n, 20.0), freq_lo=np.full(n, 100.0),
            freq_hi=np.full(n, 900.0), spl_db=np.full(n, 90.0))
        tonal = np.isfinite(a["freq"])
        if lines and tonal.any():
            m = int(tonal.sum())
            w.group("lines", "lines").append(
                time=a["time"][tonal], cone_deg=cone_deg[tonal], bearing_port_deg=port[tonal],
                bearing_stbd_deg=stbd[tonal], freq_hz=a["freq"][tonal],
                bandwidth_hz=np.full(m, 0.1), level_db=np.full(m, 90.0),
                snr_db=np.full(m, 15.0), beam=np.zeros(m, np.int64))
    return rec, prod, {"source": a["src"].astype(np.int64), "freq_hz": a["freq"],
                       "time": a["time"]}


def with_measurements(tracks: str | os.PathLike, out: str | os.PathLike, prod: str,
                      freq: np.ndarray) -> None:
    """Copy a tracks file writing, for every point, the columns of a lines+bearings tracks
    file with a frequency on every row: its measurement (``meas_cone_deg``, ``meas_port_deg``,
    ``meas_stbd_deg``), its frequency ``meas_freq_hz`` (``freq`` of the bearings row it used,
    or the ``freq_hz`` of the line it used), ``meas_tonal`` (slot 0) and ``row_kind`` (1 lines;
    −1 coasted); ``measurements`` = ``lines+bearings``. A point's ``row`` indexes the products'
    ``bearings`` group, or its ``lines`` group where the tracker wrote ``row_kind`` = 1 (a
    lines+bearings tracker); columns it already holds are replaced. For checking the
    per-track TMA on measurement-level tracks as the lines+bearings tracker writes them
    (:mod:`.per_track`)."""
    shutil.copy(tracks, out)
    keys = ("cone_deg", "bearing_port_deg", "bearing_stbd_deg")
    with h5py.File(prod, "r") as p:
        b = {k: p[f"bearings/{k}"][()] for k in keys}
        b["freq_hz"] = np.asarray(freq, float)
        ln = ({k: p[f"lines/{k}"][()] for k in keys + ("freq_hz",)} if "lines" in p else None)
    with h5py.File(out, "a") as f:
        g = f["tracks"]
        r = g["row"][()]
        kind = g["row_kind"][()] if "row_kind" in g else np.where(r >= 0, 0, -1)
        on = (r >= 0) & (kind >= 0)
        is_line = on & (kind == 1)
        if is_line.any() and ln is None:
            raise ValueError(f"{tracks}: points updated by lines but {prod} has no lines group")
        rs = np.maximum(r, 0)

        def pick(col: str) -> np.ndarray:
            v = np.where(on, b[col][np.where(is_line, 0, rs)], np.nan)
            if is_line.any():
                v = np.where(is_line, ln[col][np.where(is_line, rs, 0)], v)
            return v

        cols = {"meas_cone_deg": pick("cone_deg"), "meas_port_deg": pick("bearing_port_deg"),
                "meas_stbd_deg": pick("bearing_stbd_deg"), "meas_freq_hz": pick("freq_hz"),
                "meas_tonal": np.where(on, 0, -1).astype(np.int64),
                "row_kind": np.where(on, 1, -1).astype(np.int8)}
        for k, v in cols.items():
            if k in g:
                del g[k]
            g.create_dataset(k, data=v)
        g.attrs["measurements"] = "lines+bearings"
