"""``arrayproc tma A.h5 B.h5 -c cross_fix``: two static compact arrays' bearings products
through the command line's ``main`` → one ``tma`` row within 3σ of its CRLB; the refusals
(one products file, an array without its position, a second input for a one-file method)
are one line, exit 2, nothing written."""
from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.data import data_path
from arrayproc.evaluate.scenarios.two_array_fusion import write_array_products
from arrayproc.io.products import read_products
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.cross_fix import solve_cross_fix

SITES = np.array([[0.0, 0.0], [800.0, 0.0]])
TRUTH = np.array([-2000.0, 600.0, 7.3, 0.0])   # the paper's 7.3 m/s vessel, CPA 600 m
SIGMA_DEG = 1.5
TIMES = np.arange(0.0, 540.0 + 1e-9, 5.0)
CROSS_FIX = f"{data_path('tma')}/cross_fix.toml"


def _array(tmp_path, name, site, rng, nav=True, source=True):
    """A static tetrahedral array's recording and products file of azimuth rows (the true
    bearing of the vessel plus N(0, σ)); returns the products path and the azimuths, deg."""
    n = TIMES.size
    az = np.rad2deg(bearing_model(TRUTH, TIMES, np.tile(site, (n, 1))))
    az = (az + rng.normal(0.0, SIGMA_DEG, n)) % 360.0
    return write_array_products(tmp_path, name, site, TIMES, az, nav=nav, source=source), az


def _cli(args, capsys):
    rc = main([str(a) for a in args])
    return rc, capsys.readouterr().err.strip().splitlines()


def _state(g, i=0):
    return np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])


def test_two_arrays_through_the_command_line_within_3_sigma(tmp_path, capsys):
    rng = np.random.default_rng(5)
    (pa, aza), (pb, azb) = (_array(tmp_path, n, s, rng) for n, s in zip("AB", SITES))
    out = tmp_path / "tma.h5"
    rc, err = _cli(["tma", pa, pb, "-c", CROSS_FIX, "-o", out, "-q"], capsys)
    assert rc == 0, err
    g = read_products(str(out))["tma"]
    assert g["kind"] == "tma" and g["method"][0] == b"cross_fix" and g["x"].shape == (1,)
    est, crlb = _state(g), g["crlb"][0]
    sig = np.sqrt(np.diag(crlb))
    assert np.all(np.isfinite(sig)) and np.all(np.isfinite(g["cov"][0]))
    assert np.all(np.abs(est - TRUTH) < 3 * sig), ((est - TRUTH) / sig)
    np.testing.assert_allclose(g["attrs"]["array_x_m"], SITES[:, 0], atol=1e-9)
    # the estimated σ: each array's near the simulated 1.5°, so the solution and its bound are
    # close to those of the known σ (seed 5: within 0.24 σ; the weights of the two arrays
    # differ by their σ estimates' scatter, ~7 % each with 109 rows)
    t = np.concatenate([TIMES, TIMES])
    obs = np.repeat(SITES, TIMES.size, axis=0)
    y = np.deg2rad(np.concatenate([aza, azb]))
    known = solve_cross_fix(t, y, obs, np.deg2rad(SIGMA_DEG))
    assert np.all(np.abs(est - known.state) < 0.5 * sig), ((est - known.state) / sig)
    np.testing.assert_allclose(np.sqrt(np.diag(crlb)), np.sqrt(np.diag(known.crlb)),
                               rtol=0.2)
    # the same with the σ given: the solver's own solution on the same rows
    cfg = tmp_path / "known.toml"
    cfg.write_text(f'[tma]\nmethod = "cross_fix"\nsigma_bearing_deg = {SIGMA_DEG}\n')
    rc, err = _cli(["tma", pa, pb, "-c", cfg, "-o", tmp_path / "k.h5", "-q"], capsys)
    assert rc == 0, err
    gk = read_products(str(tmp_path / "k.h5"))["tma"]
    np.testing.assert_allclose(_state(gk), known.state, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(gk["crlb"][0], known.crlb[:4, :4], rtol=1e-9)


def _refused(tmp_path, args, capsys, match):
    before = set(tmp_path.iterdir())
    rc, err = _cli(args, capsys)
    assert rc == 2, err
    assert len(err) == 1 and err[0].startswith("arrayproc: error:"), err
    assert match in err[0], err[0]
    assert set(tmp_path.iterdir()) <= before       # nothing written, no temporary file
    assert not (tmp_path / "out.h5").exists()


@pytest.mark.parametrize("case", ["one_file", "no_nav", "no_source", "same_site"])
def test_refusals_are_one_line_exit_2(tmp_path, capsys, case):
    rng = np.random.default_rng(1)
    pa, _ = _array(tmp_path, "A", SITES[0], rng)
    kw = {"no_nav": dict(nav=False), "no_source": dict(source=False)}.get(case, {})
    pb, _ = _array(tmp_path, "B", SITES[0] if case == "same_site" else SITES[1], rng, **kw)
    args = ["tma", pa, "-c", CROSS_FIX, "-o", tmp_path / "out.h5"]
    if case != "one_file":
        args.insert(2, pb)
    match = {"one_file": "two or more products files", "no_nav": "has no /nav",
             "no_source": "names no recording", "same_site": "same position"}[case]
    _refused(tmp_path, args, capsys, match)


def test_several_inputs_for_a_one_file_method_are_refused(tmp_path, capsys):
    rng = np.random.default_rng(2)
    pa, _ = _array(tmp_path, "A", SITES[0], rng)
    pb, _ = _array(tmp_path, "B", SITES[1], rng)
    cfg = tmp_path / "compact.toml"
    cfg.write_text('[tma]\nmethod = "compact"\nspeed_mps = 7.3\n')
    _refused(tmp_path, ["tma", pa, pb, "-c", cfg, "-o", tmp_path / "out.h5"], capsys,
             "reads one products file")
