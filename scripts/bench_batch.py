#!/usr/bin/env python
"""Benchmark of ``arrayproc batch`` on dask.distributed (docs/performance/batch.md).

    .venv/bin/python scripts/bench_batch.py [--dir DIR] [--seconds 60] [--channels 64]
        [--recordings 4] [--chain towed_passive] [--repeats 2] [--mc-runs 500] [--no-mc]
        [--no-dask-defaults] [--json OUT]

1. Simulates ``--recordings`` recordings (the bundled towed-passive scenario with its line
   array widened to ``--channels`` hydrophones, ``--seconds`` s each, seeds 1, 2, …).
2. Direct: each file through the chain in this process, as ``arrayproc process`` does (open,
   :func:`run_chain`, products written), after one warm-up run: the reference time.
3. Batch: the same files as one batch on a LocalCluster of 1 worker (2 threads, the same as
   the direct run) and of 2 workers (1 thread each), each after a warm-up batch so that imports
   and JIT are paid; wall time from submit to the last result. Overhead per task = batch with
   1 worker / direct − 1 (wall and CPU, in pairs run seconds apart); speed-up = 1 worker /
   2 workers. CPU, user and system time and minor page faults of the tasks (the workers'
   ``getrusage``) and of the direct run are printed beside every wall time.
   Last, unless ``--no-dask-defaults``: 1 worker with Dask's own worker settings
   (``MALLOC_TRIM_THRESHOLD_=65536``, 10 ms profiler, 20 ms tick: what the batch used before),
   paired with the direct run: their cost (docs/performance/batch.md).
4. The L-R Monte Carlo table (:func:`arrayproc.evaluate.distributed.lr_table`) on 1 worker and on
   2 workers, wall time, and a check that both give the same numbers.

The machine is shared: ``uptime``'s load is printed beside every timing, and each timing is the
minimum and the median of ``--repeats`` runs.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "arrayproc" / "data"


def load() -> str:
    """The 1-minute load average, with the time."""
    with open("/proc/loadavg") as f:
        one = f.read().split()[0]
    return f"load {one} at {time.strftime('%H:%M:%S', time.gmtime())} UTC"


def simulate(d: Path, n: int, seconds: float, channels: int) -> list[Path]:
    from arrayproc.sim.run import simulate_file
    text = (DATA / "scenarios" / "towed_passive.toml").read_text()
    text, k = re.subn(r"(?m)^n = 32\b", f"n = {channels}", text)
    assert k == 1, "scenario array size line not found"
    scn = d / f"towed_{channels}ch.toml"
    scn.write_text(text)
    out = []
    for i in range(n):
        p = d / f"rec{i}_{channels}ch_{int(seconds)}s.h5"
        if not p.exists():
            simulate_file(str(scn), str(p), seed=i + 1, duration=seconds)
        out.append(p)
    return out


def usage() -> dict:
    """This process's user and system CPU seconds and minor page faults so far."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return {"user_s": r.ru_utime, "sys_s": r.ru_stime, "minflt": r.ru_minflt}


def direct(recs: list[Path], chain: Path, outdir: Path) -> dict:
    """Each file as ``arrayproc process`` runs it, in this process: wall s, CPU s, user and
    system s, minor page faults."""
    from arrayproc.app.api import load_chain, run_chain
    from arrayproc.io.products import ProductsWriter
    from arrayproc.io.recording import Recording
    outdir.mkdir(exist_ok=True)
    t0, c0, u0 = time.perf_counter(), time.process_time(), usage()
    for r in recs:
        spec = load_chain(str(chain))
        with Recording(r) as rec, ProductsWriter(outdir / f"{r.stem}.h5", source=str(r),
                                                 chain=spec.text) as w:
            run_chain(rec, spec, w)
    u1 = usage()
    return {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
            **{k: u1[k] - u0[k] for k in u0}}


def batch_time(client, recs: list[Path], chain: Path, outdir: Path, threads: int) -> dict:
    """One batch: wall s from submit to the last result; CPU, user and system s and minor
    page faults of the tasks, summed."""
    from arrayproc.app.batch import run_batch
    t0 = time.perf_counter()
    res = run_batch(recs, chain, outdir, client, threads=threads)
    dt = time.perf_counter() - t0
    bad = [r for r in res if r.status != "done"]
    if bad:
        raise SystemExit(f"batch failed: {bad}")
    return {"wall_s": dt, "cpu_s": sum(r.cpu_seconds for r in res),
            "user_s": sum(r.user_seconds for r in res),
            "sys_s": sum(r.system_seconds for r in res),
            "minflt": sum(r.minor_faults for r in res)}


def cluster(n: int, threads: int, dask_defaults: bool = False):
    from arrayproc.app.batch import start_client
    return start_client(workers=n, threads=threads, dask_defaults=dask_defaults)


