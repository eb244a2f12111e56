"""The report's page without a browser: the decimation against closed forms, sections only
for the products present, a page that fetches nothing, bounded sizes, and the command's
refusals."""

from __future__ import annotations

import re

import numpy as np
import pytest

from arrayproc.plots.interactive import decimate as dec
from tests.plots.report_data import other_kinds


def test_block_mean_db_averages_power_not_decibels():
    x = np.array([[0.0, 10.0, 20.0, 20.0, 5.0]])
    m, k = dec.block_mean_db(x, 1, 2)
    assert k == 3 and m.shape == (1, 2)
    want0 = 10 * np.log10((1 + 10 + 100) / 3)  # 10·log10(mean(10^(L/10)))
    want1 = 10 * np.log10((100 + 10 ** 0.5) / 2)  # the last block is shorter
    np.testing.assert_allclose(m[0], [want0, want1], rtol=1e-12)
    same, k1 = dec.block_mean_db(x, 1, 5)
    assert k1 == 1 and np.array_equal(same, x)


def test_block_max_keeps_a_one_bin_tonal():
    rng = np.random.default_rng(0)
    x = rng.normal(0.0, 1.0, (3, 1000))
    x[:, 617] = 30.0
    m, k = dec.block_max(x, 1, 100)
    assert k == 10 and m.shape == (3, 100)
    assert np.all(m[:, 61] == 30.0) and np.all(np.delete(m, 61, axis=1) < 30.0)
    np.testing.assert_allclose(dec.block_centres(np.arange(1000.0), k)[61], 614.5)  # 610..619


@pytest.mark.parametrize("n, n_max", [(1, 5), (10, 10), (11, 10), (1000, 7), (20001, 20000)])
def test_factor_and_stride_bound_the_size(n, n_max):
    k = dec.factor(n, n_max)
    assert -(-n // k) <= n_max and (k == 1 or -(-n // (k - 1)) > n_max)  # smallest such k
    assert dec.stride(n, n_max).size <= n_max


def _lofar_products(path, n=20, beams=91, bins=1000):
    from arrayproc.io.products import ProductsWriter
    rng = np.random.default_rng(2)
    p = rng.normal(0.0, 1.0, (n, beams, bins)).astype(np.float32)
    with ProductsWriter(path, attrs={"units": "Pa"}) as w:
        g = w.group("lofar", "lofar", normalise="tpsw")
        g.set("cone_deg", np.linspace(0.0, 180.0, beams))
        g.set("freq", np.linspace(10.0, 1000.0, bins))
        g.append(time=np.arange(n, dtype=float), power_db=p)
    return path


def test_a_large_lofar_is_bounded_and_the_page_says_how(tmp_path, monkeypatch):
    from bokeh.models import ColumnDataSource

    from arrayproc.io.products import read_products
    from arrayproc.plots.interactive.passive import btr_lofar
    monkeypatch.setattr(dec, "LOFAR_MAX_VALUES", 200_000)  # 20 beams of 20 x 500 values
    prod = read_products(_lofar_products(tmp_path / "big.h5"))
    g = prod["lofar"]
    rows, notes = btr_lofar(None, g, None, [], prod.root, None)
    held = {s.name: s for r in rows for s in r.select({"type": ColumnDataSource})}
    values = sum(np.asarray(v[0]).size for v in held["lofar_all"].data.values())
    assert 0 < values <= dec.LOFAR_MAX_VALUES and len(held["lofar_all"].data) == 19
    assert np.asarray(held["lofar_source"].data["image"][0]).shape == (20, 500)
    assert any("maximum" in s and "blocks of 2" in s for s in notes)
    assert any(s.startswith("LOFAR beams: every 5th of 91 kept (19)") for s in notes)


def test_sections_appear_only_for_the_products_present(tmp_path):
    from arrayproc.plots.interactive import build_report
    tracks, tma, other = other_kinds(tmp_path)
    page = build_report([other])
    assert page.sections == ["section-summary", "section-active", "section-tdoa"]
    page = build_report([tracks, tma])
    assert page.sections == ["section-summary", "section-tracks"]
    # self-contained: BokehJS inlined; outside the inlined scripts no tag loads anything
    markup = re.sub(r"(?s)<script[^>]*>.*?</script>", "", page.html)
    assert page.html.count("<script") >= 2 and not re.search(r"\b(src|href)\s*=", markup)
    assert "cdn.bokeh.org" not in page.html and "Bokeh.embed" in page.html


def test_the_command_writes_the_page_and_refuses_bad_outputs(tmp_path, capsys):
    from arrayproc.app.cli import main
    tracks, tma, other = other_kinds(tmp_path)
    out = tmp_path / "r.html"
    assert main(["report", str(other), str(tracks), str(tma), "-o", str(out)]) == 0
    assert "sections: summary, tracks, active, tdoa" in capsys.readouterr().out
    assert out.stat().st_size > 100_000
    for args, msg in (([str(other), "-o", str(tmp_path / "r.png")], "name it .html"),
                      ([str(tmp_path / "none.h5"), "-o", str(tmp_path / "n.html")],
                       "no such products file")):
        assert main(["report", *args]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1
    assert not (tmp_path / "r.png").exists() and not (tmp_path / "n.html").exists()
