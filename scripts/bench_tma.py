#!/usr/bin/env python
"""Benchmark: batch TMA objectives, numba against plain numpy/scipy, in one process (issue 15).

1. One TD-TMA solution, 128 hydrophones × 100 snapshots (thesis eqs. (3.51)-(3.52)):
   :func:`arrayproc.track.batch.td_tma.solve_delays` (differential evolution over a
   population-vectorised numba objective, then ``least_squares``) against the same solver with
   the objective written in numpy (the population × snapshots × hydrophones array of ranges,
   as a careful user vectorises it). Same seed, same DE settings.
2. One compact-array grid search, 200 × 200 positions × 72 headings, 300 bearings, full
   (exponential) covariance (compact-array paper eq. (4)): the numba grid kernel against
   (a) numpy with the dense covariance: per heading, the (200, 200, 300) wrapped residuals
   whitened by the inverse Cholesky factor in one matrix product (BLAS), and
   (b) numpy with the same O(N) innovation form the kernel uses (the Markov structure of the
   exponential correlation), the best plain implementation we know.

Times are CPU seconds of this process (``time.process_time``; the machine is shared, so wall
time is not ours), numba on ``--threads`` threads (default 1). The kernels agree with the
references to rounding (checked here and in tests/track/batch).

    python scripts/bench_tma.py [--threads 1] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

import arrayproc.track.batch.td_tma as td
from arrayproc.track.batch import _kernels as K
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.fim import innovation_coefficients


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def td_cost_numpy(pop, tau, elem_x, elem_y, dz2, wmeas, w_over_c, ref, inv_c=0.0):
    """Plain numpy population cost of thesis eq. (3.52) (same arguments as the kernel)."""
    px = pop[0][:, None] + pop[2][:, None] * tau[None, :]
    py = pop[1][:, None] + pop[3][:, None] * tau[None, :]
    if inv_c > 0:   # source at the emission time (motion eq. M5), as the kernel
        ax, ay = px, py
        for _ in range(2):
            dt = np.sqrt((px - elem_x[None, :, ref]) ** 2 + (py - elem_y[None, :, ref]) ** 2
                         + dz2[None, :, ref]) * inv_c
            px = ax - pop[2][:, None] * dt
            py = ay - pop[3][:, None] * dt
    r = np.sqrt((px[..., None] - elem_x[None]) ** 2 + (py[..., None] - elem_y[None]) ** 2
                + dz2[None])
    e = wmeas[None] - w_over_c[None] * (r - r[..., ref:ref + 1])
    return np.einsum("pbn,pbn->p", e, e)


def compact_dense_numpy(xs, ys, hd, speed, tau, a, meas, chol_inv_t):
    out = np.empty((xs.size, ys.size, hd.size))
    for k, g in enumerate(hd):
        px = xs[:, None, None] + (speed * np.sin(g) * tau - a[0])[None, None, :]
        py = ys[None, :, None] + (speed * np.cos(g) * tau - a[1])[None, None, :]
        e = _wrap(meas - np.arctan2(px, py))
        z = e @ chol_inv_t
        out[:, :, k] = np.einsum("ijb,ijb->ij", z, z)
    return out


def compact_innov_numpy(xs, ys, hd, speed, tau, a, meas, phi, scale):
    out = np.empty((xs.size, ys.size, hd.size))
    for k, g in enumerate(hd):
        px = xs[:, None, None] + (speed * np.sin(g) * tau - a[0])[None, None, :]
        py = ys[None, :, None] + (speed * np.cos(g) * tau - a[1])[None, None, :]
        e = _wrap(meas - np.arctan2(px, py))
        w = e * scale
        w[..., 1:] -= (phi[1:] * scale[1:]) * e[..., :-1]
        out[:, :, k] = np.einsum("ijb,ijb->ij", w, w)
    return out


def cpu(f, *a, **k):
    t = time.process_time()
    r = f(*a, **k)
    return time.process_time() - t, r


def bench_td(seed: int) -> dict:
    tr = S.turn_track(duration=495.0, dt=5.0)           # 100 snapshots
    el = S.line_elements(tr, 128, 0.36)
    x = S.FIG_3_18_SOURCE
    rng = np.random.default_rng(seed)
    y = td.delay_model(x, tr.time, el, 0, 1500.0) + rng.normal(0, 1e-4, (tr.time.size, 128))
    kw = dict(heading_rad=tr.heading, seed=seed)
    td.solve_delays(tr.time[:10], y[:10], el[:10], 1e-4, heading_rad=tr.heading[:10])  # JIT
    t_nb, s_nb = cpu(td.solve_delays, tr.time, y, el, 1e-4, **kw)
    orig = td.td_cost_population
    td.td_cost_population = td_cost_numpy
    try:
        t_np, s_np = cpu(td.solve_delays, tr.time, y, el, 1e-4, **kw)
    finally:
        td.td_cost_population = orig
    # one population evaluation alone (80 members)
    pop = np.ascontiguousarray(np.vstack([rng.uniform(-5e3, 5e3, (2, 80)),
                                          rng.uniform(-10, 10, (2, 80))]))
    w = np.full(y.shape, 1e4)
    w[:, 0] = 0
    args = (pop, tr.time, np.ascontiguousarray(el[..., 0]), np.ascontiguousarray(el[..., 1]),
            np.zeros(y.shape), w * y, w / 1500.0, 0)
    n = 20
    t_k = cpu(lambda: [K.td_cost_population(*args) for _ in range(n)])[0] / n
    t_r = cpu(lambda: [td_cost_numpy(*args) for _ in range(n)])[0] / n
    diff = float(np.max(np.abs(K.td_cost_population(*args) / td_cost_numpy(*args) - 1)))
    return {"snapshots": int(tr.time.size), "hydrophones": 128,
            "numba_cpu_s": t_nb, "numpy_cpu_s": t_np, "ratio": t_np / t_nb,
            "state_numba": s_nb.state.tolist(), "state_numpy": s_np.state.tolist(),
            "objective_numba_ms": 1e3 * t_k, "objective_numpy_ms": 1e3 * t_r,
            "objective_ratio": t_r / t_k, "objective_max_rel_diff": diff}


def bench_compact(seed: int) -> dict:
    rng = np.random.default_rng(seed)
    t = np.arange(300) * 4.0
    meas = rng.uniform(-np.pi, np.pi, 300)
    xs = np.linspace(-5000, 5000, 200)
    ys = np.linspace(-5000, 5000, 200)
    hd = np.deg2rad(np.arange(72) * 5.0)
    a = np.zeros(2)
    sig, corr, v = np.deg2rad(2.0), 30.0, 7.3
    phi, scale = innovation_coefficients(t, sig, corr)
    K.compact_grid_cost(xs[:2], ys[:2], hd[:2], v, t, a, meas, phi, scale)   # JIT
    t_nb, c_nb = cpu(K.compact_grid_cost, xs, ys, hd, v, t, a, meas, phi, scale)
    cov = sig**2 * np.exp(-np.abs(t[:, None] - t[None, :]) / corr)
    li_t = np.ascontiguousarray(np.linalg.inv(np.linalg.cholesky(cov)).T)
    t_dense, c_dense = cpu(compact_dense_numpy, xs, ys, hd, v, t, a, meas, li_t)
    t_inn, c_inn = cpu(compact_innov_numpy, xs, ys, hd, v, t, a, meas, phi, scale)
    return {"grid": [200, 200, 72], "bearings": 300, "numba_cpu_s": t_nb,
            "numpy_dense_cpu_s": t_dense, "numpy_innovation_cpu_s": t_inn,
            "ratio_dense": t_dense / t_nb, "ratio_innovation": t_inn / t_nb,
            "max_rel_diff_dense": float(np.max(np.abs(c_nb / c_dense - 1))),
            "max_rel_diff_innovation": float(np.max(np.abs(c_nb / c_inn - 1)))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    numba.set_num_threads(a.threads)
    res = {"threads": a.threads, "td": bench_td(a.seed)}
    r = res["td"]
    print(f"TD-TMA solution 128 x {r['snapshots']}: numba {r['numba_cpu_s']:.2f} s, numpy "
          f"{r['numpy_cpu_s']:.2f} s CPU -> {r['ratio']:.1f}x; objective alone "
          f"{r['objective_numba_ms']:.2f} vs {r['objective_numpy_ms']:.2f} ms -> "
          f"{r['objective_ratio']:.1f}x (max rel diff {r['objective_max_rel_diff']:.1e})",
          flush=True)
    res["compact"] = bench_compact(a.seed)
    r = res["compact"]
    print(f"compact grid 200x200x72, 300 bearings, full C: numba {r['numba_cpu_s']:.2f} s; "
          f"numpy dense {r['numpy_dense_cpu_s']:.2f} s -> {r['ratio_dense']:.1f}x; numpy "
          f"innovation form {r['numpy_innovation_cpu_s']:.2f} s -> "
          f"{r['ratio_innovation']:.1f}x (max rel diff {r['max_rel_diff_dense']:.1e}, "
          f"{r['max_rel_diff_innovation']:.1e})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
