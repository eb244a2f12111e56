"""Benchmark: start-up and fixed cost of the ``arrayproc`` command line.

Runs the CLI in child processes (as a user would) and prints a table of medians over
``--runs`` repetitions, wall time and CPU time (user + sys of the child, from
``resource.getrusage(RUSAGE_CHILDREN)``; on a shared machine the CPU time is the steadier of
the two). Measured:

* ``arrayproc --version``, and ``arrayproc info REC.h5`` on the short recording;
* the imports ``process`` needs before its first block (the CLI, the recording reader, the
  products writer, the chain's stage modules), with the heaviest packages from
  ``python -X importtime``;
* ``arrayproc process`` with the chain (default: the shipped ``towed_passive.toml``, CBF with
  181 beams) on simulated recordings of the same scenario, short and long (default 30 s and
  300 s, 64 channels). The fixed cost is the short run's time extrapolated linearly through the
  long run's to zero duration; the speed is the long run's duration over its time (x real time).

The recordings are simulated once from the shipped ``towed_passive`` scenario with the element
count and duration changed, into ``--workdir``, and reused by later runs. ``--tree`` runs
another checkout of the package (e.g. an unchanged copy made with ``git archive``) against the
same files; with several trees the runs are interleaved, so that a change of load on a shared
machine hits them alike. The children run with bytecode caching on
(``PYTHONDONTWRITEBYTECODE`` removed from their environment), as an installed package does;
a first, untimed run writes the ``.pyc`` files and the numba cache.

    python scripts/bench_startup.py [--runs 5] [--channels 64] [--durations 30 300]
        [--chain CHAIN.toml] [--workdir /tmp/arrayproc-startup] [--tree DIR ...] [--json OUT]
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

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "arrayproc" / "data" / "scenarios" / "towed_passive.toml"
CHAIN = ROOT / "arrayproc" / "data" / "chains" / "towed_passive.toml"
HEAVY_ROOTS = ("scipy", "numba", "h5py", "numpy", "matplotlib", "dask", "pyfftw", "ducc0",
               "llvmlite", "distributed", "xarray", "pandas")

IMPORTS = """
import sys
import arrayproc.app.cli
from arrayproc.app.resources import check_chain_memory
from arrayproc.io.recording import Recording
from arrayproc.app.api import load_chain
from arrayproc.io.products import ProductsWriter
load_chain(sys.argv[1])
"""


def timed(cmd: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float, str]:
    """Run ``cmd`` in ``cwd`` to completion; (wall s, child CPU s, stderr). Fails loudly on
    exit != 0. ``cwd`` is outside any checkout: ``python -c``/``-m`` put the current directory
    first on sys.path, so a checkout there would shadow ``--tree``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=cwd)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, r.stderr


def scenario_text(channels: int, duration: float) -> str:
    """The shipped towed-array scenario with ``channels`` elements lasting ``duration`` s."""
    text = SCENARIO.read_text()
    text, n1 = re.subn(r"(?m)^n = \d+", f"n = {channels}", text)
    text, n2 = re.subn(r"(?m)^duration = [0-9.]+", f"duration = {duration}", text, count=1)
    # the last ownship leg runs to the end of the recording
    legs = [float(v) for v in re.findall(r"(?m)^duration = ([0-9.]+)", text)[1:]]
    last = max(duration - sum(legs[:-1]), legs[-1])
    text, n3 = re.subn(r"(?ms)(.*^duration = )[0-9.]+", rf"\g<1>{last}", text, count=1)
    if (n1, n2, n3) != (1, 1, 1):
        raise SystemExit(f"{SCENARIO}: layout changed, cannot adapt it")
    return text


def recordings(cli: list[str], env: dict[str, str], workdir: Path, channels: int,
               durations: list[float]) -> dict[float, Path]:
    """Simulated recordings (simulated once, reused), keyed by duration."""
    workdir.mkdir(parents=True, exist_ok=True)
    scen = workdir / f"towed_{channels}ch_{max(durations):g}s.toml"
    scen.write_text(scenario_text(channels, max(durations)))
    out = {}
    for d in durations:
        rec = workdir / f"rec_{channels}ch_{d:g}s.h5"
        if not rec.exists():
            print(f"simulating {rec} ...", file=sys.stderr)
            timed([*cli, "simulate", str(scen), "-o", str(rec), "--duration", f"{d:g}",
                   "--no-progress", "-q"], env, workdir)
        out[d] = rec
    return out


