"""The report in a real browser: Debian's chromium (``make browser``) driven by playwright.

The page of a short simulated towed run plus hand-written groups of every other kind is
opened headless; it must render without a console error, every plot's data source must
hold data and its canvas be drawn on, and the interactions must change the view: the wheel
zooms the BTR, a click on the BTR puts the clicked beam's LOFAR up, and picking another
range-Doppler map swaps the image. Without a browser the test skips, except in CI
(``CI=true``), where a missing browser is a failure.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from arrayproc.plots.interactive.browser import (
    bokeh_state,
    browser_missing,
    data_point,
    drawn_canvases,
    open_page,
)
from tests.plots.report_data import other_kinds

#: The figures of a page with every section, and the data sources each must fill.
FIGURES = ("btr", "lofar", "bearings_port", "bearings_starboard", "track_map",
           "range_doppler", "contacts", "delays", "positions")
SOURCES = ("btr_source", "lofar_source", "lofar_all", "btr_detections", "bearings_port_source",
           "bearings_starboard_source", "track_0", "range_doppler_source", "contacts_source",
           "contact_list", "delays_ch1", "positions_source", "summary_source")


@pytest.fixture(scope="module")
def page_file(tmp_path_factory, towed_run):
    why = browser_missing()
    if why:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"CI needs the browser test: {why}")
        pytest.skip(why)
    from arrayproc.app.report import report
    d = tmp_path_factory.mktemp("report")
    out = d / "report.html"
    report([towed_run, *other_kinds(d)], out)
    return out


@pytest.fixture(scope="module")
def opened(page_file):
    """The page open in chromium (one browser for the module's tests, in order) with the
    console errors seen so far."""
    with open_page(page_file) as (page, errors):
        yield page, errors


def _lofar_state(page) -> tuple[int, float, float]:
    """The LOFAR's beam index, its cone angle and a checksum of the image shown."""
    return tuple(page.evaluate("""() => {
      const doc = Bokeh.documents[0];
      const s = doc.get_model_by_name("lofar_state").data;
      const img = doc.get_model_by_name("lofar_source").data.image[0];
      let sum = 0;
      for (let i = 0; i < img.length; i += 7) sum += (isFinite(img[i]) ? img[i] : 0);
      return [s.beam[0], s.cone[0], sum];
    }"""))


def test_the_page_renders_with_data_and_drawn_canvases(opened):
    page, errors = opened
    state = bokeh_state(page)
    canvases = drawn_canvases(page)
    assert errors == []
    assert set(FIGURES) <= set(state["ranges"]), sorted(state["ranges"])
    empty = [s for s in SOURCES if state["sources"].get(s, 0) == 0]
    assert not empty, f"empty or missing data sources: {empty}"
    # each figure draws on its own canvas: at least one per figure shows many colours
    assert sum(c > 20 for c in canvases) >= len(FIGURES), canvases


def test_wheel_zoom_click_and_pick_change_the_view(opened):
    page, errors = opened
    x0, x1, y0, y1 = bokeh_state(page)["ranges"]["btr"]
    beam0, cone0, sum0 = _lofar_state(page)
    target = 120.0 if abs(cone0 - 120.0) > 20 else 40.0
    t_mid = 0.5 * (y0 + y1)
    page.mouse.click(*data_point(page, "btr", target, t_mid))
    page.wait_for_timeout(300)
    beam1, cone1, sum1 = _lofar_state(page)
    title = bokeh_state(page)["titles"]["lofar"]
    page.mouse.move(*data_point(page, "btr", 0.5 * (x0 + x1), t_mid))
    page.mouse.wheel(0, -400)
    page.wait_for_timeout(400)
    z0, z1, _, _ = bokeh_state(page)["ranges"]["btr"]
    page.locator("select").first.select_option(index=1)  # the range-Doppler map list
    page.wait_for_timeout(300)
    rd_title = bokeh_state(page)["titles"]["range_doppler"]
    assert errors == []
    assert beam1 != beam0 and abs(cone1 - target) <= 5.0, (cone0, cone1, target)
    assert sum1 != sum0  # another beam's LOFAR is shown
    assert f"{cone1:.1f} deg" in title
    assert (z1 - z0) < 0.9 * (x1 - x0) and x0 <= z0 < z1 <= x1  # zoomed in on the BTR
    assert "ping 1" in rd_title
    assert np.isfinite([z0, z1]).all()
