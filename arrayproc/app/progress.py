"""What a long command shows while it runs and says when it ends (one home for both).

* :class:`AudioBar`: the progress bar on stderr, in seconds of audio (tqdm's bar; only on a
  terminal, see :func:`bar_wanted`). The layers below the application take it as a plain
  callback ``progress(done_s, total_s)``, so they need not know about tqdm.
* :class:`Summary`: the one line every long command (simulate, import, process, track, tma,
  batch, export, demo) prints on stdout when it has finished, e.g.
  ``arrayproc: wrote towed_products.h5 (3 groups) in 2.4 s, 125x real time, peak 310 MB``: what was
  written, the wall time since the command started, and the audio's duration over that time
  when the audio behind the output is known (:func:`audio_seconds`). ``-q`` suppresses it.

Only attributes and dataset shapes are read to describe an output, never its data.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


def bar_wanted(args: argparse.Namespace) -> bool:
    """A progress bar unless ``--no-progress`` or stderr is not a terminal."""
    return not getattr(args, "no_progress", False) and sys.stderr.isatty()


class AudioBar:
    """A progress bar over seconds of audio, created at the first call.

    Call it as ``bar(done_s, total_s)`` after each step (a block read, a chunk simulated, a
    recording processed); it shows the seconds of audio done and their rate in audio seconds
    per wall second (the multiple of real time). Use as a context manager, or call
    :meth:`close`.

    Parameters
    ----------
    desc : str
        The bar's label (the command's name).
    """

    def __init__(self, desc: str) -> None:
        self.desc = desc
        self._bar: Any = None
        self.done_s = 0.0

    def __call__(self, done_s: float, total_s: float) -> None:
        if self._bar is None:
            from tqdm import tqdm
            self._bar = tqdm(total=float(total_s), unit="s", desc=self.desc, leave=False,
                             file=sys.stderr, bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                             "{n:.0f}/{total:.0f} s of audio [{elapsed}<{remaining}, "
                             "{rate_noinv_fmt}]")
        step = min(float(done_s), float(total_s)) - self.done_s
        if step > 0:
            self._bar.update(step)
            self.done_s += step

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> AudioBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def audio_bar(progress: bool, desc: str) -> AudioBar | None:
    """An :class:`AudioBar` when ``progress``, else None (the lower layers' "no progress")."""
    return AudioBar(desc) if progress else None


# -- the summary line ---------------------------------------------------------------------------
def format_seconds(t: float) -> str:
    """Wall time as ``0.42 s``, ``2.4 s``, ``153 s``."""
    return f"{t:.2g} s" if t < 10 else f"{t:.0f} s"  # two significant digits at least


def format_ratio(r: float) -> str:
    """A multiple of real time: ``0.35x``, ``4.2x``, ``125x``."""
    return f"{r:.2g}x" if r < 1 else f"{r:.1f}x" if r < 10 else f"{r:.0f}x"


def summary_line(written: str, what: str, wall_s: float, audio_s: float | None = None,
                 peak_mb: float | None = None) -> str:
    """``arrayproc: wrote WRITTEN (WHAT) in T s, Nx real time, peak M MB`` (the ratio only when
    the audio's duration ``audio_s`` is known and positive; the peak resident memory when
    ``peak_mb`` is given)."""
    line = f"arrayproc: wrote {written}" + (f" ({what})" if what else "")
    line += f" in {format_seconds(wall_s)}"
    if audio_s and audio_s > 0 and wall_s > 0:
        line += f", {format_ratio(audio_s / wall_s)} real time"
    if peak_mb:
        line += f", peak {peak_mb:.0f} MB"
    return line


def peak_memory_mb() -> float:
    """Peak resident memory of this process and of its largest finished child process (MB;
    ``getrusage`` gives KiB on Linux)."""
    import resource
    kib = max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
              resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
    return kib / 1024.0


class Summary:
    """The end-of-command line: a timer started when the command started.

    Parameters
    ----------
    quiet : bool
        Print nothing (``-q``).
    started : float, optional
        ``time.perf_counter()`` at the command's start (default: now).
    echo : callable
        Where the line goes (default: stdout).
    """

    def __init__(self, quiet: bool = False, started: float | None = None,
                 echo: Callable[[str], None] = print) -> None:
        self.quiet = quiet
        self.started = time.perf_counter() if started is None else started
        self.echo = echo

    @classmethod
    def of(cls, args: argparse.Namespace) -> Summary:
        """The summary of a parsed command line: ``-q`` and the start time the CLI stamped
        (``args.started``, see :func:`arrayproc.app.cli.main`)."""
        return cls(quiet=getattr(args, "quiet", False), started=getattr(args, "started", None))

    def __call__(self, written: str, what: str = "", audio_s: float | None = None) -> str:
        """Print (unless quiet) and return the line for ``written``."""
        line = summary_line(written, what, time.perf_counter() - self.started, audio_s,
                            peak_memory_mb())
        if not self.quiet:
            self.echo(line)
        return line


# -- what an output holds, cheaply ------------------------------------------------------------
def _h5_attr(obj: Any, key: str) -> str:
    v = obj.attrs.get(key, "")
    return v.decode(errors="replace") if isinstance(v, bytes) else str(v)


def _recording_or_sources(path: str | os.PathLike) -> tuple[float | None, list[str]]:
    """(a recording's duration in s, else None; the files the file names as its sources)."""
    try:
        import h5py
        with h5py.File(path, "r") as f:
            td = f.get("time_data")
            if isinstance(td, h5py.Dataset) and td.ndim == 2 and "sample_freq" in td.attrs:
                fs = float(td.attrs["sample_freq"])
                return (td.shape[0] / fs if fs > 0 else None), []
            return None, [_h5_attr(f, "recording"), _h5_attr(f, "source")]
    except (OSError, ValueError, TypeError, KeyError):
        return None, []


def recording_seconds(path: str | os.PathLike) -> float | None:
    """A recording file's duration, s; None for any other file (never raises)."""
    return _recording_or_sources(path)[0]


def audio_seconds(path: str | os.PathLike, _depth: int = 0) -> float | None:
    """Seconds of audio behind a file: a recording's duration, or that of the recording a
    products or tracks file was made from (its ``recording`` or ``source`` attribute, followed
    through at most three files, relative paths beside the file or from the current
    directory). None when it cannot be told; never raises."""
    seconds, nexts = _recording_or_sources(path)
    if seconds is not None or _depth >= 3:
        return seconds
    for n in (n for n in nexts if n):
        for p in (Path(n), Path(path).parent / n):
            if p.is_file() and p.resolve() != Path(path).resolve():
                s = audio_seconds(p, _depth + 1)
                if s is not None:
                    return s
    return None


def products_what(path: str | os.PathLike) -> str:
    """``3 groups`` (and ``, N tracks`` for a tracks group, ``, N solutions`` for tma)."""
    import h5py
    import numpy as np
    with h5py.File(path, "r") as f:
        groups = [g for g in f.values() if isinstance(g, h5py.Group)]
        parts = [f"{len(groups)} group{'s' * (len(groups) != 1)}"]
        for g in groups:
            kind = _h5_attr(g, "kind")
            if kind == "tracks" and isinstance(g.get("track_id"), h5py.Dataset):
                n = int(np.unique(g["track_id"][()]).size)
                parts.append(f"{n} track{'s' * (n != 1)}")
            elif kind == "tma" and isinstance(g.get("t0"), h5py.Dataset):
                n = int(g["t0"].shape[0])
                parts.append(f"{n} solution{'s' * (n != 1)}")
    return ", ".join(parts)


def recording_what(path: str | os.PathLike) -> str:
    """``32 channels, 180 s at 2048 Hz`` of a recording file."""
    import h5py
    with h5py.File(path, "r") as f:
        td = f["time_data"]
        fs = float(td.attrs["sample_freq"])
        n, ch = td.shape
    return f"{ch} channel{'s' * (ch != 1)}, {n / fs:g} s at {fs:g} Hz"
