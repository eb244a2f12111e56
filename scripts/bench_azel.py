"""Bench of ``cbf_azel``: the azimuth × elevation beamformer on 4 and 6 hydrophones at 8 kHz,
2° grid over the full sphere (azimuth 0-358 × elevation −90..90: 180 × 91 = 16 380
directions), against eq. (1) in batched numpy (a complex matmul over bins and directions,
``azel_power_reference``) in the same process, on the same spectra.

Prints, per array: x real time of the stage (recording seconds / wall seconds of
``process`` over the whole recording, spectra included), its CPU time (and x real time by
CPU time: the machine may be shared), the reference's x real
time (timed on ``--ref-snapshots`` snapshots and scaled per snapshot: it is too slow for the
whole recording) and the ratio, and the largest difference between the two relative to the
coherent power (the stage's interpolation bound, eq. 3, is ``accuracy``).

    .venv/bin/python scripts/bench_azel.py [--seconds 30] [--nfft 1024] [--hop 512]
        [--band 0 4000] [--ref-snapshots 6] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.sim.scenario import tetrahedron
from arrayproc.stages.beamform._common import SpectraFramer
from arrayproc.stages.beamform.cbf_azel import CBFAzEl, azel_power_reference, world_directions

FS = 8000.0
C = 1500.0


def six_element(side: float = 1.84) -> np.ndarray:
    """An octahedron of edge ``side``: six hydrophones on the three body axes."""
    a = side / np.sqrt(2.0)
    return np.vstack([np.eye(3) * a, -np.eye(3) * a])


def blocks(x: np.ndarray, pos: np.ndarray, size: int = 8192):
    for i in range(0, x.shape[0], size):
        s = min(size, x.shape[0] - i)
        yield Block(x[i:i + s], Domain.TIME, i / FS, s / FS, FS, pos, None,
                    meta=TimeMeta(i, s))


def run(pos: np.ndarray, args) -> dict:
    rng = np.random.default_rng(1)
    n = int(args.seconds * FS)
    x = rng.normal(0, 1, (n, pos.shape[0])).astype(np.float32)
    kw = dict(nfft=args.nfft, hop=args.hop, window="hann", band=list(args.band),
              azimuth=[0, 360, 2], elevation=[-90, 90, 2])
    st = CBFAzEl(**kw)
    list(st.process(blocks(x[:4 * args.nfft], pos)))  # compile and plan outside the timing
    st = CBFAzEl(**kw)
    w0, c0 = time.perf_counter(), time.process_time()
    out = list(st.process(blocks(x, pos)))
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    n_snap = sum(o.data.shape[0] for o in out)
    # the reference on the first snapshots' spectra
    fr = SpectraFramer(args.nfft, args.hop, "hann", tuple(args.band))
    specs = []
    for b in blocks(x[: (args.ref_snapshots + 1) * args.hop + args.nfft], pos):
        s = fr.push(b)
        if s is not None:
            specs.append(s)
    xs = np.concatenate([s.data for s in specs])[: args.ref_snapshots]
    dirs = world_directions(st.az, st.el)
    w1, c1 = time.perf_counter(), time.process_time()
    ref = azel_power_reference(xs, specs[0].freqs, pos, dirs, C)
    rwall, rcpu = time.perf_counter() - w1, time.process_time() - c1
    mine = np.concatenate([o.data[:, 0, :] for o in out])[: xs.shape[0]]
    coherent = (np.abs(xs).sum(2) ** 2).sum(1)
    err = float((np.abs(mine - ref) / coherent[:, None]).max())
    per_snap_ref = rwall / xs.shape[0]
    return {"hydrophones": int(pos.shape[0]), "directions": int(dirs.shape[0]),
            "snapshots": n_snap, "seconds": args.seconds, "bins": int(specs[0].freqs.size),
            "stage_wall_s": wall, "stage_cpu_s": cpu, "stage_x_realtime": args.seconds / wall,
            "stage_x_realtime_cpu": args.seconds / cpu,
            "ref_wall_per_snapshot_s": per_snap_ref, "ref_cpu_per_snapshot_s": rcpu / xs.shape[0],
            "ref_x_realtime": args.seconds / (per_snap_ref * n_snap),
            "ratio": per_snap_ref * n_snap / wall, "max_rel_diff": err,
            "accuracy": st.accuracy}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--nfft", type=int, default=1024)
    ap.add_argument("--hop", type=int, default=512)
    ap.add_argument("--band", type=float, nargs=2, default=(0.0, 4000.0))
    ap.add_argument("--ref-snapshots", type=int, default=6)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # spatial aliasing above c/2d: a timing run
        for pos in (tetrahedron(1.84), six_element()):
            r = run(pos, args)
            rows.append(r)
            print(f"{r['hydrophones']} hydrophones, {r['directions']} directions, "
                  f"{r['bins']} bins, {r['snapshots']} snapshots of {args.nfft}/{args.hop}: "
                  f"stage {r['stage_x_realtime']:.0f}x real time (wall {r['stage_wall_s']:.3f} s, "
                  f"CPU {r['stage_cpu_s']:.3f} s: {r['stage_x_realtime_cpu']:.0f}x); "
                  f"numpy reference {r['ref_x_realtime']:.2f}x "
                  f"real time (CPU {r['ref_cpu_per_snapshot_s'] * 1e3:.0f} ms/snapshot); "
                  f"ratio {r['ratio']:.0f}; max diff {r['max_rel_diff']:.1e} of the coherent "
                  f"power (bound {r['accuracy']:g})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
