"""Benchmark: reading and blocking a 64-channel float32 recording vs plain h5py slabs.

Both run in this process on the same file (kept in the page cache by a warm-up pass), so the
ratio measures the reader's overhead, not the disk. Prints a table; ``--json`` writes it.

    python scripts/bench_io.py [--mb 1024] [--nfft 2048] [--hop 1024] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from arrayproc.app.api import build_chain, run_chain
from arrayproc.chain.reader import read_blocks
from arrayproc.io.geometry import line_array
from arrayproc.io.recording import Recording, RecordingWriter


def make_file(path: Path, mb: int, n_ch: int = 64, fs: float = 5120.0) -> int:
    n = mb * (1 << 20) // (4 * n_ch)
    rng = np.random.default_rng(0)
    chunk = 1 << 16
    with RecordingWriter(path, fs, n_ch, positions=line_array(n_ch, 0.36)) as w:
        for s in range(0, n, chunk):
            w.append(rng.standard_normal((min(chunk, n - s), n_ch), dtype=np.float32))
    return n


def plain_h5py(path: Path, slab_mb: int = 64) -> float:
    """Read the whole of /time_data in large contiguous slabs; returns seconds."""
    t = time.perf_counter()
    with h5py.File(path, "r") as f:
        d = f["time_data"]
        step = slab_mb * (1 << 20) // (d.dtype.itemsize * d.shape[1])
        acc = 0.0
        for s in range(0, d.shape[0], step):
            x = d[s:s + step]
            acc += float(x[0, 0])
    return time.perf_counter() - t


def arrayproc_blocks(path: Path, nfft: int, hop: int) -> tuple[float, int]:
    """Iterate Recording.blocks (hyperslabs, overlap, pose per block); returns s, n blocks."""
    t = time.perf_counter()
    n = 0
    acc = 0.0
    with Recording(path) as r:
        for b in read_blocks(r, nfft, hop):
            acc += float(b.data[0, 0])
            n += 1
    return time.perf_counter() - t, n


def arrayproc_chain(path: Path, block: int) -> float:
    """A pass-through chain through the engine (reader → pass stage → driver)."""
    spec = build_chain(f'[input]\nblock = {block}\n[[stage]]\ntype = "pass"\n')
    t = time.perf_counter()
    with Recording(path) as r:
        run_chain(r, spec)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=int, default=1024, help="file size, MiB (default 1024)")
    ap.add_argument("--nfft", type=int, default=2048)
    ap.add_argument("--hop", type=int, default=1024)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None)
    ap.add_argument("--dir", default=None, help="where to put the temporary file")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(dir=a.dir) as d:
        path = Path(d) / "bench.h5"
        n = make_file(path, a.mb)
        plain_h5py(path)  # warm the page cache
        rows = {"plain_h5py_slabs": [], "blocks": [], "chain_pass": []}
        for _ in range(a.repeat):
            rows["plain_h5py_slabs"].append(plain_h5py(path))
            rows["blocks"].append(arrayproc_blocks(path, a.nfft, a.hop)[0])
            rows["chain_pass"].append(arrayproc_chain(path, 8192))
    mb = a.mb
    best = {k: min(v) for k, v in rows.items()}
    ref = best["plain_h5py_slabs"]
    print(f"file: {mb} MiB, 64 channels float32, {n} samples; nfft {a.nfft}, hop {a.hop}")
    print(f"{'reader':<36}{'MiB/s':>10}{'ratio to h5py':>16}")
    out = {"mb": mb, "n_samples": n, "nfft": a.nfft, "hop": a.hop, "results": {}}
    for k, s in best.items():
        print(f"{k:<36}{mb / s:>10.0f}{ref / s:>16.2f}")
        out["results"][k] = {"seconds": s, "mib_per_s": mb / s, "ratio": ref / s}
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
