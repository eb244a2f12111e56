"""``arrayproc batch``: a chain over many recordings, or over segments of one long recording, as
tasks on ``dask.distributed`` (docs/scale-out.md).

    arrayproc batch INPUTS... -c CHAIN.toml -o OUTDIR [--workers N | --scheduler ADDRESS]
                    [--segment-s S] [--resume]

One task per recording writes ``OUTDIR/<input stem>.h5``, the file ``arrayproc process`` writes
(every dataset and attribute equal). With ``--segment-s`` each recording is cut into segments
(:func:`arrayproc.chain.segments.plan_segments`: warm-up margins, reads aligned on the stages'
frame grids), one task per segment writes a part file and a last task merges the parts into
``OUTDIR/<stem>.h5`` (:func:`arrayproc.chain.segments.merge_products`).

Without ``--scheduler`` a :class:`distributed.LocalCluster` of ``--workers`` processes (default:
the cores) runs here, each worker one task at a time with ``cores // workers`` threads for
BLAS, numba and the stages' own workers (a stage's ``threads = 0``, "all cores", becomes that
share), so workers do not oversubscribe the cores; they start with glibc's malloc defaults
(without the ``MALLOC_TRIM_THRESHOLD_`` Dask's nanny sets) and a quieter event loop
(:data:`WORKER_CONFIG`), which together cost a task +33-87 % CPU at Dask's defaults
(docs/performance/batch.md). With ``--scheduler`` the tasks go to that cluster
(dask-jobqueue, Kubernetes, SSH), whose workers must see the same paths.

Outputs are written under a temporary name and renamed when complete (``complete = True``),
so a task run twice, or retried after its worker died (``retries``; Dask moves the task of a
lost worker to another), gives the same file. ``--resume`` skips inputs (and segment parts)
whose output is complete. An input that cannot be read fails alone: the others complete, a
summary line names the failed inputs and the exit status is 1.

Seeds: a stage with a ``seed`` parameter left at its default gets the task's seed, from
``numpy.random.SeedSequence(root).spawn`` keyed by the input's place in the sorted input list
and the segment's index; no stage of the package draws random numbers today.
"""

from __future__ import annotations

import argparse
import glob
import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from arrayproc.errors import ArrayprocError, ConfigError, FormatError

INSTALL_HINT = ("arrayproc batch needs dask.distributed, which is not installed: install the "
                "extra with  pip install 'arrayproc[dask]'  (or  make install)")
LIST_SUFFIXES = (".txt", ".lst", ".list")
#: Environment variables that size the thread pools of numerical libraries in a worker.
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
               "NUMBA_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
#: glibc malloc variable Dask's nanny sets in its workers (``distributed.nanny.pre-spawn-environ``).
MALLOC_VAR = "MALLOC_TRIM_THRESHOLD_"
MMAP_VAR = "MALLOC_MMAP_THRESHOLD_"
#: Dask settings of the local cluster's workers. A worker's event loop runs beside the task
#: thread and, at Dask's defaults, took 0.2-0.6 s CPU per 1.7 s task of the towed-passive
#: chain: the statistical profiler sampling the task's stack every 10 ms, the 20 ms loop tick,
#: the 100 ms memory and 500 ms system monitors. At these values it takes 0.03-0.06 s
#: (docs/performance/batch.md); the dashboard still shows the profile and the memory.
WORKER_CONFIG = {
    "distributed.worker.profile.interval": "100ms",
    "distributed.admin.tick.interval": "500ms",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
}


