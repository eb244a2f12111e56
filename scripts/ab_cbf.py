"""Paired A/B of the ``cbf`` stage: this checkout against the package at another git revision.

The machine's speed drifts by ±15 % within minutes, so two designs are only comparable when
they run interleaved in one process. This script extracts ``arrayproc/`` at ``--base`` (``git
archive``) into a temporary directory under another package name, builds the issue-4 CBF
(``scripts/bench_cbf.py``'s configuration) from both packages, checks that they give the same
beams, and times them in alternating order: ``--pairs`` pairs of ``--seconds`` of data each.
Printed: min and median ms per snapshot of each, and the median and quartiles of the paired
ratio (this checkout / base).

    .venv/bin/python scripts/ab_cbf.py --base 83ba04b [--pairs 12] [--seconds 60] [--batch 32]
"""

from __future__ import annotations

import argparse
import importlib
import io
import re
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np
from bench_cbf import BAND, BEAMS, HOP, NFFT, source, time_stage


def extract_base(rev: str, root: Path, tmp: Path) -> str:
    """Extract the ``arrayproc`` package at ``rev`` into ``tmp``, importable as
    ``arrayproc_base`` (returned): its absolute imports (``from arrayproc.io import h5``, say) are
    rewritten to the new name, so that none of its modules resolves to this checkout's
    package."""
    data = subprocess.run(["git", "archive", rev, "arrayproc"], cwd=root, check=True,
                          capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(tmp, filter="data")
    (tmp / "arrayproc").rename(tmp / "arrayproc_base")
    absolute = re.compile(r"(?m)^(\s*)(from|import) arrayproc(?=[.\s])")
    for f in (tmp / "arrayproc_base").rglob("*.py"):
        text = f.read_text()
        f.write_text(absolute.sub(r"\1\2 arrayproc_base", text))
    sys.path.insert(0, str(tmp))
    return "arrayproc_base"


def load_base(rev: str, root: Path, tmp: Path):
    """The ``cbf`` stage module of the package at ``rev`` (:func:`extract_base`)."""
    pkg = extract_base(rev, root, tmp)
    for name in (f"{pkg}.stages.beamform.cbf", f"{pkg}.stages.cbf"):
        try:
            return importlib.import_module(name)
        except ModuleNotFoundError:
            continue
    raise SystemExit(f"{rev}: no cbf stage found")


def base_source(base_cbf):
    """The same blocks as :func:`bench_cbf.source` in the base package's own block type: a
    revision from before the typed domains takes a tuple domain and a dict of
    metadata. The repacking costs a few microseconds per 8192-sample block."""
    mod = sys.modules[base_cbf.__name__.split(".", 1)[0]]  # the top package
    try:
        importlib.import_module(f"{mod.__name__}.chain.domains")
        return source  # the base has typed domains: it reads our blocks as they are
    except ModuleNotFoundError:
        block_cls = importlib.import_module(f"{mod.__name__}.block").Block

    def src(seconds: float):
        for b in source(seconds):
            yield block_cls(b.data, ("time", "channel"), b.t0, b.span, b.fs, b.positions,
                            None, index=b.index,
                            meta={"n_valid": b.meta.n_valid, "sample0": b.meta.sample0})
    return src


def ab_parser(doc: str) -> argparse.ArgumentParser:
    """The options every paired A/B script takes: ``--base`` (the git revision to compare
    against) and ``--pairs``."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--base", required=True, help="git revision to compare against")
    ap.add_argument("--pairs", type=int, default=12)
    return ap


def alternate(timers: dict, pairs: int, unit: str, what: str) -> None:
    """Time ``timers`` (name → callable returning one timing) in alternating order, ``pairs``
    times each (base first on even pairs, new first on odd ones), and print each one's min and
    median (``unit``) and the median and quartiles of the paired ratio new/base (``what``
    says what one pair timed)."""
    times: dict[str, list[float]] = {k: [] for k in timers}
    for i in range(pairs):
        for k in (list(timers) if i % 2 == 0 else list(timers)[::-1]):
            times[k].append(timers[k]())
    for k, v in times.items():
        print(f"{k:5s} {unit}: min {min(v):.3f}, median {np.median(v):.3f}")
    r = np.array(times["new"]) / np.array(times["base"])
    q1, q3 = np.percentile(r, [25, 75])
    print(f"paired ratio new/base: median {np.median(r):.3f}, quartiles {q1:.3f}-{q3:.3f} "
          f"({pairs} pairs of {what})")


def main() -> None:
    ap = ab_parser(__doc__)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--threads", type=int, default=0)
    args = ap.parse_args()
    from arrayproc.stages.beamform.cbf import CBF
    root = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        base_cbf = load_base(args.base, root, Path(tmp))
        kw = dict(nfft=NFFT, hop=HOP, window="hann", band=list(BAND), beams=BEAMS,
                  batch=args.batch, threads=args.threads)
        stages = {"base": base_cbf.CBF(**kw), "new": CBF(**kw)}
        srcs = {"base": base_source(base_cbf), "new": source}
        outs = []
        for k, st in stages.items():  # warm-up (numba compile or cache, plans), then output
            time_stage(st, 5.0, srcs[k])
            outs.append(np.concatenate([b.data.copy() for b in st.process(srcs[k](10.0))]))
        diff = np.abs(outs[0] - outs[1]).max() / np.abs(outs[0]).max()
        print(f"max relative difference of the beams, new vs base: {diff:.2e} (the two "
              "stages may pick different FFT back-ends, whose roundings differ)")
        n_snap = int((args.seconds * 5120 - NFFT) // HOP) + 1
        alternate({k: (lambda k=k: time_stage(stages[k], args.seconds, srcs[k]) / n_snap * 1e3)
                   for k in stages}, args.pairs, "ms per snapshot", f"{args.seconds:g} s")


if __name__ == "__main__":
    main()
