"""Outputs before and after a refactor, compared dataset by dataset.

``--make DIR`` simulates every shipped scenario (shortened to ``--duration``) and imports the
real six-hydrophone recording when ``../shared`` is beside the checkout, runs every shipped chain
on every recording, every shipped tracker on every products file and every shipped TMA file on
every products and tracks file, with the package of ``--repo`` (default: this checkout).
Refusals are part of the outcome: ``DIR/outcomes.json`` keeps each command's exit status; an
output already in DIR is kept, and ``--like A`` runs only the commands that the run in A ran.
``--compare A B`` compares the outcomes and every HDF5 file of A with the file of the same name in
B: every group, dataset (bit for bit, NaNs equal) and attribute. A file whose only difference is
the embedded configuration text (the root ``chain`` attribute) is reported as such and does not
fail the comparison; a changed exit status, a difference in data or a file only in A does.

    git worktree add /tmp/before <commit>
    .venv/bin/python scripts/compare_outputs.py --make /tmp/out_before --repo /tmp/before
    .venv/bin/python scripts/compare_outputs.py --make /tmp/out_after --like /tmp/out_before
    .venv/bin/python scripts/compare_outputs.py --compare /tmp/out_before /tmp/out_after
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[1]
XAV = REPO.parent / "shared" / "data" / "xav-large-array"


def data_dir(repo: Path) -> Path:
    for d in (repo / "arrayproc" / "data", repo / "data"):
        if (d / "chains").is_dir():
            return d
    raise SystemExit(f"no chains folder found in {repo}")


class Runner:
    """Runs ``arrayproc`` from one checkout and keeps every command's outcome."""

    def __init__(self, repo: Path, jobs: int, out: Path, only: set[str] | None) -> None:
        self.env = {**os.environ, "PYTHONPATH": str(repo)}
        self.jobs, self.out, self.only = jobs, out, only
        self.outcomes: dict[str, str] = {}

    def one(self, key: str, args: list[str]) -> bool:
        if (self.out / key).is_file():  # made by an earlier run into this folder
            self.outcomes[key] = "ok"
            return True
        quiet = ["--no-progress"] if args[0] in ("simulate", "process", "track") else []
        p = subprocess.run([sys.executable, "-m", "arrayproc", *args, *quiet],
                           capture_output=True, text=True, env=self.env)
        err = (p.stderr.strip().splitlines() or [""])[-1][:160]
        status = "ok" if p.returncode == 0 else f"exit {p.returncode}: {err}"
        self.outcomes[key] = "ok" if p.returncode == 0 else f"exit {p.returncode}"
        print(f"{key}  [{status}]", flush=True)
        return p.returncode == 0

    def many(self, runs: dict[str, list[str]]) -> list[str]:
        """Run every command (``jobs`` at once); the keys of those that succeeded."""
        if self.only is not None:
            runs = {k: v for k, v in runs.items() if k in self.only}
        with ThreadPoolExecutor(self.jobs) as pool:
            ok = dict(zip(runs, pool.map(lambda kv: self.one(*kv), runs.items())))
        return [k for k, v in ok.items() if v]


def make(out: Path, repo: Path, duration: float, jobs: int, like: Path | None) -> None:
    """Every shipped scenario simulated, processed by every chain, tracked, TMA-solved (only
    the commands of the run in ``like`` when given)."""
    data = data_dir(repo)
    out.mkdir(parents=True, exist_ok=True)
    only = None if like is None else set(json.loads((like / "outcomes.json").read_text()))
    r = Runner(repo, jobs, out, only)
    sims = {f"rec_{s.stem}.h5": ["simulate", str(s), "-o", str(out / f"rec_{s.stem}.h5"),
                                 "--duration", f"{duration:g}", "-q"]
            for s in sorted((data / "scenarios").glob("*.toml"))}
    if XAV.is_dir():
        sims["rec_xav.h5"] = ["import", *sorted(str(p) for p in XAV.glob("AMAR173.*.wav")),
                              "--geometry", str(XAV / "hydrophones_config_07-HI.csv"),
                              "--sound-speed", "1484", "-o", str(out / "rec_xav.h5"), "-q"]
    recs = r.many(sims)
    procs = {f"prod_{rec[4:-3]}__{c.stem}.h5":
             ["process", str(out / rec), "-c", str(c),
              "-o", str(out / f"prod_{rec[4:-3]}__{c.stem}.h5"), "-q"]
             for rec in recs for c in sorted((data / "chains").glob("*.toml"))}
    prods = r.many(procs)
    tracks = {f"tracks_{p[5:-3]}__{t.stem}.h5":
              ["track", str(out / p), "-c", str(t),
               "-o", str(out / f"tracks_{p[5:-3]}__{t.stem}.h5"), "-q"]
              for p in prods for t in sorted((data / "trackers").glob("*.toml"))}
    done = r.many(tracks)
    tmas = {f"tma_{f.split('_', 1)[1][:-3]}__{c.stem}.h5":
            ["tma", str(out / f), "-c", str(c),
             "-o", str(out / f"tma_{f.split('_', 1)[1][:-3]}__{c.stem}.h5"), "-q"]
            for f in [*prods, *done] for c in sorted((data / "tma").glob("*.toml"))}
    r.many(tmas)
    (out / "outcomes.json").write_text(json.dumps(r.outcomes, indent=1, sort_keys=True))