def require_dask() -> Any:
    """Import ``distributed``, or raise ConfigError saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise ConfigError(INSTALL_HINT) from None
    return distributed


# -- inputs, outputs, seeds ---------------------------------------------------------------------
def expand_inputs(items: Sequence[str]) -> list[Path]:
    """Recordings named by paths, glob patterns and text files of paths (``.txt``, ``.lst``,
    ``.list``: one path or pattern a line, ``#`` comments, relative to the list's folder).

    Parameters
    ----------
    items : sequence of str
        Command-line inputs.

    Returns
    -------
    list of Path
        Distinct recordings, sorted.

    Raises
    ------
    ConfigError
        A pattern that matches nothing, a missing list file, or two inputs with the same stem
        (their outputs would collide).
    """
    found: set[Path] = set()

    def add(item: str, base: Path) -> None:
        pattern = item if os.path.isabs(item) else str(base / item)
        if glob.has_magic(pattern):
            hits = sorted(glob.glob(pattern))
            if not hits:
                raise ConfigError(f"input {item!r}: no file matches")
            found.update(Path(h).resolve() for h in hits)
        else:
            found.add(Path(pattern).resolve())

    for item in items:
        if item.lower().endswith(LIST_SUFFIXES):
            lst = Path(item)
            if not lst.is_file():
                raise ConfigError(f"input list {item}: no such file")
            for line in lst.read_text().splitlines():
                line = line.split("#", 1)[0].strip()
                if line:
                    add(line, lst.parent)
        else:
            add(item, Path("."))
    if not found:
        raise ConfigError("no input recordings given")
    paths = sorted(found)
    stems: dict[str, Path] = {}
    for p in paths:
        if p.stem in stems:
            raise ConfigError(f"inputs {stems[p.stem]} and {p} have the same stem: both would "
                              f"write {p.stem}.h5")
        stems[p.stem] = p
    return paths


def output_for(outdir: str | os.PathLike, recording: str | os.PathLike) -> Path:
    """``OUTDIR/<recording stem>.h5``."""
    return Path(outdir) / f"{Path(recording).stem}.h5"


def is_complete(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a products file marked complete (False when absent or unreadable)."""
    import h5py
    try:
        with h5py.File(path, "r") as f:
            return bool(f.attrs.get("complete", False))
    except (OSError, ValueError):
        return False


def task_seeds(root: int, n_inputs: int, n_segments: Sequence[int]) -> list[list[int]]:
    """Per-task seeds: ``SeedSequence(root).spawn(n_inputs)[i].spawn(n_segments[i])[j]``,
    each as one 64-bit integer.

    Parameters
    ----------
    root : int
        The batch's root seed.
    n_inputs : int
        Inputs, in sorted order.
    n_segments : sequence of int
        Segments of each input (1 when not segmented).

    Returns
    -------
    list of list of int
        ``seeds[i][j]`` for input i, segment j.
    """
    import numpy as np  # here, not at import: `arrayproc --version` stays light

    children = np.random.SeedSequence(root).spawn(n_inputs)
    return [[int(s.generate_state(1, np.uint64)[0]) for s in c.spawn(n)]
            for c, n in zip(children, n_segments)]


def worker_threads(n_workers: int, cores: int | None = None) -> int:
    """Threads each of ``n_workers`` workers may use without oversubscribing the cores."""
    cores = cores or os.cpu_count() or 1
    return max(1, cores // max(1, n_workers))


# -- tasks (run on the workers) -----------------------------------------------------------------
def _prepare_stages(spec: Any, threads: int, seed: int) -> None:
    """Stages' ``threads = 0`` (all cores) becomes the worker's share; a ``seed`` left at its
    default becomes the task's seed."""
    for st in spec.stages:
        if "threads" in st.params and getattr(st, "threads", None) == 0:
            st.threads = threads
        if "seed" in st.params and getattr(st, "seed", None) == st.params["seed"].default:
            st.seed = seed


def _limit_threads(threads: int) -> None:
    try:
        import numba
        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    except (ImportError, ValueError):
        pass


def process_task(recording: str, chain_text: str, output: str, threads: int, seed: int,
                 window: tuple[float, float] | None = None,
                 read: tuple[float | None, float | None] = (None, None)) -> dict[str, Any]:
    """Run the chain over one recording (or one segment of it) into ``output``, atomically.

    Parameters
    ----------
    recording : str
        Recording path (as the workers see it).
    chain_text : str
        The chain's TOML text.
    output : str
        Products file to write.
    threads : int
        Threads the task may use.
    seed : int
        The task's seed (for stages that draw random numbers).
    window : (float, float), optional
        Keep only rows with ``window[0] <= time < window[1]`` s (a segment).
    read : (float or None, float or None)
        ``t_start`` and ``t_stop`` handed to :func:`arrayproc.app.api.run_chain`, s.

    Returns
    -------
    dict
        ``status`` ("done" or "failed"), ``error`` (one line), ``seconds`` (wall),
        ``cpu_seconds`` (the worker process's CPU time, all threads), ``user_seconds``,
        ``system_seconds`` and ``minor_faults`` (its ``getrusage``, where available),
        ``blocks``.
    """
    from arrayproc.app.api import build_chain, run_chain
    from arrayproc.io.products import ProductsWriter
    from arrayproc.io.recording import Recording
    t0, c0, u0 = time.perf_counter(), time.process_time(), _usage()
    _limit_threads(threads)
    warnings: list[str] = []
    try:
        spec = build_chain(chain_text)
        _prepare_stages(spec, threads, seed)
        with Recording(recording) as r:
            with ProductsWriter(output, source=str(Path(recording).resolve()),
                                chain=spec.text, time_window=window) as out:
                n = run_chain(r, spec, out, read[0], read[1], log=warnings.append)
    except ArrayprocError as e:  # a bad input or chain fails alone, without retries
        return {"status": "failed", "error": str(e), "seconds": time.perf_counter() - t0}
    u1 = _usage()
    return {"status": "done", "error": "", "seconds": time.perf_counter() - t0, "blocks": n,
            "cpu_seconds": time.process_time() - c0, "warnings": warnings,
            **{k: u1[k] - u0[k] for k in u0}}


def _usage() -> dict[str, float]:
    """The process's user and system CPU seconds and minor page faults so far (all threads)."""
    try:
        import resource
    except ImportError:  # not on Windows
        return {}
    r = resource.getrusage(resource.RUSAGE_SELF)
    return {"user_seconds": r.ru_utime, "system_seconds": r.ru_stime,
            "minor_faults": float(r.ru_minflt)}


def merge_task(parts: Sequence[str], results: Sequence[dict[str, Any]], output: str,
               recording: str, chain_text: str) -> dict[str, Any]:
    """Merge the segment parts of one recording into ``output`` and remove the parts.

    Parameters
    ----------
    parts : sequence of str
        Part files, in time order.
    results : sequence of dict
        The parts' task results (a failed part fails the merge with its error).
    output : str
        Merged products file.
    recording : str
        The recording (its resolved path goes in the ``source`` attribute).
    chain_text : str
        The chain's TOML text.

    Returns
    -------
    dict
        As :func:`process_task`.
    """
    from arrayproc.chain.segments import merge_products
    t0 = time.perf_counter()
    bad = [r for r in results if r["status"] != "done"]
    if bad:
        return {"status": "failed", "error": bad[0]["error"], "seconds": 0.0}
    try:
        merge_products(parts, output, str(Path(recording).resolve()), chain_text)
    except ArrayprocError as e:
        return {"status": "failed", "error": str(e), "seconds": time.perf_counter() - t0}
    for p in parts:
        Path(p).unlink(missing_ok=True)
    return {"status": "done", "error": "", "seconds": time.perf_counter() - t0}


# -- the batch ----------------------------------------------------------------------------------
@dataclass
class TaskResult:
    """What became of one input."""

    recording: Path
    output: Path
    status: str  # "done", "skipped" or "failed"
    error: str = ""
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    user_seconds: float = 0.0
    system_seconds: float = 0.0
    minor_faults: float = 0.0
    segments: int = 1
    parts_run: int = 0
    warnings: list[str] = field(default_factory=list)


def start_client(workers: int | None = None, scheduler: str | None = None,
                 threads: int | None = None, dask_defaults: bool = False) -> tuple[Any, Any]:
    """A client of the cluster at ``scheduler``, or of a new LocalCluster of ``workers``
    worker processes (default: the cores), one task at a time each, with ``threads`` threads
    (default ``cores // workers``) for BLAS, OpenMP and numba.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: the cores).
    scheduler : str, optional
        Address of an existing scheduler (then no local cluster starts).
    threads : int, optional
        Threads per local worker (default ``cores // workers``).
    dask_defaults : bool
        Start the local workers with Dask's own settings (``MALLOC_TRIM_THRESHOLD_=65536``
        and :data:`WORKER_CONFIG`'s keys at Dask's values) instead of glibc's malloc defaults
        and :data:`WORKER_CONFIG`: only to measure what they cost (``scripts/bench_batch.py``).

    Returns
    -------
    (Client, LocalCluster or None)
        Close both when done (the cluster is None for an existing scheduler).
    """
    distributed = require_dask()
    if scheduler:
        try:
            return distributed.Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError) as e:
            raise ConfigError(f"--scheduler {scheduler}: cannot connect ({e})") from None
    n = workers or os.cpu_count() or 1
    if n < 1:
        raise ConfigError(f"--workers must be >= 1, got {n}")
    t = threads or worker_threads(n)
    env = {v: str(t) for v in THREAD_VARS}
    import dask
    # The nanny's pre-spawn environment sets MALLOC_TRIM_THRESHOLD_=65536 in every worker.
    # Setting any glibc malloc threshold switches off its dynamic mmap threshold, so every
    # array above 128 KiB is mmap-ed fresh and unmapped on free: 16-20x the minor page faults
    # and +33-87 % task CPU for the chain (docs/performance/batch.md). The workers keep glibc's
    # defaults, as `arrayproc process` does: None removes the variable from the pre-spawn
    # environment. The nanny also writes it into this process's environment, whence workers
    # started later would inherit it: Dask's own value found here is removed too (a value the
    # user chose is inherited unchanged).
    key = f"distributed.nanny.pre-spawn-environ.{MALLOC_VAR}"
    config: dict[str, Any] = {}
    if not dask_defaults:
        config = {key: None, **WORKER_CONFIG}
        dask_value = dask.config.get(key, None)
        if dask_value is not None and os.environ.get(MALLOC_VAR) == str(dask_value):
            del os.environ[MALLOC_VAR]
    # the nannies hand the configuration set here to their workers
    with dask.config.set(config):
        # a free port: the scheduler's HTTP server (and the dashboard, with bokeh) always runs
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           env=env, dashboard_address=":0",
                                           silence_logs=40)
    return distributed.Client(cluster), cluster


