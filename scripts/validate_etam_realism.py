"""ETAM gain against SNR and the tonal's coherence time (thesis 2.2.3.2 and 2.3) on simulator
recordings (docs/validation/realism.md).

Set-up of scripts/reproduce_psas.py (64 hydrophones 0.36 m apart towed north, a 250 Hz tonal
from a distant broadside source, half-overlapping snapshots T_B = (N_H − 1)δx/(2U) = 4 s,
N_B = 10, lateral motion σ = 0.1 λ so that ETAM has phases to correct), with white noise at
60 dB re 1 µPa²/Hz and the tonal's in-bin SNR per hydrophone set by its level; the tonal's
phase a random walk of coherence time T_c (``coherence_time``). Two measures: noise-free, the
mean ETAM cell power over N_B times one physical snapshot's (as for fig. 2.12); with noise,
the excess of the target cell over the neighbouring bins, ETAM over one physical snapshot
(``target_gain`` of reproduce_psas.py). Ideal 10 log10 N_B = 10 dB.

    .venv/bin/python scripts/validate_etam_realism.py [--snapshots 30] [--snr-snapshots 100]
        [--json OUT]
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

SNRS_DB = [-25.0, -20.0, -15.0, -10.0, -5.0, 0.0]  # tonal over noise in one bin, per element
TCS = [None, 100.0, 30.0, 10.0, 4.0, 2.0]  # s (None: coherent)
TB = 4.0
N_B = 10
KW = {"band": [236.0, 264.0], "beams": {"start": 80.0, "stop": 100.0, "count": 41}}


def recording(tmp: Path, snr_db: float | None, tc: float | None, n_snap: int,
              seed: int) -> Path:
    """The towed-array recording: noise 60 dB re 1 µPa²/Hz and the tonal at ``snr_db`` in one
    1/T_B bin per hydrophone (None: noise-free, the tonal at 0 dB re that noise)."""
    u = (rp.N_H - 1) * rp.DX / (2 * TB)
    dur = TB * n_snap
    noise_db = 60.0
    # in-bin tonal power P over the noise N/T_B: P = N − 10 log10 T_B + SNR, source 100 km away
    level = noise_db - 10 * np.log10(TB) + (snr_db or 0.0) + 100.0
    src = rp.far_tonal(90.0, u * dur / 2, level_db=level)
    if tc is not None:
        src["tonals"][0]["coherence_time"] = tc
    d = rp.scenario(dur, u, [src], noise_db=noise_db if snr_db is not None else None,
                    lateral_std=0.1 * rp.LAM, lateral_snapshot=TB, seed=seed)
    return rp.sim(d, tmp / f"etam_{snr_db}_{tc}_{seed}.h5")


def coherence_gain(tmp: Path, tc: float | None, n_snap: int) -> tuple[float, float, float]:
    """Noise-free: (ETAM gain dB = mean ETAM cell power over N_B times one physical
    snapshot's; the ETAM and the physical cell powers, linear, for absolute comparisons)."""
    p = recording(tmp, None, tc, n_snap, seed=31)
    one = rp.cell_power(rp.run(rp.PSAS(snapshots=1, snapshot="etam", **KW), p), 90.0).mean()
    et = rp.cell_power(rp.run(rp.ETAM(snapshots=N_B, **KW), p), 90.0).mean()
    return float(10 * np.log10(et / (N_B * one))), float(et), float(one)


def snr_gain(tmp: Path, snr_db: float, tc: float | None, n_snap: int) -> float:
    """With noise: excess of the target cell over the neighbouring bins, ETAM over one
    physical snapshot (``target_gain`` of reproduce_psas.py), dB."""
    p = recording(tmp, snr_db, tc, n_snap, seed=41)
    phys = rp.run(rp.PSAS(snapshots=1, snapshot="etam", window="hann", **KW), p)
    etam = rp.run(rp.ETAM(snapshots=N_B, window="hann", **KW), p)
    return rp.target_gain(etam, phys, 90.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snapshots", type=int, default=30, help="noise-free runs")
    ap.add_argument("--snr-snapshots", type=int, default=100, help="runs with noise")
    ap.add_argument("--no-snr", action="store_true", help="only the noise-free sweep")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    rows: dict = {"coherence": {}, "snr": {}}
    with tempfile.TemporaryDirectory() as tmp:
        ref = None
        for tc in TCS:
            g, et, one = coherence_gain(Path(tmp), tc, args.snapshots)
            ref = ref or (et, one)  # the coherent tonal's (first in TCS)
            rows["coherence"][str(tc)] = {"gain_db": g,
                                          "etam_re_coherent_db": 10 * np.log10(et / ref[0]),
                                          "physical_re_coherent_db": 10 * np.log10(
                                              one / ref[1])}
            print(f"noise-free, T_c {'coherent' if tc is None else f'{tc:g} s':>9}: ETAM gain "
                  f"{g:6.2f} dB (ideal {10 * np.log10(N_B):.0f}); ETAM cell "
                  f"{10 * np.log10(et / ref[0]):+.2f} dB and physical cell "
                  f"{10 * np.log10(one / ref[1]):+.2f} dB re the coherent tonal", flush=True)
        if args.no_snr:
            return _dump(rows, args.json)
        for tc in (None, 10.0):
            for snr in SNRS_DB:
                g = snr_gain(Path(tmp), snr, tc, args.snr_snapshots)
                rows["snr"][f"{snr:g}, {tc}"] = {"snr_db": snr, "tc_s": tc, "gain_db": g}
                print(f"SNR {snr:+5.0f} dB per hydrophone-bin, T_c "
                      f"{'coherent' if tc is None else f'{tc:g} s':>9}: ETAM gain {g:6.2f} dB",
                      flush=True)
    _dump(rows, args.json)


def _dump(rows: dict, path: str | None) -> None:
    if path:
        Path(path).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
