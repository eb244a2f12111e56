"""The plots' two layers: ``draw_*`` functions draw data on a matplotlib Axes the caller gives
and return its Figure; the file writers draw on a Figure outside pyplot, so writing files
neither imports pyplot nor selects a backend, and importing the plots selects none."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest


def _btr_group(n: int = 6, beams: int = 5) -> tuple[dict, dict]:
    rng = np.random.default_rng(3)
    g = {"time": np.arange(n, dtype=float), "cone_deg": np.linspace(0.0, 180.0, beams),
         "power_db": rng.standard_normal((n, beams)), "attrs": {"freq_lo": 100.0,
                                                                "freq_hi": 400.0}}
    return g, {"units": "Pa"}


def test_draw_btr_draws_on_the_given_axes():
    from matplotlib.figure import Figure

    from arrayproc.plots.btr import draw_btr
    fig = Figure()
    ax, other = fig.subplots(1, 2)
    g, root = _btr_group()
    assert draw_btr(g, root, ax, truth=False, file="x.h5") is fig
    assert ax.get_xlabel().startswith("cone angle") and ax.get_title() == \
        "BTR, 100-400 Hz\nx.h5"
    assert other.get_title() == "" and not other.images  # nothing drawn beside it
    assert len(ax.images) == 1


def test_draw_without_axes_makes_a_pyplot_figure():
    import matplotlib
    matplotlib.use("Agg")  # the test's choice of backend, not the package's
    import matplotlib.pyplot as plt

    from arrayproc.plots.btr import LAYOUT, draw_btr
    g, root = _btr_group()
    fig = draw_btr(g, root, truth=False)
    try:
        assert plt.fignum_exists(fig.number)
        assert tuple(fig.get_size_inches()) == LAYOUT["figsize"] and fig.dpi == LAYOUT["dpi"]
    finally:
        plt.close(fig)


@pytest.mark.parametrize("draw", ["rmse_curves", "geometry"])
def test_script_plots_return_a_figure_without_a_file(draw):
    from matplotlib.figure import Figure

    from arrayproc.plots.rmse import plot_rmse_curves, plot_scenario_geometry
    ax = Figure().subplots()
    t = np.linspace(0.0, 10.0, 5)
    if draw == "rmse_curves":
        fig = plot_rmse_curves(t, {"a": t + 1.0}, ax=ax)
    else:
        xy = np.c_[t, t]
        fig = plot_scenario_geometry(xy, xy[::-1], ax=ax)
    assert fig is ax.figure and ax.lines


PROBE = """
import json, sys
import matplotlib
before = matplotlib.rcParams._get_backend_or_none()
import arrayproc.plots as p
p._load()
after_import = matplotlib.rcParams._get_backend_or_none()
p.plot_file(sys.argv[1], sys.argv[2], "btr", truth=False)
print(json.dumps([before, after_import, "matplotlib.pyplot" in sys.modules]))
"""


def test_writing_a_file_needs_no_backend_and_no_pyplot(tmp_path):
    from arrayproc.io.products import ProductsWriter
    g, _ = _btr_group()
    with ProductsWriter(tmp_path / "p.h5") as w:
        b = w.group("btr", "btr", freq_lo=100.0, freq_hi=400.0)
        b.set("cone_deg", g["cone_deg"])
        b.append(time=g["time"], power_db=g["power_db"])
    out = tmp_path / "btr.png"
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    r = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path / "p.h5"), str(out)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    before, after_import, pyplot = json.loads(r.stdout.strip().splitlines()[-1])
    assert after_import == before and pyplot is False
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
