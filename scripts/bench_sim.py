"""Benchmark of the simulator: 64 channels at 5120 Hz, two moving sources with three
tonals and a broadband band each, ambient noise, moving ownship.

Prints the real-time factor (simulated seconds per wall-clock second) of the full simulator
(``Simulator.render`` over the whole duration, and ``simulate`` to an HDF5 file), the share of
each part, and the throughput of the numba propagation kernel against a plain-numpy
implementation of the same computation in this process.

Then the demo scenario (arrayproc/data/scenarios/towed_passive.toml) free field and with
first-order image-source multipath (surface + bottom, 3 paths per source), same process.

    .venv/bin/python scripts/bench_sim.py [--duration 60] [--threads 2] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np


def bench_scenario(duration: float) -> dict:
    return {
        "recording": {"fs": 5120.0, "duration": duration, "sound_speed": 1500.0, "seed": 1,
                      "chunk": 8192},
        "array": {"type": "line", "n": 64, "spacing": 0.36, "depth": 100.0},
        "ownship": {"start": [0.0, 0.0], "leg": [
            {"course": 140.0, "speed_kn": 5.0, "duration": duration / 2},
            {"course": 20.0, "speed_kn": 5.0, "duration": duration / 2,
             "turn_rate": max(0.5, 250.0 / duration)}]},
        "source": [
            {"name": "one", "start": [5000.0, 800.0], "depth": 5.0, "course": 220.0,
             "speed_kn": 5.0,
             "tonals": [{"freq": 120.0, "level_db": 150.0}, {"freq": 355.0, "level_db": 145.0},
                        {"freq": 910.0, "level_db": 140.0}],
             "broadband": {"band": [50.0, 2000.0], "model": "speed"}},
            {"name": "two", "start": [-3000.0, -2500.0], "depth": 60.0, "course": 45.0,
             "speed_kn": 8.0,
             "tonals": [{"freq": 88.0, "level_db": 140.0}, {"freq": 470.0, "level_db": 138.0},
                        {"freq": 1500.0, "level_db": 135.0}],
             "broadband": {"band": [100.0, 2200.0], "level_db": 115.0}},
        ],
        "noise": {"level_db": 60.0},
    }


#: first-order image sources added to the demo scenario (make demo): pressure-release
#: surface and a 200 m flat bottom with 6 dB loss per bounce (3 paths per source)
DEMO_MULTIPATH = {"surface": True, "bottom_depth": 200.0, "bottom_loss_db": 6.0, "order": 1}


def demo_realtime(duration: float) -> dict:
    """Render speed (x real time, wall and CPU) of the demo scenario, free field and with
    first-order multipath, measured one after the other in this process."""
    from arrayproc.config import read_toml
    from arrayproc.sim.run import Simulator
    from arrayproc.sim.scenario import parse_scenario

    path = Path(__file__).resolve().parents[1] / "arrayproc/data/scenarios/towed_passive.toml"
    rows = {}
    for label, mp in (("free_field", None), ("multipath_order1", DEMO_MULTIPATH)):
        data, _ = read_toml(path, "scenario")
        data["recording"]["duration"] = duration
        if mp is not None:
            data["propagation"]["multipath"] = dict(mp)
        sim = Simulator(parse_scenario(data, str(path), base_dir=path.parent))
        sim.render(0, 2048)  # compile / warm caches
        n, chunk = sim.n_samples, sim.s.chunk
        t0, c0 = time.perf_counter(), time.process_time()
        for k in range(0, n, chunk):
            sim.render(k, min(n, k + chunk))
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        rows[label] = {"paths_per_source": len(sim.images), "wall_s": wall, "cpu_s": cpu,
                       "realtime_wall": duration / wall, "realtime_cpu": duration / cpu}
    return rows


def numpy_propagation(sim, k0: int, k1: int) -> np.ndarray:
    """Plain-numpy version of the propagation kernel: per element, exact τ by fixed-point
    iteration on the Taylor-expanded source, table interpolation by fancy indexing."""
    from arrayproc.sim.propagation import retarded_time
    t = (k0 + np.arange(k1 - k0)) / sim.fs
    pose = sim.pose(t)
    out = np.zeros((t.size, sim.n_channels))
    table = sim.table
    ntap = table.shape[1]
    M = table.shape[0] - 1
    for mover, sig, _ in sim.sources:
        tau_r = retarded_time(pose.ref3, t, mover, sim.c)
        p, v, a = mover.state3(t - tau_r)
        m0 = int(np.floor((t[0] - tau_r.max() - 0.1) * sim.fs_src)) - 10
        m1 = int(np.ceil((t[-1] - tau_r.min() + 0.1) * sim.fs_src)) + 10
        buf = sig.block(m0, m1)
        by = sim.body[:, 1][None, :] + pose.lateral[:, None]
        bx = sim.body[:, 0][None, :]
        ex = pose.rpos[:, :1] + bx * pose.sin_h[:, None] + by * pose.cos_h[:, None]
        ey = pose.rpos[:, 1:] + bx * pose.cos_h[:, None] - by * pose.sin_h[:, None]
        ez = pose.rdepth[:, None] + sim.body[:, 2][None, :]
        tau = np.repeat(tau_r[:, None], sim.n_channels, axis=1)
        for _ in range(6):
            d = tau - tau_r[:, None]
            sx = p[:, :1] - v[:, :1] * d + 0.5 * a[:, :1] * d * d
            sy = p[:, 1:2] - v[:, 1:2] * d + 0.5 * a[:, 1:2] * d * d
            sz = p[:, 2:] - v[:, 2:] * d + 0.5 * a[:, 2:] * d * d
            tau = np.sqrt((ex - sx) ** 2 + (ey - sy) ** 2 + (ez - sz) ** 2) / sim.c
        u = (t[:, None] - tau - m0 / sim.fs_src) * sim.fs_src
        m = np.floor(u)
        pos = (u - m) * M
        ph = pos.astype(int)
        fr = pos - ph
        base = m.astype(int) - ntap // 2 + 1
        acc = np.zeros_like(u)
        for i in range(ntap):
            w = table[ph, i] + fr * (table[ph + 1, i] - table[ph, i])
            acc += w * buf[base + i]
        out += acc / (sim.c * tau)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    ap.add_argument("--threads", type=int, default=2, help="numba threads")
    ap.add_argument("--json", default=None, help="write the numbers here")
    args = ap.parse_args()
    import numba

    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    from arrayproc.sim.run import Simulator, simulate
    from arrayproc.sim.scenario import parse_scenario

    scen = parse_scenario(bench_scenario(args.duration), "bench")
    sim = Simulator(scen)
    sim.render(0, 2048)  # compile / warm caches
    n = sim.n_samples
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    for k in range(0, n, scen.chunk):
        sim.render(k, min(n, k + scen.chunk))
    t_render = time.perf_counter() - t0
    cpu_render = time.process_time() - c0

    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        simulate(parse_scenario(bench_scenario(args.duration), "bench"), Path(d) / "b.h5")
        t_file = time.perf_counter() - t0

    # numba kernel vs plain numpy on the same 1 s of data (propagation only, no noise)
    sim2 = Simulator(parse_scenario(bench_scenario(args.duration), "bench"))
    sim2.noise = None
    k0, k1 = 10 * 5120, 11 * 5120
    sim2.render(k0, k1)
    t0 = time.perf_counter()
    ref = sim2.render(k0, k1)
    t_numba = time.perf_counter() - t0
    t0 = time.perf_counter()
    npy = numpy_propagation(sim2, k0, k1)
    t_numpy = time.perf_counter() - t0
    agree = float(np.max(np.abs(ref - npy)) / np.max(np.abs(npy)))

    rows = {
        "channels": sim.n_channels, "fs": sim.fs, "duration_s": args.duration,
        "threads": numba.get_num_threads(), "cpu_count": os.cpu_count(),
        "render_s": t_render, "realtime_factor_render": args.duration / t_render,
        "render_cpu_s": cpu_render, "load_average_1min": load0,
        "file_s": t_file, "realtime_factor_file": args.duration / t_file,
        "propagation_numba_s_per_s": t_numba, "propagation_numpy_s_per_s": t_numpy,
        "numba_speedup_vs_numpy": t_numpy / t_numba, "numba_numpy_max_rel_diff": agree,
    }
    print(f"simulator benchmark: {sim.n_channels} ch, {sim.fs:g} Hz, 2 moving sources "
          f"(3 tonals + broadband each), noise, {args.duration:g} s, "
          f"{rows['threads']} numba threads")
    print(f"machine load average at start: {load0:.1f} on {os.cpu_count()} cores")
    print(f"{'what':<44}{'wall s':>10}{'x real time':>14}")
    print(f"{'render (chunks, in memory)':<44}{t_render:>10.2f}{args.duration / t_render:>14.1f}")
    print(f"{'  same, CPU time of the process':<44}{cpu_render:>10.2f}"
          f"{args.duration / cpu_render:>14.1f}")
    print(f"{'simulate to HDF5 (incl. truth, nav)':<44}{t_file:>10.2f}"
          f"{args.duration / t_file:>14.1f}")
    print(f"{'propagation 1 s, numba':<44}{t_numba:>10.3f}{1 / t_numba:>14.1f}")
    print(f"{'propagation 1 s, plain numpy':<44}{t_numpy:>10.3f}{1 / t_numpy:>14.1f}")
    print(f"numba / numpy speed-up {t_numpy / t_numba:.1f}x; max relative difference "
          f"{agree:.1e}")
    demo = demo_realtime(args.duration)
    rows["demo"] = demo
    print(f"demo scenario (towed_passive.toml: 32 ch, 2048 Hz, 2 sources + tow ship), "
          f"{args.duration:g} s:")
    for label, r in demo.items():
        print(f"  {label:<20} {r['paths_per_source']} path(s)/source: {r['wall_s']:.2f} s wall, "
              f"{r['realtime_wall']:.1f}x real time (CPU {r['realtime_cpu']:.1f}x)")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