def _malloc_env() -> tuple[str | None, str | None]:
    return os.environ.get(MALLOC_VAR), os.environ.get(MMAP_VAR)


def malloc_note(client: Any) -> str | None:
    """A note when workers of an existing cluster run with glibc's dynamic mmap threshold
    switched off (``MALLOC_TRIM_THRESHOLD_`` set, as Dask's nanny does by default, without
    ``MALLOC_MMAP_THRESHOLD_``), which costs the chain about +50 % CPU; None otherwise.

    Parameters
    ----------
    client : distributed.Client
        Client of the cluster.

    Returns
    -------
    str or None
        One line for stderr.
    """
    try:
        env = client.run(_malloc_env)
    except Exception:  # noqa: BLE001 - a cluster that refuses client.run gets no note
        return None
    n = sum(trim is not None and mmap is None for trim, mmap in env.values())
    if not n:
        return None
    return (f"note: {n} of {len(env)} workers run with {MALLOC_VAR} set and no {MMAP_VAR} "
            "(Dask's default), which costs the chain about +50 % CPU in page faults; start "
            f"them without it (see docs/scale-out.md, 'Worker settings')")


def _has_bokeh() -> bool:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return False
    return True


def _recording_shape(path: Path) -> tuple[float, int, int]:
    from arrayproc.io.recording import Recording
    with Recording(path) as r:
        return r.fs, r.n_samples, r.n_channels


