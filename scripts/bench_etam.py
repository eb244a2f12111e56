"""Benchmark: inverse beamforming (3 waves) + ETAM (N_S = 10) on 64 channels at 5120 Hz.

A towed 64 × 0.36 m array at 2.5 m/s (ETAM snapshots T_B = (N_H − 1) δx / 2U = 4.536 s, i.e.
23 224 samples, rounded up to the FFT-friendly 23 232), three tonal plane waves and white
noise, band 100-1000 Hz, 181 cone beams. Runs the chain ``ibf → etam`` through the engine
(reader, products writer) and reports multiples of real time; then times the ETAM part alone
against a plain-numpy implementation of the same equations (einsum sub-aperture beams,
vectorised eqs. 2.53-2.54, explicit steering exponentials) on the same element spectra, in
this process.

    python scripts/bench_etam.py [--seconds 120] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from arrayproc.app.api import build_chain, run_chain
from arrayproc.chain import RunContext
from arrayproc.chain.reader import read_blocks
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import Recording, RecordingWriter
from arrayproc.sim.plane_wave import towed_tonal_plane_waves
from arrayproc.stages.beamform.etam import ETAM, etam_reference
from arrayproc.stages.beamform.ibf import IBF

N, DX, C, FS, U = 64, 0.36, 1500.0, 5120.0, 2.5
BAND = [100.0, 1000.0]
CHAIN = f"""
[input]
block = 65536
[[stage]]
type = "ibf"
max_sources = 3
band = {BAND}
[[stage]]
type = "etam"
snapshots = 10
band = {BAND}
beams = {{start = 0.0, stop = 180.0, count = 181}}
"""


def make_recording(path: Path, seconds: float) -> None:
    rng = np.random.default_rng(0)
    pos = line_array(N, DX)
    waves = [(180.0, 40.0, 0.3), (420.0, 95.0, 0.1), (730.0, 150.0, 0.05)]  # Hz, cone, Pa
    n = int(seconds * FS)
    chunk = 1 << 16
    with RecordingWriter(path, FS, N, positions=pos, sound_speed=C) as w:
        for s in range(0, n, chunk):
            t = (s + np.arange(min(chunk, n - s))) / FS
            x = rng.standard_normal((t.size, N)) * 0.05
            x += towed_tonal_plane_waves(t, pos, U, waves, C)
            w.append(x.astype(np.float32))
        tn = np.arange(0.0, seconds + 1.0)
        w.set_nav(tn, np.stack([np.zeros_like(tn), U * tn], -1), np.zeros_like(tn))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=120.0, help="recording length (s)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        rec = Path(d) / "bench.h5"
        make_recording(rec, a.seconds)
        spec = build_chain(CHAIN)
        # warm-up (numba compilation, FFTW plans) on a short segment
        with Recording(rec) as r, ProductsWriter(Path(d) / "w.h5") as w:
            run_chain(r, build_chain(CHAIN), w, 0.0, 60.0)
        t0 = time.perf_counter()
        with Recording(rec) as r, ProductsWriter(Path(d) / "p.h5") as w:
            run_chain(r, spec, w)
        chain_s = time.perf_counter() - t0
        # ETAM alone: ours vs numpy on the same IBF-cleaned spectra
        with Recording(rec) as r:
            ibf = IBF(max_sources=3, band=BAND)
            ibf.bind(RunContext(sound_speed=C, recording=r))
            t0 = time.perf_counter()
            cleaned = list(ibf(read_blocks(r, 65536, 65536)))
            ibf_s = time.perf_counter() - t0
            etam = ETAM(snapshots=10, band=BAND, beams={"start": 0.0, "stop": 180.0,
                                                        "count": 181})
            etam.bind(RunContext(sound_speed=C, recording=r))
            t0 = time.perf_counter()
            ours = list(etam(iter(cleaned)))
            etam_s = time.perf_counter() - t0
        nfft = cleaned[0].meta.nfft
        freqs = cleaned[0].freqs
        x = cleaned[0].positions[:, 0]
        spectra = [b.data[i].astype(complex) for b in cleaned for i in range(b.data.shape[0])]
        step = U * nfft / FS
        t0 = time.perf_counter()
        ref = etam_reference(spectra, freqs, x, step, int(np.floor(step / DX + 0.5 + 1e-6)), 10,
                             np.linspace(0, 180, 181), C)
        numpy_s = time.perf_counter() - t0
        err = max(float(np.max(np.abs(o.data[0] - r_)) / np.max(np.abs(r_)))
                  for o, r_ in zip(ours, ref))
    n_snap = len(spectra)
    res = {"seconds_of_data": a.seconds, "snapshots": n_snap, "nfft": int(nfft),
           "bins": int(freqs.size), "chain_wall_s": chain_s,
           "chain_x_real_time": a.seconds / chain_s,
           "ibf_wall_s": ibf_s, "ibf_x_real_time": a.seconds / ibf_s,
           "etam_wall_s": etam_s, "etam_x_real_time": a.seconds / etam_s,
           "numpy_etam_wall_s": numpy_s, "etam_speedup_vs_numpy": numpy_s / etam_s,
           "max_rel_diff_vs_numpy": err}
    print(f"{a.seconds:.0f} s of 64-channel data at {FS:g} Hz, {n_snap} ETAM snapshots of "
          f"{nfft} samples, {freqs.size} bins, 181 beams")
    print(f"{'step':<34}{'wall s':>9}{'x real time':>13}")
    print(f"{'ibf (3 waves) + etam (N_S=10) chain':<34}{chain_s:>9.2f}{a.seconds / chain_s:>13.1f}")
    print(f"{'  ibf alone':<34}{ibf_s:>9.2f}{a.seconds / ibf_s:>13.1f}")
    print(f"{'  etam alone':<34}{etam_s:>9.2f}{a.seconds / etam_s:>13.1f}")
    print(f"{'  etam, plain numpy reference':<34}{numpy_s:>9.2f}{a.seconds / numpy_s:>13.1f}")
    print(f"etam speed-up over numpy: {numpy_s / etam_s:.1f}x (max rel. difference {err:.1e})")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
