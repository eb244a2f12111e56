"""ETAM gain against SNR and the tonal's coherence time (thesis 2.2.3.2 and 2.3) on simulator
recordings (docs/validation/realism.md).

Set-up of scripts/reproduce_psas.py (64 hydrophones 0.36 m apart towed north, a 250 Hz tonal
from a distant broadside source, half-overlapping snapshots T_B = (N_H − 1)δx/(2U) = 4 s,
N_B = 10, lateral motion σ = 0.1 λ so that ETAM has phases to correct), with white noise at
60 dB re 1 µPa²/Hz and the tonal's in-bin SNR per hydrophone set by its level; the tonal's
phase a random walk of coherence time T_c (``coherence_time``). Gain = excess of the target
cell over the neighbouring bins, ETAM over one physical snapshot (``target_gain`` of
reproduce_psas.py), ideal 10 log10 N_B = 10 dB.

    .venv/bin/python scripts/validate_etam_realism.py [--snapshots 30] [--json OUT]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("reproduce_psas", HERE / "reproduce_psas.py")
rp = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rp)

SNRS_DB = [-20.0, -10.0, 0.0]  # tonal power over the noise in one 0.25 Hz bin, per hydrophone
TCS = [None, 100.0, 30.0, 10.0, 4.0]  # s (None: coherent)


def gain(tmp: Path, snr_db: float, tc: float | None, n_snap: int, seed: int) -> float:
    tb = 4.0
    u = (rp.N_H - 1) * rp.DX / (2 * tb)
    dur = tb * n_snap
    noise_db = 60.0
    # in-bin tonal power P over the noise N·(1/T_B): P = N + 10 log10(1/T_B) + SNR, at 100 km
    level = noise_db - 10 * np.log10(tb) + snr_db + 100.0
    src = rp.far_tonal(90.0, u * dur / 2, level_db=level)
    if tc is not None:
        src["tonals"][0]["coherence_time"] = tc
    d = rp.scenario(dur, u, [src], noise_db=noise_db, lateral_std=0.1 * rp.LAM,
                    lateral_snapshot=tb, seed=seed)
    p = rp.sim(d, tmp / f"etam_{snr_db:g}_{tc}.h5")
    kw = {"band": [236.0, 264.0], "beams": {"start": 80.0, "stop": 100.0, "count": 41}}
    phys = rp.run(rp.PSAS(snapshots=1, snapshot="etam", window="hann", **kw), p)
    etam = rp.run(rp.ETAM(snapshots=10, window="hann", **kw), p)
    return rp.target_gain(etam, phys, 90.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snapshots", type=int, default=30)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for snr in SNRS_DB:
            for tc in TCS:
                g = gain(Path(tmp), snr, tc, args.snapshots, seed=31)
                rows[f"{snr:g} dB, Tc {tc}"] = {"snr_db": snr, "tc_s": tc, "gain_db": g}
                print(f"SNR {snr:+5.0f} dB per hydrophone-bin, T_c "
                      f"{'coherent' if tc is None else f'{tc:g} s':>9}: ETAM gain {g:6.2f} dB "
                      "(ideal 10)", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