def _segment_grid(spec: Any, fs: float) -> int:
    """Read grid (recording samples) for stages known to batch frames from the read's start:
    ``cbf`` runs one GEMM per bin over ``batch`` frames, and the rounding of a frame's beams
    depends on its place in the batch, so reads start on ``batch · hop`` input samples."""
    from arrayproc.chain.graph import set_rates
    set_rates(spec, fs)
    grid = 1
    for st in spec.stages:
        if st.kind == "cbf" and getattr(st, "segment_grid", None) is None:
            ratio = fs / st.fs_in
            if abs(ratio - round(ratio)) < 1e-9:
                grid = math.lcm(grid, int(st.batch) * int(st.hop) * int(round(ratio)))
    return grid


def run_batch(inputs: Sequence[str | os.PathLike], chain: str | os.PathLike,
              outdir: str | os.PathLike, client: Any, segment_s: float | None = None,
              resume: bool = False, seed: int = 0, threads: int = 1, retries: int = 2,
              progress: bool = False) -> list[TaskResult]:
    """Run a chain over recordings as Dask tasks; see the module doc.

    Parameters
    ----------
    inputs : sequence of path
        Recordings (already expanded, see :func:`expand_inputs`).
    chain : path
        Chain TOML file (validated here, before any task is submitted).
    outdir : path
        Output folder (created when absent).
    client : distributed.Client
        Where the tasks run.
    segment_s : float, optional
        Cut each recording into segments of about this many seconds.
    resume : bool
        Skip inputs (and parts) whose output is complete.
    seed : int
        Root seed of the per-task seeds.
    threads : int
        Threads each task may use.
    retries : int
        Dask retries of a task that raised an unexpected error or lost its worker.
    progress : bool
        Show a bar on stderr over the seconds of audio of the inputs to run.

    Returns
    -------
    list of TaskResult
        One per input, in input order.
    """
    distributed = require_dask()
    from arrayproc.app.api import load_chain
    from arrayproc.chain.segments import part_path, plan_segments
    spec = load_chain(str(chain))
    text = spec.text
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    recs = [Path(p).resolve() for p in inputs]
    results = [TaskResult(r, output_for(out, r), "done") for r in recs]
    plans: list[list[Any] | None] = [None] * len(recs)
    if segment_s is not None:
        for i, r in enumerate(recs):
            if resume and is_complete(results[i].output):
                continue
            try:
                fs, n, nch = _recording_shape(r)
                plans[i] = plan_segments(spec, fs, n, nch, segment_s,
                                         grid=_segment_grid(load_chain(str(chain)), fs))
            except FormatError as e:
                results[i].status, results[i].error = "failed", str(e)
    seeds = task_seeds(seed, len(recs), [len(p) if p else 1 for p in plans])
    futures: dict[Any, int] = {}
    for i, res in enumerate(results):
        if res.status == "failed":
            continue
        if resume and is_complete(res.output):
            res.status = "skipped"
            continue
        _clean_partials(res.output)
        plan = plans[i]
        if plan is None:
            f = client.submit(process_task, str(res.recording), text, str(res.output), threads,
                              seeds[i][0], retries=retries, pure=False,
                              key=f"process-{res.output.stem}-{os.getpid()}-{time.time_ns()}")
            futures[f] = i
            res.parts_run = 1
            continue
        res.segments = len(plan)
        parts, part_results = [], []
        for seg in plan:
            pp = part_path(res.output, seg)
            parts.append(str(pp))
            if resume and is_complete(pp):
                part_results.append({"status": "done", "error": "", "seconds": 0.0})
                continue
            _clean_partials(pp)
            res.parts_run += 1
            part_results.append(client.submit(
                process_task, str(res.recording), text, str(pp), threads, seeds[i][seg.index],
                seg.window, (seg.t_start, seg.t_read_stop), retries=retries, pure=False,
                key=f"segment-{res.output.stem}-{seg.index}-{os.getpid()}-{time.time_ns()}"))
        f = client.submit(merge_task, parts, part_results, str(res.output), str(res.recording),
                          text, retries=retries, pure=False,
                          key=f"merge-{res.output.stem}-{os.getpid()}-{time.time_ns()}")
        futures[f] = i
    from arrayproc.app.progress import audio_bar, recording_seconds
    bar = audio_bar(progress and bool(futures), "batch")
    seconds = {i: recording_seconds(results[i].recording) or 0.0 for i in futures.values()} \
        if bar is not None else {}
    total_s, done_s = sum(seconds.values()), 0.0
    try:
        for f in distributed.as_completed(list(futures)):
            res = results[futures[f]]
            try:
                r = f.result()
                res.status, res.error = r["status"], r["error"]
                res.seconds = r.get("seconds", 0.0)
                res.cpu_seconds = r.get("cpu_seconds", 0.0)
                res.user_seconds = r.get("user_seconds", 0.0)
                res.system_seconds = r.get("system_seconds", 0.0)
                res.minor_faults = r.get("minor_faults", 0.0)
                res.warnings = r.get("warnings", [])
            except Exception as e:  # noqa: BLE001 - retries exhausted or worker lost: report it
                res.status = "failed"
                res.error = f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
            if bar is not None:
                done_s += seconds[futures[f]]
                bar(done_s, total_s)
    finally:
        if bar is not None:
            bar.close()
    for res in results:  # a retried task leaves the temporary file of its lost attempt
        if res.status == "done":
            _clean_partials(res.output)
    return results


