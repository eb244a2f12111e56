"""Start-up: ``arrayproc --version`` and ``info`` import no heavy module (scipy,
numba, matplotlib, dask, the stage registry); the time itself is measured outside the tests
(docs/performance/startup.md)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from arrayproc.io.geometry import line_array
from tests.conftest import write_recording

HEAVY = ("scipy", "numba", "matplotlib", "dask", "distributed", "pyfftw", "arrayproc.stages",
         "arrayproc.sim", "arrayproc.track", "arrayproc.plots")

PROBE = """
import json, sys
from arrayproc.app.cli import main
try:
    rc = main(sys.argv[1:])
except SystemExit as e:
    rc = e.code
print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {0!r} or
                        m.startswith({1!r}))), file=sys.stderr)
"""


def _heavy_modules(*args: str) -> list[str]:
    roots = sorted({h.split(".")[0] for h in HEAVY if "." not in h})
    code = PROBE.format(roots, tuple(h for h in HEAVY if "." in h))
    r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True)
    return json.loads(r.stderr.strip().splitlines()[-1])


def test_version_imports_nothing_heavy():
    assert _heavy_modules("--version") == []


def test_info_imports_nothing_heavy(tmp_path, rng):
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((100, 4)).astype(np.float32),
                          positions=line_array(4, 0.5))
    assert _heavy_modules("info", str(rec)) == []


# `process` with the shipped towed-array chain (dft_filter, CBF, integrate, BTR,
# LOFAR, bearings) runs without importing these: windows and tapers are closed forms (or
# numpy's Kaiser), pyfftw (which imports dask.array) and scipy.fft load only when a path uses
# them. scipy.linalg is not listed: numba imports it on its first compile or cache load.
PROCESS_FORBIDDEN = ("scipy.signal", "scipy.stats", "scipy.optimize", "scipy.interpolate",
                     "pyfftw", "dask", "distributed", "matplotlib", "arrayproc.sim",
                     "arrayproc.track", "arrayproc.plots")

PROCESS_PROBE = """
import json, sys
from arrayproc.app.cli import main
rc = main(sys.argv[1:])
print(json.dumps([rc, sorted(sys.modules)]), file=sys.stderr)
"""


def test_process_of_the_towed_chain_imports_no_scipy_signal_pyfftw_or_dask(tmp_path, rng):
    from arrayproc.data import data_path
    from arrayproc.dsp import fft

    rec = write_recording(tmp_path / "r.h5",
                          rng.standard_normal((3 * 2048, 8)).astype(np.float32), fs=2048.0,
                          positions=line_array(8, 0.75))
    chain = data_path("chains", "towed_passive.toml")
    r = subprocess.run([sys.executable, "-c", PROCESS_PROBE, "process", str(rec), "-c",
                        str(chain), "-o", str(tmp_path / "p.h5"), "-q", "--no-progress"],
                       capture_output=True, text=True)
    rc, modules = json.loads(r.stderr.strip().splitlines()[-1])
    assert rc == 0 and (tmp_path / "p.h5").exists()
    loaded = [m for m in modules if any(m == f or m.startswith(f + ".")
                                        for f in PROCESS_FORBIDDEN)]
    assert loaded == []
    assert "arrayproc.stages.beamform.cbf" in modules  # the probe did run the chain
    if fft.HAVE_DUCC:  # the FFT sizes and plans come from ducc0 then
        assert "scipy.fft" not in modules
