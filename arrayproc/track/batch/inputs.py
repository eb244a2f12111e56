"""Which batch TMA reads a ``tma`` command's inputs: one products file (:mod:`.run`), one
tracks file (:mod:`.per_track`), or, for ``method = "cross_fix"``, two or more products files
(:mod:`.cross_fix_run`) or two tracks files (:mod:`.cross_fix_tracks`), one per array, or one
fused tracks file of several arrays (:mod:`.cross_fix_fused`). The
command (:func:`arrayproc.app.tracking.tma`) and the evaluations' pipeline
(:mod:`arrayproc.evaluate.pipeline`) both call :func:`run_tma_inputs`."""
from __future__ import annotations

from collections.abc import Sequence

from arrayproc.errors import ConfigError

from .per_track import is_tracks_file, run_tracks_tma
from .run import load_tma_config, run_tma

__all__ = ["run_tma_inputs"]


def run_tma_inputs(inputs: str | Sequence[str], config: str, output: str,
                   progress: bool = False) -> None:
    """Solve the inputs by the method the configuration names and write ``output``.

    Parameters
    ----------
    inputs : str or sequence of str
        One products or tracks file; for ``method = "cross_fix"`` one products file per
        array, two tracks files, or one tracks file of the fused tracker.
    config : str
        TMA TOML (checked first).
    output : str
        Products file to write (one ``tma`` group).
    progress : bool
        One line per solution on stderr.
    """
    paths = [inputs] if isinstance(inputs, str) else list(inputs)
    method = load_tma_config(config)["method"]  # configuration errors first
    tracks = [is_tracks_file(p) for p in paths]
    if method == "cross_fix" and len(paths) == 1 and tracks[0]:
        from .cross_fix_fused import is_fused_tracks, run_cross_fix_fused
        if is_fused_tracks(paths[0]):  # the tracker associated the arrays' rows
            run_cross_fix_fused(paths[0], config, output, progress=progress)
            return
    if method == "cross_fix" or len(paths) > 1:
        if any(tracks) and not all(tracks):
            raise ConfigError("cross_fix reads either products files or tracks files, one per "
                              "array, not both: "
                              + ", ".join(p for p, t in zip(paths, tracks, strict=True) if t)
                              + " hold tracks")
        if all(tracks):
            from .cross_fix_tracks import run_cross_fix_tracks
            run_cross_fix_tracks(paths, config, output, progress=progress)
        else:
            from .cross_fix_run import run_cross_fix
            run_cross_fix(paths, config, output, progress=progress)
    elif tracks[0]:  # one solution per confirmed track
        run_tracks_tma(paths[0], config, output, progress=progress)
    else:
        run_tma(paths[0], config, output, progress=progress)