def _clean_partials(target: Path) -> None:
    """Remove temporary files an interrupted or killed run left for ``target`` (those no live
    writer holds: :func:`arrayproc.io.atomic.remove_stale_parts`)."""
    from arrayproc.io.atomic import remove_stale_parts
    remove_stale_parts(target)


def summary(results: Sequence[TaskResult]) -> str:
    """One line: counts, and each failed input with its reason."""
    done = sum(r.status == "done" for r in results)
    skipped = sum(r.status == "skipped" for r in results)
    failed = [r for r in results if r.status == "failed"]
    line = f"{done} done, {skipped} skipped, {len(failed)} failed of {len(results)} inputs"
    if failed:
        line += ": " + "; ".join(f"{r.recording.name} ({r.error})" for r in failed)
        if any("cannot write the output" in r.error for r in failed):
            line += ("; the outputs that could not be written are not left behind: free space "
                     "and run the same command with --resume to complete them")
    return line


# -- command line -------------------------------------------------------------------------------
def cmd_batch(args: argparse.Namespace) -> int:
    """``arrayproc batch``: exit 0 when every input is done or skipped, 1 when any failed."""
    from arrayproc.app.progress import Summary, bar_wanted, recording_seconds
    done_line = Summary.of(args)
    require_dask()
    inputs = expand_inputs(args.inputs)
    if args.segment_s is not None and not args.segment_s > 0:
        raise ConfigError(f"--segment-s must be > 0 s, got {args.segment_s}")
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {args.workers}")
    from arrayproc.app.api import load_chain
    load_chain(args.config)  # a bad chain stops here, before a cluster starts
    client, cluster = start_client(args.workers, args.scheduler)
    try:
        n_workers = len(client.scheduler_info().get("workers", {})) or 1
        threads = (worker_threads(args.workers or os.cpu_count() or 1) if cluster is not None
                   else 1)
        link = client.dashboard_link if (cluster is None or _has_bokeh()) else None
        where = f"scheduler {args.scheduler}" if cluster is None else \
            f"local cluster of {n_workers} worker(s) x {threads} thread(s)"
        print(f"arrayproc batch: {len(inputs)} inputs on {where}"
              + (f"; dashboard {link}" if link else ""), file=sys.stderr)
        note = malloc_note(client) if cluster is None else None
        if note:
            print(f"arrayproc batch: {note}", file=sys.stderr)
        results = run_batch(inputs, args.config, args.output, client, args.segment_s,
                            args.resume, args.seed, threads, args.retries,
                            progress=bar_wanted(args))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    for r in results:
        for w in r.warnings:
            print(f"arrayproc: warning: {r.recording.name}: {w}", file=sys.stderr)
    line = summary(results)
    failed = any(r.status == "failed" for r in results)
    if failed:
        print(f"arrayproc batch: {line}", file=sys.stderr)
        return 1
    audio = [recording_seconds(r.recording) for r in results if r.status == "done"]
    done_line(f"{Path(args.output)}/", line,
              sum(audio) if audio and None not in audio else None)
    return 0


def add_parser(sub: Any) -> None:
    """Register ``arrayproc batch`` on the CLI's subparsers."""
    from arrayproc.app.options import add_config, add_no_progress, add_quiet
    s = sub.add_parser("batch", help="run a chain over many recordings (or segments) on Dask")
    s.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="recordings, glob patterns, or .txt/.lst files of paths")
    add_config(s, "chain TOML file", alias="--chain")
    s.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                   help="folder for OUTDIR/<input stem>.h5")
    g = s.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: the cores)")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="an existing Dask scheduler, e.g. tcp://host:8786")
    s.add_argument("--segment-s", type=float, default=None, metavar="S",
                   help="cut each recording into segments of about S seconds")
    s.add_argument("--resume", action="store_true", help="skip inputs whose output is complete")
    s.add_argument("--seed", type=int, default=0, help="root of the per-task seeds (default 0)")
    s.add_argument("--retries", type=int, default=2,
                   help="retries of a task whose worker died or that failed unexpectedly")
    add_no_progress(s)
    add_quiet(s)
    s.set_defaults(func=cmd_batch)