def _items(f: h5py.File) -> dict[str, object]:
    found: dict[str, object] = {}

    def visit(name: str, obj: object) -> None:
        found[name] = obj
    f.visititems(visit)
    return found


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind in "fc":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


def _attrs_diff(where: str, a: h5py.AttributeManager, b: h5py.AttributeManager,
                ignore: set[str]) -> list[str]:
    out = []
    for k in sorted(set(a) | set(b)):
        if k in ignore:
            continue
        if k not in a or k not in b:
            out.append(f"{where}: attr {k} only in one file")
        elif not _same(np.asarray(a[k]), np.asarray(b[k])):
            out.append(f"{where}: attr {k} differs: {a[k]!r} vs {b[k]!r}")
    return out


def compare_files(pa: Path, pb: Path) -> list[str]:
    diffs: list[str] = []
    # paths of the inputs and the software version may differ between two checkouts
    ignore = {"source", "software_version", "chain_path", "config_path", "recording", "products"}
    with h5py.File(pa, "r") as fa, h5py.File(pb, "r") as fb:
        diffs += _attrs_diff("/", fa.attrs, fb.attrs, ignore)
        ia, ib = _items(fa), _items(fb)
        for name in sorted(set(ia) | set(ib)):
            if name not in ia or name not in ib:
                diffs.append(f"{name}: only in {'A' if name in ia else 'B'}")
                continue
            a, b = ia[name], ib[name]
            if isinstance(a, h5py.Dataset) and isinstance(b, h5py.Dataset):
                if not _same(a[()], b[()]):
                    diffs.append(f"{name}: data differs")
            elif type(a) is not type(b):
                diffs.append(f"{name}: group in one file, dataset in the other")
            diffs += _attrs_diff(name, a.attrs, b.attrs, ignore)
    return diffs


CONFIG_TEXT = "/: attr chain differs"


def compare_outcomes(a: Path, b: Path) -> int:
    """Commands whose exit status changed (present in both runs); their count."""
    if not ((a / "outcomes.json").is_file() and (b / "outcomes.json").is_file()):
        return 0
    oa = json.loads((a / "outcomes.json").read_text())
    ob = json.loads((b / "outcomes.json").read_text())
    changed = [k for k in sorted(set(oa) & set(ob)) if oa[k] != ob[k]]
    for k in changed:
        print(f"{k}: {oa[k]} -> {ob[k]}")
    print(f"{len(set(oa) & set(ob))} commands in both runs, {len(changed)} changed outcome, "
          f"{len(set(ob) - set(oa))} only in B")
    return len(changed)


def compare(a: Path, b: Path) -> int:
    bad = compare_outcomes(a, b)
    fa = {p.name for p in a.glob("*.h5")}
    fb = {p.name for p in b.glob("*.h5")}
    n_diff = n_text = 0
    for name in sorted(fa | fb):
        if name not in fa or name not in fb:
            print(f"{name}: only in {'A' if name in fa else 'B'}")
            bad += name in fa  # a file the new code no longer makes is a difference
            continue
        d = compare_files(a / name, b / name)
        if d and all(line.startswith(CONFIG_TEXT) for line in d):
            n_text += 1  # the shipped TOML's text (comments, keys) edited, every number equal
            print(f"{name}: data identical, embedded configuration text differs")
            continue
        print(f"{name}: {'identical' if not d else f'{len(d)} differences'}")
        for line in d[:20]:
            print("   ", line[:300])
        n_diff += bool(d)
    bad += n_diff
    print(f"{len(fa | fb)} files, {len(fa & fb)} in both: {n_diff} differ in data, "
          f"{n_text} only in their embedded configuration text "
          f"({len(fb - fa)} only in B: chains, trackers or scenarios that A does not have)")
    return 1 if bad else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--make", metavar="DIR", help="write every output here")
    g.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare two --make folders")
    p.add_argument("--repo", type=Path, default=REPO, help="checkout whose package runs")
    p.add_argument("--duration", type=float, default=60.0, help="scenario length, s")
    p.add_argument("--jobs", type=int, default=2, help="commands run at once")
    p.add_argument("--like", type=Path, help="run only the commands of this earlier --make "
                   "(what a comparison with it needs)")
    a = p.parse_args()
    if a.make:
        make(Path(a.make), a.repo.resolve(), a.duration, a.jobs, a.like)
        return 0
    return compare(Path(a.compare[0]), Path(a.compare[1]))


if __name__ == "__main__":
    sys.exit(main())
