"""The report page: sections for the products present, assembled into one self-contained
HTML document (BokehJS inlined with ``bokeh.resources.INLINE``; nothing is fetched)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from arrayproc.plots.interactive.common import WIDTH, heading, notes, source_recording

#: The sections in page order: (CSS class, title, the kinds that make it appear).
SECTIONS = (("section-summary", "Summary", ()),
            ("section-passive", "BTR and LOFAR", ("btr", "lofar")),
            ("section-bearings", "Bearings against time", ("bearings",)),
            ("section-tracks", "Track map", ("tracks", "tma")),
            ("section-active", "Active: range-Doppler and contacts", ("range_doppler",
                                                                       "contacts")),
            ("section-tdoa", "TDOA: delays and positions", ("delays", "positions")))

_INTRO = ("Wheel: zoom; drag: pan; the toolbar of each plot resets it. On the BTR, the LOFAR "
          "beside it follows the beam under the cursor; a click pins that beam. Legends hide "
          "an overlay when clicked. Time runs down on every time plot (sonar orientation); "
          "bearings are true, clockwise from north; cone angles 0° forward end-fire.")


class _Found:
    """The groups of each kind over all the files, each with its file's root attributes and
    path (the first group of a kind drives its section)."""

    def __init__(self, files: list[tuple[str, Any]]):
        self.by_kind: dict[str, list[tuple[dict, dict, str]]] = {}
        for path, prod in files:
            for name, g in prod.items():
                if name != "/":
                    self.by_kind.setdefault(g.kind, []).append((g, prod.root, path))
        self._recs: dict[str, Any] = {}

    def first(self, kind: str) -> dict | None:
        g = self.by_kind.get(kind)
        return g[0][0] if g and _has_rows(g[0][0]) else None

    def all(self, kind: str) -> list[dict]:
        return [g for g, _, _ in self.by_kind.get(kind, []) if _has_rows(g)]

    def recording(self, kind: str):
        """The truth recording of the first group of ``kind`` (None without truth)."""
        if kind not in self.by_kind:
            return None
        root = self.by_kind[kind][0][1]
        path = source_recording(root)
        if path not in self._recs:
            from arrayproc.plots.interactive.common import truth_recording
            self._recs[path] = truth_recording(path)
        return self._recs[path]

    def close(self) -> None:
        for r in self._recs.values():
            if r is not None:
                r.close()


def _has_rows(g: dict) -> bool:
    for c in ("time", "time_start", "t0"):
        if c in g:
            return bool(np.size(g[c]))
    return False


def _elements(found: _Found) -> np.ndarray | None:
    """The hydrophones (n, 3) m of the recording the positions came from, when at hand."""
    root = found.by_kind["positions"][0][1]
    path = source_recording(root)
    if not path:
        return None
    from arrayproc.io.recording import Recording
    with Recording(path) as rec:
        return np.asarray(rec.pose(0.0).elements, float)


def _sections(found: _Found, files: list[tuple[str, Any]]) -> list[tuple[str, list, list]]:
    """(CSS class, figures, notes) of each section whose products are present."""
    from arrayproc.plots.interactive import active, passive, summary, tdoa, tracks
    out = [("section-summary", [summary.summary_table(files)], [])]
    btr, lofar, brg = found.first("btr"), found.first("lofar"), found.first("bearings")
    trk, tma = found.all("tracks"), found.all("tma")
    if btr is not None or lofar is not None:
        rec = found.recording("btr" if btr is not None else "lofar")
        out.append(("section-passive", *passive.btr_lofar(btr, lofar, brg, trk, {
            **found.by_kind["btr" if btr is not None else "lofar"][0][1]}, rec)))
    if brg is not None:
        out.append(("section-bearings", *passive.bearing_time(brg, trk,
                                                              found.recording("bearings"))))
    if trk or tma:
        rec = found.recording("tracks" if trk else "tma")
        out.append(("section-tracks", *tracks.track_map(trk, tma, rec)))
    rd, ct = found.first("range_doppler"), found.first("contacts")
    if rd is not None or ct is not None:
        figs, nts = [], []
        for g, make, kind in ((rd, active.range_doppler, "range_doppler"),
                              (ct, active.contacts, "contacts")):
            if g is not None:
                f, n = make(g, found.recording(kind))
                figs += f
                nts += n
        out.append(("section-active", figs, nts))
    dl, ps = found.first("delays"), found.first("positions")
    if dl is not None or ps is not None:
        from bokeh.layouts import row
        figs, nts = [], []
        if dl is not None:
            f, n = tdoa.delays(dl, found.by_kind["delays"][0][2])
            figs += f
            nts += n
        if ps is not None:
            f, n = tdoa.positions(ps, _elements(found))
            figs += f
            nts += n
        out.append(("section-tdoa", [row(*figs)], nts))
    return out


class ReportPage(NamedTuple):
    """A built report: the HTML document and the sections it holds (their CSS classes, in
    page order)."""

    html: str
    sections: list[str]


def build_report(files: Sequence[str | os.PathLike], title: str = "") -> ReportPage:
    """The report of products and tracks files as one self-contained HTML page.

    Parameters
    ----------
    files : sequence of path-like
        Products files (the first is the run's), tracks files and TMA products; every
        group of each is read with :func:`arrayproc.io.products.read_products`.
    title : str
        The page title (default: from the first file's name).

    Returns
    -------
    ReportPage
        The HTML document, with BokehJS inlined, and the sections present.
    """
    from bokeh.embed import file_html
    from bokeh.layouts import column
    from bokeh.resources import INLINE

    from arrayproc.io.products import read_products
    read = [(str(p), read_products(p)) for p in files]
    title = title or f"arrayproc report: {Path(read[0][0]).name}"
    found = _Found(read)
    try:
        parts = _sections(found, read)
    finally:
        found.close()
    titles = {c: t for c, t, _ in SECTIONS}
    blocks = [heading(title, _INTRO, level=1)]
    for css, figs, nts in parts:
        items = [heading(titles[css]), *figs]
        n = notes(nts)
        if n is not None:
            items.append(n)
        blocks.append(column(*items, css_classes=[css], name=css))
    doc = column(*blocks, width=WIDTH + 40)
    return ReportPage(file_html(doc, resources=INLINE, title=title), [p[0] for p in parts])
