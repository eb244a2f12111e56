"""Issue 12/13 start-up: ``arrayproc --version`` and ``info`` import no heavy module (scipy,
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
