"""Passive chain against the thesis closed forms: the numbers of docs/validation.md.

Measures, with the same set-ups as the tests (the functions of
:mod:`arrayproc.evaluate.scenarios.thesis_passive`):

- CBF beam pattern vs |I_NH|² (eq. 2.13): max |error| in dB over the main lobe and first
  sidelobes (down to −40 dB), θ0 = 60°, 90°, 125°;
- 3 dB beamwidth / 0.886 c/(f N_H δx sin θ0) (eq. 2.41) at θ0 = 90° and 60°;
- array gain (white noise vs plane wave) in dB vs 10 log10 N_H;
- KS p-values of the integrated noise against Γ(N_B) (eq. 2.24);
- DFT filter: passband ripple, stopband rejection, max deviation from scipy.signal.fftconvolve
  of the streamed output;
- end to end (``--e2e SECONDS``, default 50): bearing RMS errors and LOFAR line offsets.

    .venv/bin/python scripts/validate_passive.py [--e2e 180] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.thesis_passive import (
    array_gain_db,
    beamwidth_ratio,
    dft_filter_figures,
    e2e,
    gamma_ks,
    pattern_error,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--e2e", type=float, default=50.0, help="simulated seconds (0: skip)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    res = {
        "pattern_max_err_db": {f"{t:g}": pattern_error(t) for t in (60.0, 90.0, 125.0)},
        "beamwidth_ratio": {f"{t:g}": beamwidth_ratio(t) for t in (90.0, 60.0)},
        "array_gain_db": array_gain_db(), "array_gain_expected_db": 10 * np.log10(32),
        "gamma_ks_pvalue": {str(n): gamma_ks(n) for n in (1, 4, 10)},
        "dft_filter": dft_filter_figures(),
    }
    if args.e2e > 0:
        with tempfile.TemporaryDirectory() as d:
            res["e2e"] = {"seconds": args.e2e, **e2e(args.e2e, Path(d))}
    print(json.dumps(res, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
