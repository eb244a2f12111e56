#!/usr/bin/env python
"""Benchmark: batch TMA, numba against plain numpy/scipy, in one process.

1. One TD-TMA solution, 128 hydrophones × 100 snapshots (thesis eqs. (3.51)-(3.52)):
   :func:`arrayproc.track.batch.td_tma.solve_delays` — differential evolution
   (:mod:`arrayproc.track.batch.evolution`, whole-population generations) over the
   population-vectorised numba objective, a ``leastsq`` polish whose residuals and
   Jacobian come from one numba kernel, the FIM as the weighted Jacobian's Gram matrix and
   the plane-wave bounds vectorised — against the same solver with the objective, the
   residuals and the Jacobian written in numpy as a careful user writes them (the population
   × snapshots × hydrophones array of ranges and one ``einsum``; ``delay_model`` and
   ``fim.td_jacobian``). Same seed, same settings. numba on 1 and on 2 threads (``prange``
   over the population and over the snapshots).
2. One compact-array grid search, 200 × 200 positions × 72 headings, 300 bearings, full
   (exponential) covariance (compact-array paper eq. (4)): the numba grid kernel against
   (a) numpy with the dense covariance: per heading, the (200, 200, 300) wrapped residuals
   whitened by the inverse Cholesky factor in one matrix product (BLAS), and
   (b) numpy with the same O(N) innovation form the kernel uses (the Markov structure of the
   exponential correlation), the best plain implementation we know; numba on 1 and 2 threads.

CPU seconds (``time.process_time``, all threads of this process) and wall seconds
(``time.perf_counter``) of each run, and the load average (``os.getloadavg``) before and
after: the machine is shared, so wall times depend on the others' load. The kernels agree
with the references to rounding (checked here and in tests/track/batch).

    python scripts/bench_tma.py [--threads 1 2] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numba
import numpy as np

import arrayproc.track.batch.result as R
import arrayproc.track.batch.td_tma as td
from arrayproc.track.batch import _kernels as K
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.fim import innovation_coefficients, td_jacobian


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


def td_model_jacobian_numpy(state, tau, elem_x, elem_y, dz2, ref, c, retarded):
    """numpy twin of the kernel: ``delay_model`` and ``fim.td_jacobian``."""
    el = np.stack([elem_x, elem_y], -1)
    dz = np.sqrt(dz2) if np.any(dz2) else None
    return (td.delay_model(state, tau, el, ref, c, retarded, dz),
            td_jacobian(state, tau, el, ref, c, retarded, dz))


def cpu(f, *a, **k):
    """(CPU s, wall s, result) of one call."""
    t, w = time.process_time(), time.perf_counter()
    r = f(*a, **k)
    return time.process_time() - t, time.perf_counter() - w, r


class Phases:
    """CPU/wall time spent in the named module functions during a solution."""

    NAMES = ((R, "evolve"), (R, "leastsq"), (td, "td_cost_population"),
             (td, "td_model_jacobian"), (td, "plane_wave_directions"), (td, "finish_solution"))

    def __enter__(self):
        self.acc: dict[str, list[float]] = {}
        self.orig = []
        for mod, name in self.NAMES:
            f = getattr(mod, name)
            self.orig.append((mod, name, f))

            def timed(*a, _f=f, _n=name, **k):
                t, w = time.process_time(), time.perf_counter()
                try:
                    return _f(*a, **k)
                finally:
                    acc = self.acc.setdefault(_n, [0.0, 0.0, 0])
                    acc[0] += time.process_time() - t
                    acc[1] += time.perf_counter() - w
                    acc[2] += 1
            setattr(mod, name, timed)
        return self

    def __exit__(self, *exc):
        for mod, name, f in self.orig:
            setattr(mod, name, f)


def _numpy_solver():
    """Swap the numba kernels of solve_delays for their numpy twins (restored on exit)."""
    class Swap:
        def __enter__(self):
            self.o = td.td_cost_population, td.td_model_jacobian
            td.td_cost_population, td.td_model_jacobian = td_cost_numpy, td_model_jacobian_numpy

        def __exit__(self, *exc):
            td.td_cost_population, td.td_model_jacobian = self.o
    return Swap()


def bench_td(seed: int, threads: list[int], repeats: int) -> dict:
    tr = S.turn_track(duration=495.0, dt=5.0)           # 100 snapshots
    el = S.line_elements(tr, 128, 0.36)
    x = S.FIG_3_18_SOURCE
    rng = np.random.default_rng(seed)
    y = td.delay_model(x, tr.time, el, 0, 1500.0) + rng.normal(0, 1e-4, (tr.time.size, 128))
    kw = dict(heading_rad=tr.heading, seed=seed)
    td.solve_delays(tr.time[:10], y[:10], el[:10], 1e-4, heading_rad=tr.heading[:10])  # JIT
    out: dict = {"snapshots": int(tr.time.size), "hydrophones": 128, "numba": {}}
    for n in threads:
        numba.set_num_threads(n)
        runs = []
        for _ in range(repeats):
            with Phases() as ph:
                c, w, sol = cpu(td.solve_delays, tr.time, y, el, 1e-4, **kw)
            runs.append((c, w, sol, ph.acc))
        c, w, sol, acc = min(runs, key=lambda r: r[1])
        out["numba"][n] = {"cpu_s": c, "wall_s": w, "cpu_s_all": [r[0] for r in runs],
                           "wall_s_all": [r[1] for r in runs], "state": sol.state.tolist(),
                           "phases": {k: {"cpu_s": v[0], "wall_s": v[1], "calls": v[2]}
                                      for k, v in acc.items()}}
    numba.set_num_threads(max(threads))
    with _numpy_solver(), Phases() as ph:
        c, w, sol = cpu(td.solve_delays, tr.time, y, el, 1e-4, **kw)
    out["numpy"] = {"cpu_s": c, "wall_s": w, "state": sol.state.tolist(),
                    "phases": {k: {"cpu_s": v[0], "wall_s": v[1], "calls": v[2]}
                               for k, v in ph.acc.items()}}
    # one population evaluation alone (80 members), and the polish kernel alone
    pop = np.ascontiguousarray(np.vstack([rng.uniform(-5e3, 5e3, (2, 80)),
                                          rng.uniform(-10, 10, (2, 80))]))
    wt = np.full(y.shape, 1e4)
    wt[:, 0] = 0
    ex, ey = np.ascontiguousarray(el[..., 0]), np.ascontiguousarray(el[..., 1])
    args = (pop, tr.time, ex, ey, np.zeros(y.shape), wt * y, wt / 1500.0, 0)
    margs = (x, tr.time, ex, ey, np.zeros(y.shape), 0, 1500.0, False)
    n_rep = 20

    def per_call(f, *args):
        f(*args)  # compile this signature (the default argument left out) outside the timing
        c, w, _ = cpu(lambda: [f(*args) for _ in range(n_rep)])
        return {"cpu_ms": 1e3 * c / n_rep, "wall_ms": 1e3 * w / n_rep}

    obj = {}
    for n in threads:
        numba.set_num_threads(n)
        obj[n] = {"objective": per_call(K.td_cost_population, *args),
                  "model_jacobian": per_call(K.td_model_jacobian, *margs)}
    out["objective_numpy"] = per_call(td_cost_numpy, *args)
    out["model_jacobian_numpy"] = per_call(td_model_jacobian_numpy, *margs)
    out["objective_numba"] = obj
    out["objective_max_rel_diff"] = float(np.max(np.abs(K.td_cost_population(*args)
                                                        / td_cost_numpy(*args) - 1)))
    h, j = K.td_model_jacobian(*margs)
    h2, j2 = td_model_jacobian_numpy(*margs)
    out["model_jacobian_max_rel_diff"] = float(max(np.max(np.abs(h - h2)) / np.max(np.abs(h2)),
                                                   np.max(np.abs(j - j2)) / np.max(np.abs(j2))))
    return out


def bench_compact(seed: int, threads: list[int], dense: bool = True) -> dict:
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
    out: dict = {"grid": [200, 200, 72], "bearings": 300, "numba": {}}
    c_nb = None
    for n in threads:
        numba.set_num_threads(n)
        c, w, c_nb = cpu(K.compact_grid_cost, xs, ys, hd, v, t, a, meas, phi, scale)
        out["numba"][n] = {"cpu_s": c, "wall_s": w}
    if dense:
        cov = sig**2 * np.exp(-np.abs(t[:, None] - t[None, :]) / corr)
        li_t = np.ascontiguousarray(np.linalg.inv(np.linalg.cholesky(cov)).T)
        c, w, c_dense = cpu(compact_dense_numpy, xs, ys, hd, v, t, a, meas, li_t)
        out["numpy_dense"] = {"cpu_s": c, "wall_s": w}
        out["max_rel_diff_dense"] = float(np.max(np.abs(c_nb / c_dense - 1)))
    c, w, c_inn = cpu(compact_innov_numpy, xs, ys, hd, v, t, a, meas, phi, scale)
    out["numpy_innovation"] = {"cpu_s": c, "wall_s": w}
    out["max_rel_diff_innovation"] = float(np.max(np.abs(c_nb / c_inn - 1)))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2],
                    help="numba thread counts to measure (default 1 2)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=3,
                    help="TD solutions per thread count (the fastest wall time is kept)")
    ap.add_argument("--skip-compact", action="store_true")
    ap.add_argument("--skip-dense", action="store_true",
                    help="compact grid: leave out the dense-covariance numpy reference (5 min)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    if any(n < 1 or n > numba.config.NUMBA_NUM_THREADS for n in a.threads):
        ap.error(f"--threads must be within 1..{numba.config.NUMBA_NUM_THREADS}")
    res: dict = {"threads": a.threads, "cores": os.cpu_count(), "load_before": os.getloadavg()}
    res["td"] = r = bench_td(a.seed, a.threads, a.repeats)
    npy = r["numpy"]
    print(f"TD-TMA solution 128 x {r['snapshots']}: numpy {npy['cpu_s']:.2f} s CPU, "
          f"{npy['wall_s']:.2f} s wall", flush=True)
    for n, m in r["numba"].items():
        ph = m["phases"]
        de, obj = ph["evolve"], ph["td_cost_population"]
        ls, mj = ph["leastsq"], ph["td_model_jacobian"]
        print(f"  numba {n} thread(s): {m['cpu_s']:.3f} s CPU, {m['wall_s']:.3f} s wall -> "
              f"{npy['wall_s'] / m['wall_s']:.1f}x wall, {npy['cpu_s'] / m['cpu_s']:.1f}x CPU; "
              f"wall: DE {de['wall_s']:.3f} s (objective {obj['wall_s']:.3f} s in "
              f"{obj['calls']} calls), polish {ls['wall_s']:.3f} s (kernel "
              f"{mj['wall_s']:.3f} s in {mj['calls']} calls)", flush=True)
    on, mn = r["objective_numpy"], r["model_jacobian_numpy"]
    for n, o in r["objective_numba"].items():
        ob, mj = o["objective"], o["model_jacobian"]
        print(f"  objective 80 states, numba {n} thread(s): {ob['cpu_ms']:.2f} ms CPU "
              f"({ob['wall_ms']:.2f} wall) vs numpy {on['cpu_ms']:.2f} ({on['wall_ms']:.2f}); "
              f"residuals + Jacobian {mj['cpu_ms']:.2f} ({mj['wall_ms']:.2f}) vs "
              f"{mn['cpu_ms']:.2f} ({mn['wall_ms']:.2f}) ms")
    print(f"  max rel diff: objective {r['objective_max_rel_diff']:.1e}, model/Jacobian "
          f"{r['model_jacobian_max_rel_diff']:.1e}", flush=True)
    if not a.skip_compact:
        res["compact"] = r = bench_compact(a.seed, a.threads, not a.skip_dense)
        inn = r["numpy_innovation"]
        for n, m in r["numba"].items():
            dense = ""
            if "numpy_dense" in r:
                dn = r["numpy_dense"]
                dense = (f"numpy dense {dn['cpu_s']:.1f} / {dn['wall_s']:.1f} s -> "
                         f"{dn['wall_s'] / m['wall_s']:.1f}x wall; ")
            print(f"compact grid 200x200x72, 300 bearings, full C: numba {n} thread(s) "
                  f"{m['cpu_s']:.2f} s CPU / {m['wall_s']:.2f} s wall; {dense}numpy innovation"
                  f" {inn['cpu_s']:.1f} / {inn['wall_s']:.1f} s -> "
                  f"{inn['wall_s'] / m['wall_s']:.1f}x wall, {inn['cpu_s'] / m['cpu_s']:.1f}x CPU")
        dd = r.get("max_rel_diff_dense")
        print(f"  max rel diff: dense {'skipped' if dd is None else f'{dd:.1e}'}, "
              f"innovation {r['max_rel_diff_innovation']:.1e}")
    res["load_after"] = os.getloadavg()
    print(f"load average before {res['load_before']}, after {res['load_after']}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
