"""Outputs before and after a refactor, compared dataset by dataset.

``--make DIR`` simulates the demo recordings (towed passive, synthetic aperture), imports the
real six-hydrophone recording when ``../shared`` is beside the checkout, runs every chain in the
package's ``chains`` folder on every recording it accepts, and tracks the demo's products with
every tracker file; ``--compare A B`` compares every HDF5 file of A with the file of the same
name in B: every group, dataset (bit for bit, NaNs equal) and attribute.

    .venv/bin/python scripts/compare_outputs.py --make /tmp/before
    .venv/bin/python scripts/compare_outputs.py --make /tmp/after
    .venv/bin/python scripts/compare_outputs.py --compare /tmp/before /tmp/after
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[1]
XAV = REPO.parent / "shared" / "data" / "xav-large-array"
EXE = [sys.executable, "-m", "arrayproc"]  # the package on sys.path (PYTHONPATH wins)


def data_dir() -> Path:
    for d in (REPO / "arrayproc" / "data", REPO / "data"):
        if (d / "chains").is_dir():
            return d
    raise SystemExit("no chains folder found")


def run(args: list[str]) -> bool:
    p = subprocess.run([*EXE, *args, *(["--no-progress"] if args[0] in
                                       ("simulate", "process", "track") else [])],
                       capture_output=True, text=True)
    status = "ok" if p.returncode == 0 else f"exit {p.returncode}: {p.stderr.strip()[-200:]}"
    print(f"$ arrayproc {' '.join(args)}  [{status}]", flush=True)
    return p.returncode == 0


def make(out: Path) -> None:
    data = data_dir()
    out.mkdir(parents=True, exist_ok=True)
    recs = {}
    for name, dur in (("towed_passive", "120"), ("towed_synthetic_aperture", "120")):
        rec = out / f"rec_{name}.h5"
        if run(["simulate", str(data / "scenarios" / f"{name}.toml"), "-o", str(rec),
                "--duration", dur, "-q"]):
            recs[name] = rec
    if XAV.is_dir():
        rec = out / "rec_xav.h5"
        wavs = sorted(str(p) for p in XAV.glob("AMAR173.*.wav"))
        if run(["import", *wavs, "--geometry", str(XAV / "hydrophones_config_07-HI.csv"),
                "--sound-speed", "1484", "-o", str(rec), "-q"]):
            recs["xav"] = rec
    for chain in sorted((data / "chains").glob("*.toml")):
        for name, rec in recs.items():
            prod = out / f"prod_{name}__{chain.stem}.h5"
            if run(["process", str(rec), "-c", str(chain), "-o", str(prod), "-q"]) and \
                    name == "towed_passive" and chain.stem == "towed_passive":
                for tr in sorted((data / "trackers").glob("*.toml")):
                    run(["track", str(prod), "-c", str(tr), "-o",
                         str(out / f"tracks_{name}__{tr.stem}.h5")])


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
    ignore = {"source", "software_version", "chain_path", "config_path", "recording"}
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


def compare(a: Path, b: Path) -> int:
    fa = {p.name for p in a.glob("*.h5")}
    fb = {p.name for p in b.glob("*.h5")}
    bad = 0
    for name in sorted(fa | fb):
        if name not in fa or name not in fb:
            print(f"{name}: only in {'A' if name in fa else 'B'}")
            bad += name in fa  # a file the new code no longer makes is a difference
            continue
        d = compare_files(a / name, b / name)
        print(f"{name}: {'identical' if not d else f'{len(d)} differences'}")
        for line in d[:20]:
            print("   ", line)
        bad += bool(d)
    both = len(fa & fb)
    print(f"{len(fa | fb)} files, {both} in both, {bad} differ "
          f"({len(fb - fa)} only in B: chains or trackers that A does not have)")
    return 1 if bad else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--make", metavar="DIR")
    g.add_argument("--compare", nargs=2, metavar=("A", "B"))
    a = p.parse_args()
    if a.make:
        make(Path(a.make))
        return 0
    return compare(Path(a.compare[0]), Path(a.compare[1]))


if __name__ == "__main__":
    sys.exit(main())
