"""``arrayproc track`` and ``arrayproc tma``: measurements of a products file into tracks or
batch TMA solutions. The configuration is checked first, then the products' columns, and the
recording the products name (its navigation is read) is among the inputs an output must not
replace.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from arrayproc.app.inputs import TRACK_INPUT, check_product_input
from arrayproc.errors import ArrayprocError
from arrayproc.io.atomic import check_output


def track(products: str | Sequence[str], config: str, output: str,
          progress: bool = False) -> None:
    """Track targets from a products file's bearings into a tracks file.

    Parameters
    ----------
    products : str or sequence of str
        Products HDF5 file with a bearings group; for ``measurements = "fused_bearings"``
        two or more, one per static array, each naming its recording (the array's
        position, :mod:`arrayproc.track.multi.fused`).
    config : str
        Tracker TOML file.
    output : str
        Tracks HDF5 file to write.
    progress : bool
        Progress messages on stderr.
    """
    paths = [products] if isinstance(products, str) else list(products)
    inputs = [*paths, config]
    for p in paths:
        rec = _products_source(p)
        if rec is not None:
            inputs.append(rec)  # the recording whose navigation the tracker reads
    check_output(output, inputs)
    from arrayproc.track.runner import check_one_input, load_tracker_config
    cfg = load_tracker_config(config)  # configuration errors first, before the products are read
    multi = cfg.get("mode") == "multi"
    if not (multi and cfg["multi"]["measurements"] == "fused_bearings"):
        check_one_input(paths, config, cfg)
    if not multi or cfg["multi"]["measurements"] in ("bearings", "fused_bearings"):
        for p in paths:
            check_product_input(p, "the tracker", TRACK_INPUT, empty_ok=True)
    from arrayproc.chain.guard import running
    from arrayproc.track.runner import run_tracker
    with running(f"the tracker of {Path(config).name}"):  # named by the memory guard
        run_tracker(paths if len(paths) > 1 else paths[0], config, output,
                    progress=progress, cfg=cfg)


def _products_source(products: str) -> str | None:
    """The recording a products file names in its ``source`` attribute (if it exists)."""
    try:
        from arrayproc.io.products import products_source
        src = products_source(products)
    except ArrayprocError:
        return None
    if not src:
        return None
    for p in (Path(src), Path(products).parent / src):  # as the tracker resolves it
        if p.exists():
            return str(p)
    return None


# -- tma --------------------------------------------------------------------------------------
def tma(products: str | Sequence[str], config: str, output: str,
        progress: bool = False) -> None:
    """Batch maximum-likelihood TMA with its CRLB (thesis 3.3; compact-array paper eqs. 1-5).

    Parameters
    ----------
    products : str or sequence of str
        Products HDF5 file with a bearings, lines or delays group, or a tracks file of the
        multi-target tracker (one solution per confirmed track,
        :mod:`arrayproc.track.batch.per_track`); for ``method = "cross_fix"`` two or more
        products files, one per static array (:mod:`arrayproc.track.batch.cross_fix_run`),
        or two arrays' tracks files (:mod:`arrayproc.track.batch.cross_fix_tracks`), or one
        tracks file of the fused tracker (:mod:`arrayproc.track.batch.cross_fix_fused`).
    config : str
        TMA TOML file (``[tma] method = "bearings" | "bearings_frequency" | "delays" |
        "compact" | "cross_fix" | "auto"``, …).
    output : str
        Products HDF5 file to write (one ``tma`` group).
    progress : bool
        One line per solution on stderr.
    """
    paths = [products] if isinstance(products, str) else list(products)
    inputs = [*paths, config]
    for p in paths:
        rec = _products_source(p)
        if rec is not None:
            inputs.append(rec)  # the recording whose navigation and geometry are read
    check_output(output, inputs)
    from arrayproc.chain.guard import running
    from arrayproc.track.batch.inputs import run_tma_inputs
    with running(f"the TMA of {Path(config).name}"):  # named by the memory guard
        run_tma_inputs(paths, config, output, progress=progress)


def tracks_summary(path: str) -> str:
    """``N tracks, M points`` (``no tracks (…): empty tracks table`` for an empty result), read
    from the tracks file just written, for the summary line."""
    import numpy as np

    from arrayproc.io.products import read_products
    ids = [np.asarray(g["track_id"]).reshape(-1)
           for g in read_products(path).groups("tracks").values() if "track_id" in g]
    n_pts = sum(i.size for i in ids)
    if n_pts == 0:
        return "no tracks (no measurements to track): empty tracks table"
    n_tr = sum(np.unique(i).size for i in ids)
    return f"{n_tr} track{'s' * (n_tr != 1)}, {n_pts} points"