def line(what: str, r: dict, n: int) -> str:
    return (f"{what}: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} s CPU (user {r['user_s']:.1f}, "
            f"system {r['sys_s']:.1f}), {r['minflt'] / 1e3:.0f} k minor faults for {n} files "
            f"({load()})")


def stats(xs: list[float]) -> dict:
    return {"min_s": min(xs), "median_s": statistics.median(xs), "runs_s": xs}


def bench_batches(a: argparse.Namespace, recs: list[Path], chain: Path, d: Path, cores: int,
                  out: dict) -> None:
    """Direct runs and batches on 1 worker x all threads (paired with direct), 1 x 1 and
    2 x half; with Dask's default worker settings unless ``--no-dask-defaults``."""
    # the last configuration starts its worker with Dask's defaults (MALLOC_TRIM_THRESHOLD_=
    # 65536, 10 ms profiler, 20 ms tick: what the batch did before): their cost, paired with
    # the direct run
    configs = [(1, cores, False), (1, 1, False), (2, max(1, cores // 2), False)]
    if not a.no_dask_defaults:
        configs.append((1, cores, True))
    for n_workers, threads, dask_defaults in configs:
        key = f"batch_{n_workers}w_{threads}t" + ("_dask_defaults" if dask_defaults else "")
        paired = n_workers == 1 and threads == cores  # overhead: direct and batch in pairs
        t_start = time.perf_counter()
        client, clu = cluster(n_workers, threads, dask_defaults)
        runs, pairs = [], []
        try:
            client.wait_for_workers(n_workers)
            t_up = time.perf_counter() - t_start
            env = client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_")
            batch_time(client, recs[:n_workers], chain, d / "bwarm", threads)
            for _ in range(a.repeats):
                if paired:
                    rd = direct(recs, chain, d / "direct")
                    print(line(f"direct (as arrayproc process, in this process, {cores} "
                               "threads)", rd, len(recs)), flush=True)
                    out.setdefault("direct", []).append(rd)
                rb = batch_time(client, recs, chain, d / key, threads)
                runs.append(rb)
                print(line(f"batch, {n_workers} worker(s) x {threads} thread(s), worker "
                           f"MALLOC_TRIM_THRESHOLD_={sorted(set(env.values()))[0]}", rb,
                           len(recs)), flush=True)
                if paired:
                    pairs.append({"wall_pct": 100.0 * (rb["wall_s"] / rd["wall_s"] - 1.0),
                                  "cpu_pct": 100.0 * (rb["cpu_s"] / rd["cpu_s"] - 1.0)})
        finally:
            client.close()
            clu.close()
        out[key] = {**stats([r["wall_s"] for r in runs]), "runs": runs,
                    "task_cpu_s": [r["cpu_s"] for r in runs], "cluster_start_s": t_up,
                    "worker_malloc_trim_threshold": sorted(set(map(str, env.values())))}
        if pairs:
            out[key]["overhead_pairs"] = pairs
            print(f"per-task overhead of {key} vs direct, paired: "
                  + ", ".join(f"{q['wall_pct']:+.1f} % wall / {q['cpu_pct']:+.1f} % CPU"
                              for q in pairs), flush=True)


def summarise_batches(out: dict, cores: int) -> None:
    """Speed-ups and per-task overheads from :func:`bench_batches`' timings."""
    b1 = out[f"batch_1w_{cores}t"]
    b2 = out[f"batch_2w_{max(1, cores // 2)}t"]
    b11 = out["batch_1w_1t"]
    out["overhead_pct_pairs"] = [q["wall_pct"] for q in b1["overhead_pairs"]]
    out["speedup_2w_vs_1w_min"] = b1["min_s"] / b2["min_s"]
    out["speedup_2w_vs_1w1t_min"] = b11["min_s"] / b2["min_s"]
    out["speedup_2w_vs_direct_min"] = min(x["wall_s"] for x in out["direct"]) / b2["min_s"]
    # with the cores free, 2 single-thread workers on 4 equal tasks finish in half the summed
    # task CPU time of 2 workers; 1 worker x 1 thread in its summed task CPU time
    out["speedup_2w_vs_1w1t_cpu_projection"] = min(b11["task_cpu_s"]) / (min(b2["task_cpu_s"]) / 2)
    cpu_direct = min(x["cpu_s"] for x in out["direct"])
    out["overhead_cpu_pct"] = 100.0 * (min(b1["task_cpu_s"]) / cpu_direct - 1.0)
    print(f"speed-up 2 workers vs 1 worker x {cores} threads: {out['speedup_2w_vs_1w_min']:.2f}x "
          f"(min wall); vs 1 worker x 1 thread: {out['speedup_2w_vs_1w1t_min']:.2f}x (min wall), "
          f"{out['speedup_2w_vs_1w1t_cpu_projection']:.2f}x (task CPU projection); vs direct: "
          f"{out['speedup_2w_vs_direct_min']:.2f}x (min wall)")
    print("per-task overhead vs direct, paired wall: "
          + ", ".join(f"{p:+.1f} %" for p in out["overhead_pct_pairs"])
          + f"; task CPU (min vs min): {out['overhead_cpu_pct']:+.1f} %", flush=True)
    dm = out.get(f"batch_1w_{cores}t_dask_defaults")
    if dm:
        out["dask_defaults_cpu_pct"] = 100.0 * (min(dm["task_cpu_s"]) / cpu_direct - 1.0)
        print(f"with Dask's default worker settings: task CPU "
              f"{out['dask_defaults_cpu_pct']:+.1f} % vs direct (min vs min)", flush=True)



def bench_mc(a: argparse.Namespace, cores: int, out: dict) -> None:
    """The L-R Monte Carlo table on 1 and on 2 workers: time and same numbers."""
    from arrayproc.evaluate.distributed import lr_table
    filters = [f for f in a.mc_filters.split(",") if f]
    tables = {}
    for n_workers in (1, 2):
        threads = max(1, cores // n_workers)
        client, clu = cluster(n_workers, threads)
        try:
            client.wait_for_workers(n_workers)
            lr_table(n_workers * 20, 99, [1, 2], filters, client=client, chunk=20,
                     threads=threads)  # JIT in every worker
            t0 = time.perf_counter()
            tables[n_workers] = lr_table(a.mc_runs, 2024, [1, 2], filters, client=client,
                                         chunk=50, threads=threads)
            dt = time.perf_counter() - t0
        finally:
            client.close()
            clu.close()
        out[f"mc_{n_workers}w_s"] = dt
        print(f"L-R table, {a.mc_runs} runs x {len(filters)} filters x 2 cases, "
              f"{n_workers} worker(s) x {threads} thread(s): {dt:.1f} s ({load()})",
              flush=True)
    same = all(np.array_equal(np.asarray(tables[1][c][f][k]), np.asarray(tables[2][c][f][k]),
                              equal_nan=True)
               for c in tables[1] for f in tables[1][c] for k in tables[1][c][f]
               if not k.startswith("seconds"))
    out["mc_speedup"] = out["mc_1w_s"] / out["mc_2w_s"]
    out["mc_same_numbers"] = same
    print(f"L-R table speed-up 2 vs 1 worker: {out['mc_speedup']:.2f}x; same numbers: {same}")
    print(f"{'case':<5}{'filter':<7}{'loss% known':>12}{'loss% res.':>11}"
          f"{'RMSE pos m':>11}{'true side%':>11}")
    for c, rows in tables[2].items():
        for f, r in rows.items():
            print(f"{'I' * c:<5}{f.upper():<7}{r['track_loss_pct_known_side']:>12.2f}"
                  f"{r['track_loss_pct_resolved']:>11.2f}{r['rmse_pos_final_m']:>11.0f}"
                  f"{r['true_side_pct']:>11.2f}")
    out["mc_table"] = {c: {f: {k: v for k, v in r.items() if not isinstance(v, np.ndarray)}
                           for f, r in rows.items()} for c, rows in tables[2].items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", default="/tmp/bench_batch")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--channels", type=int, default=64)
    ap.add_argument("--recordings", type=int, default=4)
    ap.add_argument("--chain", default="towed_passive")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--mc-runs", type=int, default=500)
    ap.add_argument("--mc-filters", default="ekf,ukf,ckf,ghf")
    ap.add_argument("--no-mc", action="store_true")
    ap.add_argument("--no-dask-defaults", action="store_true",
                    help="skip the 1-worker batch with Dask's default worker settings")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    d = Path(a.dir)
    d.mkdir(parents=True, exist_ok=True)
    chain = DATA / "chains" / f"{a.chain}.toml"
    cores = os.cpu_count() or 1
    out: dict = {"cores": cores, "command": " ".join([Path(sys.argv[0]).name] + sys.argv[1:])}
    print(f"simulating {a.recordings} x {a.seconds:g} s, {a.channels} channels ({load()})",
          flush=True)
    recs = simulate(d, a.recordings, a.seconds, a.channels)

    direct(recs[:1], chain, d / "warm")
    exe = str(Path(sys.executable).with_name("arrayproc"))
    t0 = time.perf_counter()
    subprocess.run([exe, "process", str(recs[0]), "-c", str(chain), "-o",
                    str(d / "cli.h5"), "-q", "--no-progress"], check=True)
    out["cli_one_file_s"] = time.perf_counter() - t0
    print(f"arrayproc process (CLI, one file, with start-up): {out['cli_one_file_s']:.1f} s "
          f"({load()})", flush=True)

    bench_batches(a, recs, chain, d, cores, out)
    summarise_batches(out, cores)
    if not a.no_mc:
        bench_mc(a, cores, out)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