def heaviest_imports(python: str, env: dict[str, str], chain: Path, cwd: Path,
                     top: int = 6) -> str:
    """The ``top`` heaviest third-party packages (cumulative -X importtime, ms) of the
    ``process`` imports, e.g. ``scipy 1150, numba 266``."""
    r = subprocess.run([python, "-X", "importtime", "-c", IMPORTS, str(chain)], env=env,
                       capture_output=True, text=True, cwd=cwd)
    best: dict[str, int] = {}
    for line in r.stderr.splitlines():
        m = re.match(r"import time:\s+\d+ \|\s+(\d+) \|( *)(\S+)$", line)
        if m and m.group(3).split(".")[0] in HEAVY_ROOTS:
            root = m.group(3).split(".")[0]
            best[root] = max(best.get(root, 0), int(m.group(1)))
    ranked = sorted(best.items(), key=lambda kv: -kv[1])[:top]
    return ", ".join(f"{k} {v / 1000:.0f}" for k, v in ranked)


def fixed_and_speed(med: dict[str, tuple[float, float]], short: float,
                    long_: float) -> dict[str, tuple[float, float]]:
    """Fixed cost (the short run extrapolated through the long run to zero duration, s) and
    the long run's speed (x real time), each as (wall, CPU)."""
    ws, cs = med[f"process {short:g} s"]
    wl, cl = med[f"process {long_:g} s"]
    slope = (long_ - short)
    return {"process fixed cost (extrapolated)": (ws - short * (wl - ws) / slope,
                                                  cs - short * (cl - cs) / slope),
            f"process {long_:g} s, x real time": (long_ / wl, long_ / cl)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--channels", type=int, default=64)
    ap.add_argument("--durations", type=float, nargs=2, default=[30.0, 300.0])
    ap.add_argument("--chain", type=Path, default=CHAIN)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/arrayproc-startup"))
    ap.add_argument("--tree", type=Path, nargs="+", default=[ROOT],
                    help="package checkouts to run, interleaved run by run")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()

    envs = {}
    for tree in a.tree:
        env = dict(os.environ, PYTHONPATH=str(tree.resolve()))
        env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installed package: .pyc files
        envs[str(tree)] = env
    cli = [sys.executable, "-m", "arrayproc"]
    short, long_ = sorted(a.durations)
    a.workdir = a.workdir.resolve()
    recs = recordings(cli, envs[str(a.tree[0])], a.workdir, a.channels, [short, long_])
    out = a.workdir / "products.h5"
    chain = str(a.chain.resolve())
    cases = {
        "python -c pass": [sys.executable, "-c", "pass"],
        "arrayproc --version": [*cli, "--version"],
        f"arrayproc info ({short:g} s)": [*cli, "info", str(recs[short])],
        "process imports": [sys.executable, "-c", IMPORTS, chain],
    }
    for d in (short, long_):
        cases[f"process {d:g} s"] = [*cli, "process", str(recs[d]), "-c", chain, "-o",
                                     str(out), "--no-progress", "-q"]
    samples = {t: {k: [] for k in cases} for t in envs}
    for env in envs.values():
        timed(cases["process imports"], env, a.workdir)  # .pyc files written
        timed(cases[f"process {short:g} s"], env, a.workdir)  # numba cache, page cache warm
    for _ in range(a.runs):  # interleaved, so that load changes hit every case alike
        for name, cmd in cases.items():
            for t, env in envs.items():
                if out.exists():
                    out.unlink()
                samples[t][name].append(timed(cmd, env, a.workdir)[:2])
    med = {t: {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
               for k, v in sv.items()} for t, sv in samples.items()}
    for t in med:
        med[t].update(fixed_and_speed(med[t], short, long_))
    load = os.getloadavg()

    print(f"{a.runs} runs, medians; load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} "
          f"on {os.cpu_count()} CPUs; chain {a.chain.name}, {a.channels} channels")
    print("| measurement | " + " | ".join(f"{t}: wall | CPU" for t in med) + " |")
    print("| --- | " + " | ".join("---: | ---:" for _ in med) + " |")
    for k in next(iter(med.values())):
        unit = "x" if "real time" in k else "s"
        cells = " | ".join(f"{med[t][k][0]:.{0 if unit == 'x' else 2}f} | "
                           f"{med[t][k][1]:.{0 if unit == 'x' else 2}f}" for t in med)
        print(f"| {k} ({unit}) | {cells} |")
    heavy = {t: heaviest_imports(sys.executable, env, a.chain.resolve(), a.workdir)
             for t, env in envs.items()}
    for t, h in heavy.items():
        print(f"{t}: heaviest packages in the process imports (-X importtime, cumulative "
              f"ms): {h}")
    if a.json:
        a.json.write_text(json.dumps({"runs": a.runs, "load": load, "median_wall_cpu": med,
                                      "samples": samples, "heaviest_imports": heavy},
                                     indent=1))


if __name__ == "__main__":
    main()
