"""``arrayproc demo``: the main job end to end on the bundled examples, with its plots.

1. Towed array, passive: simulate ``data/scenarios/towed_passive.toml`` → process with
   ``data/chains/towed_passive.toml`` (DFT filter, CBF, integration, BTR, LOFAR, bearings) →
   BTR and LOFAR plots → track the merchant from its bearings with a UKF resolving the
   left-right ambiguity (``data/trackers/towed_demo.toml``) → track plot.
2. Passive synthetic aperture: simulate ``data/scenarios/towed_synthetic_aperture.toml`` (a
   weak 250 Hz tonal at cone 100°, a loud broadband source astern, lateral array motion) →
   BTR of the conventional beamformer (``data/chains/cbf_narrowband.toml``) beside the BTR of
   inverse beamforming + ETAM (``data/chains/ibf_etam.toml``).
3. Field data: import the six-hydrophone recording (when ``../shared/data`` is beside the
   checkout) → per-channel band power.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from arrayproc.app.cli import main as cli_main
from arrayproc.data import data_path

DATA = data_path()


def field_recording_dir() -> Path | None:
    """The six-hydrophone field recording: ``$ARRAYPROC_XAV``, else ``shared/data/xav-large-array``
    beside the current directory or one of its parents (a checkout with ``../shared``)."""
    env = os.environ.get("ARRAYPROC_XAV")
    if env:
        return Path(env) if Path(env).is_dir() else None
    for d in (Path.cwd(), *Path.cwd().parents):
        for cand in (d / "shared" / "data" / "xav-large-array",
                     d.parent / "shared" / "data" / "xav-large-array"):
            if cand.is_dir():
                return cand
    return None


def _run(args: list[str]) -> None:
    print("$ arrayproc " + " ".join(args), flush=True)
    rc = cli_main(args)
    if rc:
        raise SystemExit(rc)


def run_demo(outdir: str = "demo_out", progress: bool = False) -> None:
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    np_ = [] if progress else ["--no-progress"]
    scenario = DATA / "scenarios" / "towed_passive.toml"
    chain = DATA / "chains" / "towed_passive.toml"
    if scenario.exists() and chain.exists():
        rec = out / "towed_passive.h5"
        prod = out / "towed_passive_products.h5"
        _run(["simulate", str(scenario), "-o", str(rec), *np_])
        _run(["process", str(rec), "-c", str(chain), "-o", str(prod), *np_])
        _run(["info", str(prod)])
        _run(["plot", str(prod), "--kind", "btr", "-o", str(out / "btr.png")])
        _run(["plot", str(prod), "--kind", "lofar", "--beam", "56", "-o",
              str(out / "lofar.png")])
        tracks = out / "towed_passive_tracks.h5"
        _run(["track", str(prod), "-c", str(DATA / "trackers" / "towed_demo.toml"), "-o",
              str(tracks), *np_])
        _run(["plot", str(tracks), "--kind", "track", "-o", str(out / "track.png")])
    scenario = DATA / "scenarios" / "towed_synthetic_aperture.toml"
    if scenario.exists():
        rec = out / "synthetic_aperture.h5"
        _run(["simulate", str(scenario), "-o", str(rec), *np_])
        for name in ("cbf_narrowband", "ibf_etam"):
            prod = out / f"synthetic_aperture_{name}.h5"
            _run(["process", str(rec), "-c", str(DATA / "chains" / f"{name}.toml"), "-o",
                  str(prod), *np_])
            _run(["plot", str(prod), "--kind", "btr", "-o", str(out / f"btr_{name}.png")])
    xav = field_recording_dir()
    if xav is not None:
        wavs = sorted(str(p) for p in xav.glob("AMAR173.*.wav"))
        rec = out / "xav.h5"
        _run(["import", *wavs, "--geometry", str(xav / "hydrophones_config_07-HI.csv"),
              "--sound-speed", "1484", "-o", str(rec)])
        _run(["info", str(rec)])
        _run(["process", str(rec), "-c", str(DATA / "chains" / "power.toml"), "-o",
              str(out / "xav_power.h5"), *np_])
        _run(["info", str(out / "xav_power.h5")])
    print(f"demo outputs in {out}/", file=sys.stderr)
