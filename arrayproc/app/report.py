"""``arrayproc report``: products, tracks and TMA files as one interactive HTML page.

The page is built by :mod:`arrayproc.plots.interactive` (Bokeh, scripts inlined, nothing
fetched) and written atomically; this layer checks the inputs and the output's name and
turns a missing Bokeh into a one-line error.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from arrayproc.errors import ArrayprocError, FormatError
from arrayproc.io.atomic import check_output

#: Extensions the report may be written to.
HTML_SUFFIXES = (".html", ".htm")


def report(files: Sequence[str | os.PathLike], output: str | os.PathLike,
           title: str = "") -> dict[str, object]:
    """Write the interactive report of a run.

    Parameters
    ----------
    files : sequence of path-like
        The products file of the run first, then any tracks files and TMA products
        (``arrayproc track``, ``arrayproc tma``); every group of each is shown in the section
        of its kind.
    output : path-like
        The HTML file to write (``.html`` or ``.htm``).
    title : str
        Page title (default: from the first file's name).

    Returns
    -------
    dict
        ``sections`` (the CSS classes of the sections written, in page order) and ``bytes``
        (the page's size).

    Raises
    ------
    ArrayprocError
        No input, an output that is not ``.html``, Bokeh missing, or an input that is not a
        products file (FormatError, naming it).
    """
    from arrayproc.io.atomic import commit, discard, temporary_sibling
    from arrayproc.io.products import product_kinds
    if not files:
        raise ArrayprocError("report: give at least one products file")
    if Path(output).suffix.lower() not in HTML_SUFFIXES:
        raise ArrayprocError(f"{output}: the report is an HTML page; name it .html")
    check_output(output, list(files))
    for f in files:
        if not product_kinds(f):
            raise FormatError(f"{f}: products file has no group to report")
    try:
        import bokeh  # noqa: F401
    except ImportError:
        raise ArrayprocError("report needs Bokeh: pip install 'arrayproc[dask]' "
                             "(or pip install bokeh)") from None
    from arrayproc.plots.interactive import build_report
    page = build_report([str(f) for f in files], title=title)
    tmp = temporary_sibling(output)
    try:
        tmp.write_text(page.html, encoding="utf-8")
        commit(tmp, output)
    except BaseException:
        discard(tmp)
        raise
    return {"sections": page.sections, "bytes": len(page.html.encode())}


def _run(args) -> int:
    from arrayproc.app.progress import Summary
    done = Summary.of(args)
    r = report(args.files, args.output, title=args.title or "")
    sections = ", ".join(s.removeprefix("section-") for s in r["sections"])
    done(str(args.output), f"{r['bytes'] / 1e6:.1f} MB; sections: {sections}", None)
    return 0


def add_parser(sub) -> None:
    """Register ``arrayproc report`` on the command line's sub-parsers."""
    from arrayproc.app.options import add_output, add_quiet
    s = sub.add_parser("report", help="one self-contained interactive HTML page of a run's "
                       "products, tracks and TMA")
    s.add_argument("files", nargs="+", metavar="FILE",
                   help="the products file first, then tracks files and TMA products")
    add_output(s, "HTML file to write (.html)")
    s.add_argument("--title", default=None, help="page title (default: from the first file)")
    add_quiet(s)
    s.set_defaults(func=_run)
