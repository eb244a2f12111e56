"""Bounded memory: process a large generated recording and report the peak RSS.

Generates a 64-channel float32 recording of ``--gb`` GiB (not committed; in a temporary
directory), runs ``arrayproc process`` with the given chain (default: a pass-through chain) in a
child process and prints the child's peak resident set size.

    python scripts/check_memory.py [--gb 2] [--chain data/chains/passthrough.toml]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from arrayproc.io.geometry import line_array
from arrayproc.io.recording import RecordingWriter

PASS = '[input]\nblock = 8192\n[[stage]]\ntype = "pass"\n'


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gb", type=float, default=2.0)
    ap.add_argument("--chain", default=None, help="chain TOML (default: pass-through)")
    ap.add_argument("--dir", default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    n_ch, fs = 64, 5120.0
    n = int(a.gb * (1 << 30)) // (4 * n_ch)
    with tempfile.TemporaryDirectory(dir=a.dir) as d:
        rec = Path(d) / "big.h5"
        rng = np.random.default_rng(1)
        noise = rng.standard_normal((1 << 16, n_ch), dtype=np.float32)
        with RecordingWriter(rec, fs, n_ch, positions=line_array(n_ch, 0.36)) as w:
            for s in range(0, n, 1 << 16):
                w.append(noise[: min(1 << 16, n - s)])
        chain = Path(a.chain) if a.chain else Path(d) / "pass.toml"
        if not a.chain:
            chain.write_text(PASS)
        cmd = [sys.executable, "-m", "arrayproc.app.cli", "process", str(rec), "-c", str(chain),
               "-o", str(Path(d) / "out.h5"), "--no-progress", "-q"]
        subprocess.run(cmd, check=True)
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
        size_mb = rec.stat().st_size / (1 << 20)
    print(f"recording: {size_mb:.0f} MiB ({n} samples x {n_ch} channels); chain: "
          f"{a.chain or 'pass-through'}; peak RSS of the process: {peak_mb:.0f} MiB")
    if a.json:
        Path(a.json).write_text(json.dumps({"file_mib": size_mb, "peak_rss_mib": peak_mb,
                                            "chain": a.chain or "pass"}))


if __name__ == "__main__":
    main()
