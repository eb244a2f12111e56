"""Products for the report tests: a short simulated towed-array run (BTR, LOFAR, bearings,
truth) and hand-written groups of every other kind the report shows."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.io.products import ProductsWriter

#: Seconds of the towed scenario the tests simulate.
SIM_SECONDS = 12.0


def passive_run(d: Path) -> Path:
    """Simulate the first SIM_SECONDS of the bundled towed scenario and process it with the
    bundled passive chain; returns the products file (its recording holds the truth)."""
    from arrayproc.app import commands
    from arrayproc.data import data_path
    rec, prod = d / "towed.h5", d / "towed_products.h5"
    commands.simulate(str(data_path() / "scenarios" / "towed_passive.toml"), str(rec),
                      duration=SIM_SECONDS, seed=1)
    commands.process(str(rec), str(data_path() / "chains" / "towed_passive.toml"), str(prod))
    return prod


def other_kinds(d: Path, seed: int = 4) -> list[Path]:
    """A tracks file, a TMA file, and a products file with contacts, range-Doppler maps,
    delays and positions, all written by hand (seeded)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 12.0, 1.0)
    n = t.size
    tracks = d / "tracks.h5"
    with ProductsWriter(tracks) as w:
        cov = np.tile(np.diag([1e4, 4e4, 1.0, 1.0]), (2 * n, 1, 1))
        w.group("track", "tracks").append(
            time=np.r_[t, t], track_id=np.r_[np.zeros(n, int), np.ones(n, int)],
            x=np.r_[100 * t, -2000 + 0 * t], y=np.r_[3000 + 0 * t, 2000 - 50 * t],
            vx=np.r_[100 + 0 * t, 0 * t], vy=np.r_[0 * t, -50 + 0 * t], cov=cov,
            own_x=np.r_[5 * t, 5 * t], own_y=np.zeros(2 * n))
    tma = d / "tma.h5"
    with ProductsWriter(tma) as w:
        c = np.diag([4e4, 9e4, 1.0, 1.0])[None]
        w.group("tma", "tma").append(
            t0=np.array([0.0]), t1=np.array([11.0]), method=np.array([b"bearings"]),
            x=np.array([0.0]), y=np.array([3000.0]), vx=np.array([100.0]),
            vy=np.array([0.0]), cov=c, crlb=c, cost=np.array([1.0]),
            fim_cond=np.array([10.0]), heading_deg=np.array([90.0]),
            speed_mps=np.array([100.0]))
    other = d / "other.h5"
    with ProductsWriter(other, attrs={"units": "Pa"}) as w:
        m = 3
        rd = rng.standard_normal((m, 20, 64)) - 30.0
        rd[:, 10, 30] = 0.0
        g = w.group("matched_filter", "range_doppler")
        g.append(time=np.arange(m, dtype=float), ping=np.arange(m),
                 cone_deg=np.array([30.0, 60.0, 90.0]), level_db=rd,
                 range_m=np.tile(np.linspace(1000, 2000, 64), (m, 1)),
                 range_rate_mps=np.tile(np.linspace(-10, 10, 20), (m, 1)))
        k = 40
        w.group("cfar", "contacts").append(
            time=rng.uniform(0, 12, k), ping=rng.integers(0, m, k),
            range_m=rng.uniform(1000, 2000, k), cone_deg=rng.uniform(0, 180, k),
            bearing_port_deg=rng.uniform(0, 360, k), bearing_stbd_deg=rng.uniform(0, 360, k),
            range_rate_mps=rng.normal(0, 3, k), absolute_doppler_mps=rng.normal(0, 3, k),
            snr_db=rng.uniform(10, 25, k), moving=rng.random(k) > 0.5,
            waveform=np.array([b"cw"] * k))
        ch = 4
        tau = rng.normal(0, 1e-3, (n, ch))
        tau[:, 0] = 0.0
        w.group("tde", "delays", reference=0).append(
            time=t, tau=tau, sigma=np.full((n, ch), 5e-5), corr=np.full((n, ch), 0.8))
        w.group("localise", "positions").append(
            time=t, x=rng.normal(0, 5, n), y=rng.normal(0, 5, n), z=rng.normal(5, 1, n),
            cov=np.tile(np.diag([4.0, 1.0, 1.0]), (n, 1, 1)), tdoa_rms_s=np.full(n, 1e-5),
            n_used=np.full(n, 6))
    return [tracks, tma, other]
