"""The interactive HTML report: one self-contained Bokeh page of a run's products.

Each section is built by its own module from products groups read with
:func:`arrayproc.io.products.read_products` (``ProductsFile.groups(kind)``) and appears only
when its products are present:

* :mod:`~arrayproc.plots.interactive.passive`: the BTR with bearing detections and tracks
  overlaid, the LOFAR of the beam under the cursor, the bearing-time plot (port/starboard);
* :mod:`~arrayproc.plots.interactive.tracks`: the track map with TMA solutions and their
  ellipses;
* :mod:`~arrayproc.plots.interactive.active`: range-Doppler maps and the contact list;
* :mod:`~arrayproc.plots.interactive.tdoa`: delays and localised positions;
* :mod:`~arrayproc.plots.interactive.summary`: the summary table (recording, chain,
  durations, counts);
* :mod:`~arrayproc.plots.interactive.page`: the page itself, with BokehJS inlined
  (``bokeh.resources.INLINE``) so it opens offline and fetches nothing;
* :mod:`~arrayproc.plots.interactive.browser`: the page opened in headless chromium
  (playwright), for the browser test and the screenshots.

Large products are decimated to a bounded size by :mod:`~arrayproc.plots.interactive.decimate`
and the page says what was decimated and how. Bokeh draws the figures and runs the linking in
the browser (``CustomJS``): nothing here re-implements plotting. This package imports Bokeh
only inside its functions, so loading the plotters costs nothing without it.
"""

from __future__ import annotations

__all__ = ["build_report"]


def build_report(files, title: str = ""):
    """The report of products/tracks files: ``(html, sections)``
    (:func:`arrayproc.plots.interactive.page.build_report`)."""
    from arrayproc.plots.interactive.page import build_report as _build
    return _build(files, title=title)
