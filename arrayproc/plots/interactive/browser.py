"""Opening a report in a real headless browser: Debian's chromium driven by playwright.

Used by the browser test and by ``scripts/report_screenshots.py``. The browser runs with a
fresh profile, no network services of its own (no sync, updates, QUIC or background
requests) and no sandbox (the test runs as root in CI containers). :func:`bokeh_state`
reads what BokehJS built: the document's data sources and how many values each holds, the
figures' ranges, and whether the canvases were drawn on.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

#: The chromium the project installs (``make browser``: Debian's package).
CHROMIUM = os.environ.get("ARRAYPROC_CHROMIUM", "/usr/bin/chromium")
#: Command-line flags of the headless browser.
CHROMIUM_ARGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync")


def browser_missing() -> str:
    """Why the browser cannot run here ('' when it can)."""
    if not Path(CHROMIUM).is_file():
        return f"no chromium at {CHROMIUM} (make browser installs Debian's chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (pip install -e '.[test]')"
    return ""


@contextmanager
def open_page(html: str | os.PathLike, width: int = 1280, height: int = 900
              ) -> Iterator[tuple[Any, list[str]]]:
    """The playwright page of ``html`` (a file) once BokehJS has rendered it, and the list
    the console errors and page errors are appended to while it is open. Every request the
    page makes is also listed, as ``"request: URL"`` unless it is the page itself: a
    self-contained page makes none."""
    from playwright.sync_api import sync_playwright
    errors: list[str] = []
    with tempfile.TemporaryDirectory() as profile, sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            profile, executable_path=CHROMIUM, headless=True, args=list(CHROMIUM_ARGS),
            viewport={"width": width, "height": height})
        try:
            page = ctx.new_page()
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            uri = Path(html).resolve().as_uri()
            page.on("request", lambda r: errors.append(f"request: {r.url}")
                    if r.url != uri else None)
            page.goto(uri)
            page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0 "
                                   "&& Bokeh.index && Object.keys(Bokeh.index).length > 0",
                                   timeout=60_000)
            page.wait_for_timeout(500)
            yield page, errors
        finally:
            ctx.close()


#: JavaScript: every named data source with the number of values in its columns, and the
#: ranges of every named figure (``all_models`` from BokehJS 3.2 on, ``_all_models`` in 3.1).
_STATE = """() => {
  const doc = Bokeh.documents[0];
  const out = {sources: {}, ranges: {}, titles: {}};
  const models = doc.all_models !== undefined ? doc.all_models : doc._all_models.values();
  for (const m of models) {
    if (m.type === "ColumnDataSource" && m.name) {
      let n = 0;
      for (const v of Object.values(m.data)) {
        for (const x of (v.length !== undefined ? Array.from(v) : [v])) {
          n += (x && x.length !== undefined) ? x.length : 1;
        }
      }
      out.sources[m.name] = n;
    }
    if (m.type === "Figure" && m.name) {
      out.ranges[m.name] = [m.x_range.start, m.x_range.end, m.y_range.start, m.y_range.end];
      out.titles[m.name] = m.title ? m.title.text : "";
    }
  }
  return out;
}"""


def bokeh_state(page: Any) -> dict[str, Any]:
    """``sources`` {name: values held}, ``ranges`` {figure: [x0, x1, y0, y1]} and
    ``titles`` {figure: text} of the page's Bokeh document."""
    return page.evaluate(_STATE)


def drawn_canvases(page: Any) -> list[int]:
    """For every canvas of the page (in Bokeh's shadow roots too), the number of distinct
    pixel colours over a 64×64 grid: a blank canvas has one."""
    return page.evaluate("""() => {
      const found = [];
      const walk = (root) => {
        for (const el of root.querySelectorAll("*")) {
          if (el.tagName === "CANVAS") found.push(el);
          if (el.shadowRoot) walk(el.shadowRoot);
        }
      };
      walk(document);
      return found.filter(c => c.width > 50 && c.height > 50).map(c => {
        const g = c.getContext("2d");
        const d = g.getImageData(0, 0, c.width, c.height).data;
        const seen = new Set();
        for (let i = 0; i < 64; i++) for (let j = 0; j < 64; j++) {
          const x = Math.floor(i * c.width / 64), y = Math.floor(j * c.height / 64);
          const k = 4 * (y * c.width + x);
          seen.add(d[k] + "," + d[k + 1] + "," + d[k + 2]);
        }
        return seen.size;
      });
    }""")


#: JavaScript: the viewport position (px) of data point (x, y) of the figure named ``name``,
#: after scrolling the figure into view.
_TO_PIXELS = """([name, x, y]) => {
  const find = (view) => {
    if (view.model && view.model.name === name) return view;
    for (const child of (view.child_views || [])) {
      const v = find(child);
      if (v) return v;
    }
    return null;
  };
  for (const root of Object.values(Bokeh.index)) {
    const v = find(root);
    if (!v) continue;
    v.el.scrollIntoView({block: "center"});
    const box = v.el.getBoundingClientRect();
    return [box.x + v.frame.x_scale.compute(x), box.y + v.frame.y_scale.compute(y)];
  }
  return null;
}"""


def data_point(page: Any, name: str, x: float, y: float) -> tuple[float, float]:
    """Viewport pixel (px) of data coordinates (x, y) on the figure named ``name`` (the
    figure is scrolled into view first)."""
    p = page.evaluate(_TO_PIXELS, [name, x, y])
    if p is None:
        raise LookupError(f"no figure named {name!r} on the page")
    return float(p[0]), float(p[1])
