"""``cbf``: frequency-domain conventional (delay-and-sum) beamformer, thesis eq. (2.8).

For each snapshot (``nfft`` samples every ``hop``, time taper ``window``) and each frequency bin
f in ``band``, the beam output is

    Y(θ, f) = Σ_n w_n X_n(f) exp(−j 2π f τ_n(θ)),     τ_n(θ) = (r_n − r̄)·k(θ) / c,

the DFT-domain delay-and-sum of eq. (2.6)/(2.8): X_n is the (unnormalised) DFT of hydrophone n,
k(θ) the unit vector towards the source, r̄ the element centroid (phase reference) and w_n the
array shading (mean 1). A plane wave from θ0 therefore gives Y ∝ I_NH(θ, θ0, f) of eq. (2.13),
and white noise of variance σ² per sample gives E|Y|² = N_DFT N_H σ² (rectangular window, no
shading), as in thesis 2.1.1.1. The sign of the exponent is the physical one for numpy's DFT
convention (e^{−j2πkl/N}); eq. (2.8) writes the opposite sign for the opposite convention.

Beams (``beams`` table):

- ``{start, stop, count}``: cone angles θ in degrees (0 forward end-fire, 90 broadside), for line
  arrays; only the body-frame x coordinate of each element enters (the cone's projection on
  the array axis), so a line array along the body x axis is steered exactly. Optional
  ``spacing = "cos"`` spaces the beams uniformly in cos θ instead of θ.
- ``{bearings = [...], elevations = [...]}``: for 3-D arrays, every combination of a bearing
  relative to the array's forward axis (deg, clockwise seen from above, i.e. towards
  starboard) and an elevation (deg above the horizontal, default ``[0]``).

Steering uses the element positions of each block (the steering matrix is rebuilt whenever
they change). Output: blocks of domain ``("snapshot", "freq", "beam")``, complex64, holding up
to ``batch`` snapshots each (docs/architecture.md, "Snapshot batches"); ``meta["times"]`` has
each snapshot's centre time (s) and ``meta["headings"]`` the array heading (deg) at that time.

Implementation: each frame's rfft through :mod:`arrayproc.dsp.fft` (packed into the per-bin
GEMM operands while it is in cache), then per bin one *real* GEMM of the paired steering rows
against the stacked real/imaginary snapshots (see :mod:`arrayproc.stages.beamform._kernels`):
beams in opposite directions (θ and 180° − θ) share their rows, which halves the work of a
complex GEMM for the usual symmetric fan. Fast path for centro-symmetric arrays (uniform line
arrays, symmetric shading): element pairs are folded into sums and differences, two real GEMMs
of half depth, halving the work again. The snapshots of a batch are split over ``threads``
worker threads, each running the whole path (windowing, FFT, packing, GEMMs, unpacking) on its
part with single-threaded BLAS.
"""

from __future__ import annotations

import math
import sys
import warnings
from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta
from arrayproc.dsp import fft, workers
from arrayproc.dsp.bands import check_nyquist
from arrayproc.dsp.blas_threads import set_local_threads
from arrayproc.dsp.shading import KINDS as SHADINGS
from arrayproc.dsp.shading import shading_weights
from arrayproc.dsp.windows import time_taper
from arrayproc.errors import ConfigError
from arrayproc.geo.beams import beam_directions
from arrayproc.stages.beamform import _kernels as kb
from arrayproc.stages.beamform.checks import warn_cone_geometry, warn_spatial_aliasing

WINDOWS = ("none", "hann", "hamming", "blackman", "blackmanharris")
BINS_PER_TASK = 32  # bins per GEMM call of a worker

def pair_directions(dirs: np.ndarray, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """Group beams into unique directions up to sign.

    Returns ``(unique (U, 3), uidx (B,), sign (B,))`` with ``dirs[b] = sign[b] ·
    unique[uidx[b]]`` (to within ``tol``).
    """
    d = np.asarray(dirs, float)
    q = np.round(d / tol).astype(np.int64)
    # canonical sign: the first non-zero component positive
    first = np.argmax(q != 0, axis=1)
    s = np.sign(q[np.arange(len(q)), first])
    s[s == 0] = 1
    keys = q * s[:, None]
    index: dict[tuple, int] = {}
    uniq: list[np.ndarray] = []
    uidx = np.empty(len(d), np.int64)
    for i, k in enumerate(map(tuple, keys)):
        j = index.get(k)
        if j is None:
            j = index[k] = len(uniq)
            uniq.append(d[i] * s[i])
        uidx[i] = j
    return np.array(uniq).reshape(-1, 3), uidx, s.astype(np.float32)


def element_delays(positions: np.ndarray, unique_dirs: np.ndarray, mode: str,
                   sound_speed: float) -> np.ndarray:
    """Plane-wave advances τ (U, C) s of each element over the centroid for each direction."""
    p = np.asarray(positions, float)
    rel = p - p.mean(axis=0)
    if mode == "cone":
        rel = rel.copy()
        rel[:, 1:] = 0.0  # cone beams: projection on the array (body x) axis only
    return (unique_dirs @ rel.T) / sound_speed


def symmetric_pairs(rel: np.ndarray, weights: np.ndarray,
                    tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray] | None:
    """Element pairs (i, j) with ``rel[j] = −rel[i]`` and equal weights (a centre element
    pairs with itself), or None if the array is not centro-symmetric. ``rel`` (C, 3) m are
    positions relative to the centroid."""
    n = rel.shape[0]
    d = np.abs(rel[:, None, :] + rel[None, :, :]).max(axis=2)  # |r_i + r_j|
    match = np.argmin(d, axis=1)
    if np.any(d[np.arange(n), match] > tol) or np.any(match[match] != np.arange(n)):
        return None
    if np.any(np.abs(weights - weights[match]) > 1e-9 * np.abs(weights).max()):
        return None
    keep = np.arange(n) <= match
    return np.flatnonzero(keep), match[keep]


def check_frame_keys(stage: Stage) -> None:
    """The checks of the keys ``cbf`` shares with the frequency-domain beamformers (``hop``,
    ``threads``, ``band``, ``beams``): ``hop = 0`` becomes nfft/2, a hop beyond nfft warns,
    and ``stage.beam_axis``, ``stage._dirs``, ``stage.beam_mode`` are set from ``beams``."""
    w = f"stage {stage.name!r}"
    if stage.hop == 0:
        stage.hop = max(1, stage.nfft // 2)
    if not 0 < stage.hop:
        raise ConfigError(f"{w}: key 'hop' must be > 0, got {stage.hop}")
    if stage.hop > stage.nfft:  # allowed (sparse snapshots), but never silently
        warnings.warn(f"{w}: key 'hop' ({stage.hop}) exceeds 'nfft' ({stage.nfft}): each "
                      f"snapshot skips {stage.hop - stage.nfft} samples", stacklevel=3)
    if stage.threads < 0:
        raise ConfigError(f"{w}: key 'threads' must be >= 0, got {stage.threads}")
    if stage.band is not None and stage.band[0] < 0:
        raise ConfigError(f"{w}: key 'band' must be >= 0 Hz, got {stage.band}")
    try:
        stage.beam_axis, stage._dirs, stage.beam_mode = beam_directions(stage.beams)
    except ConfigError as e:
        raise ConfigError(f"{w}: {e}") from None


@register
class CBF(Stage):
    """Conventional beamformer in the frequency domain (thesis eq. 2.8); see module doc.

    Examples
    --------
    Outside a chain: the keys are checked when the stage is made, and ``process`` turns time
    blocks into beams. A 250 Hz plane wave reaching eight elements (0.75 m apart) at the same
    time comes from broadside:

    >>> import os, tempfile
    >>> import numpy as np
    >>> from arrayproc import CBF, Recording, RecordingWriter
    >>> from arrayproc.chain.reader import read_blocks
    >>> cbf = CBF(nfft=256, beams={"start": 0.0, "stop": 180.0, "count": 19}, threads=1)
    >>> cbf.hop  # 0 means nfft / 2
    128
    >>> CBF(nfft=256, beam=3)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    arrayproc.errors.ConfigError: stage 'cbf': unknown key 'beam' for type 'cbf' (known: ...)
    >>> tmp = tempfile.TemporaryDirectory()
    >>> path = os.path.join(tmp.name, "rec.h5")
    >>> positions = np.zeros((8, 3)); positions[:, 0] = -0.75 * np.arange(8)
    >>> wave = np.sin(2 * np.pi * 250.0 * np.arange(4096) / 1000.0)
    >>> with RecordingWriter(path, 1000.0, 8, positions=positions) as w:
    ...     w.append(np.repeat(wave[:, None], 8, axis=1).astype(np.float32))
    >>> with Recording(path) as rec:
    ...     block = next(cbf.process(read_blocks(rec, 1024, 1024)))
    >>> block.data.shape  # (snapshots, bins, beams)
    (31, 129, 19)
    >>> power = (np.abs(block.data) ** 2).sum(axis=(0, 1))
    >>> float(block.beams[np.argmax(power)])  # cone angle, deg
    90.0
    >>> tmp.cleanup()
    """

    kind = "cbf"
    accepts = frozenset({Domain.TIME})
    produces = Domain.BEAMS
    params = {
        "nfft": Param("int", 2048, "samples per snapshot (DFT length)", check=positive,
                      unit="samples"),
        "hop": Param("int", 0, "samples between snapshots (0: nfft/2)", unit="samples"),
        "window": Param("str", "hann", "time taper of each snapshot", choices=WINDOWS),
        "band": Param("band", None, "[lo, hi] Hz of the bins to beamform (default: all); "
                      "an upper edge above the input's Nyquist frequency (fs/2, or fc + fs/2 for "
                      "complex baseband) is refused; a band above the array's spatial-aliasing "
                      "limit c/(2d) gets a warning",
                      unit="Hz"),
        "beams": Param("table", {"start": 0.0, "stop": 180.0, "count": 181},
                       "cone angles {start, stop, count} (spacing = \"angle\" "
                       "or \"cos\"), or {bearings, elevations}: every combination of a bearing "
                       "relative to the array's forward axis and an elevation above the "
                       "horizontal, deg",
                       unit="deg"),
        "shading": Param("str", "none", "array shading", choices=SHADINGS),
        "sidelobe_db": Param("float", 30.0, "sidelobe level of taylor/chebyshev shading, dB "
                             "below the main lobe",
                             check=positive, unit="dB"),
        "batch": Param("int", 32, "snapshots per GEMM batch (and per output block)",
                       check=positive),
        "threads": Param("int", 0, "worker threads, each on a part of the batch's snapshots "
                         "(0: all cores)"),
    }

    def validate(self) -> None:
        check_frame_keys(self)
        self._unique, self._uidx, self._sign = pair_directions(self._dirs)
        self._runs = kb.beam_runs(self._uidx, self._sign)
        self._win = time_taper(self.window, self.nfft).astype(np.float32)
        self._key = None

    # -- set-up per stream -------------------------------------------------------------
    def _prepare(self, b: Block) -> None:
        """(Re)build the bin selection and steering matrix for this block's fs and positions."""
        is_complex = np.iscomplexobj(b.data)
        fc = float(b.meta.fc) if is_complex else 0.0
        key = (b.fs, is_complex, fc, b.positions.shape, b.positions.tobytes(),
               self.ctx.sound_speed)
        if key == self._key:
            return
        self._key = key
        fs = b.fs
        if is_complex:  # complex baseband around fc (dft_filter complex = true)
            f_all = fc + np.fft.fftfreq(self.nfft, 1.0 / fs)
        else:
            f_all = np.fft.rfftfreq(self.nfft, 1.0 / fs)
        check_nyquist(self.band, fc + fs / 2, f"stage {self.name!r}")
        lo, hi = (self.band if self.band is not None else (-np.inf, np.inf))
        idx = np.flatnonzero((f_all >= lo) & (f_all <= hi))
        if idx.size == 0:
            raise ConfigError(f"stage {self.name!r}: key 'band' {self.band} holds no DFT bin "
                              f"(fs = {fs:g} Hz, nfft = {self.nfft})")
        idx = idx[np.argsort(f_all[idx], kind="stable")]
        self._complex = is_complex
        self._bins = idx
        self._contig = bool(np.all(np.diff(idx) == 1))
        self.freqs = f_all[idx]
        if self.beam_mode == "cone":
            warn_cone_geometry(f"stage {self.name!r}", b.positions)
        warn_spatial_aliasing(f"stage {self.name!r}", b.positions, float(self.freqs.max()),
                              self.ctx.sound_speed, self.beam_mode)
        weights = shading_weights(self.shading, b.positions, self.sidelobe_db)
        delays = element_delays(b.positions, self._unique, self.beam_mode, self.ctx.sound_speed)
        self.weights, self._delays = weights, delays
        rel = np.asarray(b.positions, float) - np.asarray(b.positions, float).mean(axis=0)
        if self.beam_mode == "cone":
            rel[:, 1:] = 0.0
        pairs = symmetric_pairs(rel, weights)
        f64 = self.freqs.astype(np.float64)
        nu = len(self._unique)
        if pairs is not None:  # fast path: fold element pairs (uniform line arrays and the like)
            pi, pj = pairs
            self._pairs = (pi.astype(np.int64), pj.astype(np.int64))
            gc = np.empty((idx.size, pi.size, nu), np.float32)
            gs = np.empty((idx.size, pi.size, nu), np.float32)
            kb.steering_fold(f64, np.ascontiguousarray(delays[:, pi]),
                             weights[pi].astype(np.float64), gc, gs)
            self._steer = (gc, gs)
        else:
            self._pairs = None
            g = np.empty((idx.size, b.positions.shape[0], 2 * nu), np.float32)
            kb.steering_real(f64, delays, weights.astype(np.float64), g)
            self._steer = g

    @property
    def folded(self) -> bool:
        """Whether the centro-symmetric fast path (element pairs folded) is in use."""
        return self._pairs is not None

    def steering_matrix(self) -> np.ndarray:
        """Complex weights (F, B, C) applied to the DFTs: w_n e^{−j2πfτ_n} (for references)."""
        tau = self._delays[self._uidx] * self._sign[:, None]  # (B, C)
        return self.weights[None, None, :] * np.exp(
            -2j * np.pi * self.freqs[:, None, None] * tau[None])

    # -- compute -----------------------------------------------------------------------
    def _dtype(self) -> type:
        return np.complex64 if self._complex else np.float32

    def _part_plan(self, part: int, n_ch: int):
        """The FFT plan of worker ``part``: one frame, time-major (nfft, C) input transformed
        along the first axis. One frame at a time keeps the FFT's input and output in the
        core's L2 cache, and the FFT vectorises across the channels (window + FFT + pack 0.24
        ms per snapshot against 0.47 ms for a whole part's (nfft, S, C) batch,
        docs/performance.md). Owned by the stage: two CBF stages of the same shape in a chain
        must not share buffers."""
        kind = "fft" if self._complex else "rfft"
        key = (part, kind, self.nfft, n_ch)
        plans = self.__dict__.setdefault("_plans", {})
        if key not in plans:
            if len(plans) > 16:
                plans.clear()
            plans[key] = fft.BufferedPlan(kind, (self.nfft, n_ch), self._dtype(), axis=0)
        return plans[key]

    def _operands(self, s_n: int, n_ch: int) -> tuple[np.ndarray, ...]:
        """A batch's packed spectra, one contiguous piece per snapshot: (S, 2, F, K) pair sums
        and differences (folded path) or (S, 2, F, C) spectra, real parts in ``[:, 0]`` and
        imaginary parts in ``[:, 1]``. Views of arrays sized for a whole batch, allocated once
        per stream: a fresh array costs page faults (docs/performance.md)."""
        nf = self._bins.size
        cap = max(self.batch, s_n)
        folded = self._pairs is not None
        width = self._pairs[0].size if folded else n_ch
        key = ("ops", cap, width, nf, folded)
        bufs = self.__dict__.setdefault("_bufs", {})
        if key not in bufs:
            if len(bufs) > 8:
                bufs.clear()
            bufs[key] = tuple(fft.empty_aligned((cap, 2, nf, width), np.float32)
                              for _ in range(2 if folded else 1))
        return tuple(v[:s_n] for v in bufs[key])

    def _results(self, part: int, s_n: int, n_ch: int) -> tuple[np.ndarray, ...]:
        """Worker ``part``'s arrays for one chunk of bins: the GEMM operands (chunk, 2S, K)
        twice (folded path) or (chunk, 2S, C), then the GEMM results (chunk, 2S, U) twice or
        (chunk, 2S, 2U); views of arrays sized for a whole batch."""
        cap = max(self.batch, s_n)
        nu = int(self._uidx.max()) + 1
        chunk = min(self._bins.size, BINS_PER_TASK)
        folded = self._pairs is not None
        width = self._pairs[0].size if folded else n_ch
        key = ("res", part, cap, nu, chunk, width, folded)
        bufs = self.__dict__.setdefault("_bufs", {})
        if key not in bufs:
            if len(bufs) > 8:
                bufs.clear()
            if folded:
                shapes = [(chunk, 2 * cap, width)] * 2 + [(chunk, 2 * cap, nu)] * 2
            else:
                shapes = [(chunk, 2 * cap, width), (chunk, 2 * cap, 2 * nu)]
            bufs[key] = tuple(fft.empty_aligned(sh, np.float32) for sh in shapes)
        return tuple(v[:, :2 * s_n] for v in bufs[key])

    def beamform(self, frames: np.ndarray) -> np.ndarray:
        """Beam outputs (S, F, B) complex64 of time frames (S, nfft, C) (after :meth:`_prepare`)."""
        x = np.ascontiguousarray(frames, self._dtype())
        srcs = [(x[s], 0) for s in range(x.shape[0])]
        out = []
        for a in range(0, len(srcs), self.batch):
            out.append(self._beamform_frames(srcs[a:a + self.batch]).copy())
        return np.concatenate(out)

    def _beamform_frames(self, srcs: list[tuple[np.ndarray, int]]) -> np.ndarray:
        """Beams (S, F, B) of the frames ``srcs`` — frame s is ``srcs[s][0][o:o + nfft]`` with
        ``o = srcs[s][1]``, time-major (T, C) arrays — in two parallel phases on the worker
        threads. First each frame is windowed, transformed and packed into the batch's GEMM
        operands (:meth:`_front`), then each chunk of bins gets its GEMMs and its unpack, over
        all snapshots (:meth:`_back`). The workers take frames, then chunks, from a shared
        queue (an iterator: its ``next`` is atomic), so a worker slowed down by the machine
        does not hold the batch up, and the chunks of the steering matrix (17.7 MB for the
        issue-4 configuration) are read once per batch, not once per worker."""
        s_n = len(srcs)
        n_thr = workers.count(self.threads)
        nf, n_ch = self._bins.size, srcs[0][0].shape[1]
        y = self._out_buffer((s_n, nf, self._uidx.size))
        ops = self._operands(s_n, n_ch)
        chunk = min(nf, BINS_PER_TASK)
        n_parts = max(1, min(n_thr, s_n))
        for i in range(n_parts):  # plans and buffers are made here, not in the workers (FFTW
            self._part_plan(i, n_ch)  # planning is not thread-safe)
            self._results(i, s_n, n_ch)
        frames, chunks = iter(range(s_n)), iter(range(0, nf, chunk))
        if n_parts == 1:
            old = set_local_threads(1)
            try:
                self._front(0, frames, ops, srcs)
                self._back(0, chunks, ops, y)
            finally:
                if old is not None:
                    set_local_threads(old)
        else:
            pool = workers.pool(n_parts)
            list(pool.map(lambda i: self._front(i, frames, ops, srcs), range(n_parts)))
            list(pool.map(lambda i: self._back(i, chunks, ops, y), range(n_parts)))
        return y

    def _front(self, part: int, frames: Iterator[int], ops: tuple,
               srcs: list[tuple[np.ndarray, int]]) -> None:
        """Frames taken from ``frames``, one at a time while it is in cache: window, FFT, and
        pack its band into its own contiguous piece of the operands (worker ``part``)."""
        plan = self._part_plan(part, srcs[0][0].shape[1])
        win = self._win_cast()
        first = int(self._bins[0])
        pairs = self._pairs
        for s in frames:
            x, offset = srcs[s]
            kb.window_frame(x, offset, win, plan.input)
            spec = plan()  # (F_all, C)
            f0 = first
            if not self._contig:
                spec, f0 = spec[self._bins], 0
            if pairs is not None:
                kb.pack_fold(spec, f0, pairs[0], pairs[1], ops[0][s], ops[1][s])
            else:
                kb.pack_bins(spec, f0, ops[0][s])

    def _back(self, part: int, chunks: Iterator[int], ops: tuple, y: np.ndarray) -> None:
        """Chunks of bins taken from ``chunks`` (first bin of each), for every snapshot: the
        corner turn of the chunk into per-bin operands in cache (``_kernels.gather_bins``), one
        real GEMM per bin and the unpack of its results into the beams (worker ``part``)."""
        w = self._results(part, y.shape[0], ops[0].shape[3])
        chunk, nf = w[0].shape[0], y.shape[1]
        for c in chunks:
            n = min(nf, c + chunk) - c
            if self._pairs is not None:
                kb.gather_bins(ops[0], c, w[0][:n])
                kb.gather_bins(ops[1], c, w[1][:n])
                za = np.matmul(w[0][:n], self._steer[0][c:c + n], out=w[2][:n])
                zb = np.matmul(w[1][:n], self._steer[1][c:c + n], out=w[3][:n])
                kb.unpack_fold(za, zb, self._runs, y, c)
            else:
                kb.gather_bins(ops[0], c, w[0][:n])
                z = np.matmul(w[0][:n], self._steer[c:c + n], out=w[1][:n])
                kb.unpack_beams(z, self._uidx, self._sign, y, c)

    def _out_buffer(self, shape: tuple[int, ...]) -> np.ndarray:
        """An output array of ``shape`` (S, F, B): the first S snapshots of a full-batch
        array that was emitted before and that nobody references any more (blocks and views
        keep their base alive, so the reference count says it is free), else of a new one.
        Every array holds a whole batch, so a short batch (the end of a stream, a gap) reuses
        one too: a fresh 35 MB array costs 8-100 ms of page faults here (docs/performance.md),
        up to 0.6 ms per snapshot of a 30 s run."""
        full = (max(self.batch, shape[0]),) + tuple(shape[1:])
        pool = self.__dict__.setdefault("_pool", [])
        for buf in pool:
            # references: the pool list, the loop variable and getrefcount's argument
            if buf.shape == full and sys.getrefcount(buf) <= 3:
                return buf[:shape[0]]
        buf = np.empty(full, np.complex64)
        if len(pool) >= 3:
            pool.pop(0)
        pool.append(buf)
        return buf[:shape[0]]

    def _headings(self, times: np.ndarray, fallback: float) -> np.ndarray:
        rec = self.ctx.recording
        if rec is not None and getattr(rec, "nav", None) is not None:
            return rec.nav.at(times)[1]
        return np.full(times.shape, fallback)

    def _win_cast(self) -> np.ndarray:
        w = self.__dict__.get("_winc")
        if w is None or w.dtype != self._dtype():
            w = self._winc = self._win.astype(self._dtype())
        return w

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        # Frames on the stream's absolute sample grid (frame k starts at sample k·hop, as
        # chain.FrameBuffer). The workers window each frame straight out of the input block
        # that holds it (the stage keeps the blocks its pending frames need; blocks are not
        # modified once yielded, as everywhere in the chain); only a frame that straddles two
        # blocks is first copied together into a staging slot. No copy of the stream, so the
        # calling thread has almost nothing to do between batches.
        segs: list[tuple[int, np.ndarray]] = []  # retained blocks: (first sample, (n, C) data)
        end: int | None = None  # sample after the last retained block's last valid one
        nxt = 0  # absolute sample index of the next frame's start
        starts: list[int] = []
        srcs: list[tuple[np.ndarray, int]] = []
        last: Block | None = None
        index = 0
        nfft, hop = self.nfft, self.hop

        def emit() -> Block:
            nonlocal index
            st = np.asarray(starts, np.int64)
            y = self._beamform_frames(srcs)
            starts.clear()
            srcs.clear()
            fs = last.fs
            times = (st + 0.5 * nfft) / fs
            heading = last.pose.heading if last.pose is not None else 0.0
            headings = self._headings(times, heading)
            out = Block(y, Domain.BEAMS, st[0] / fs,
                        (st[-1] - st[0] + nfft) / fs, fs, last.positions,
                        last.pose, self.freqs, self.beam_axis, index,
                        SnapshotMeta(times, headings, nfft, hop, self.window, fs / nfft,
                                     starts=st, shading=self.shading,
                                     beam_mode=self.beam_mode))
            index += y.shape[0]
            return out

        def frame_source(a: int) -> tuple[np.ndarray, int]:
            """Where the frame starting at sample ``a`` lies: (array, first row)."""
            k = 0
            while a >= segs[k][0] + segs[k][1].shape[0]:
                k += 1
            s0, d = segs[k]
            if a + nfft <= s0 + d.shape[0]:
                return d, a - s0
            slot = self._staging(len(srcs), d.shape[1], d.dtype)  # straddles blocks
            pos = 0
            for s0, d in segs[k:]:
                lo = a + pos - s0
                take = min(nfft - pos, d.shape[0] - lo)
                slot[pos:pos + take] = d[lo:lo + take]
                pos += take
                if pos == nfft:
                    break
            return slot, 0

        for b in blocks:
            if last is not None and (b.positions.shape != last.positions.shape
                                     or not np.array_equal(b.positions, last.positions)
                                     or b.fs != last.fs or np.iscomplexobj(b.data)
                                     != np.iscomplexobj(last.data)):
                if starts:
                    yield emit()  # geometry changed: flush with the old steering
                segs.clear()
                end = None
            self._prepare(b)
            last = b
            x = b.data[: b.meta.n_valid]
            s0 = b.meta.sample0
            if end is None or end != s0:  # start, or a gap in the stream
                if starts:
                    yield emit()
                segs.clear()
                nxt = max(nxt, -(-s0 // hop) * hop)
            if x.shape[0] == 0:
                end = s0
                continue
            segs.append((s0, x))
            end = s0 + x.shape[0]
            while nxt + nfft <= end:
                srcs.append(frame_source(nxt))
                starts.append(nxt)
                nxt += hop
                if len(starts) == self.batch:
                    yield emit()
            while segs and segs[0][0] + segs[0][1].shape[0] <= nxt:
                segs.pop(0)  # no later frame needs it (pending frames hold their arrays)
        if starts and last is not None:
            yield emit()

    def _staging(self, slot: int, n_ch: int, dtype: np.dtype) -> np.ndarray:
        """Staging slot ``slot`` (nfft, C) for a frame that straddles two input blocks; one
        per frame of a batch, allocated once per stream."""
        st = self.__dict__.get("_stage")
        if st is None or st.shape[1:] != (self.nfft, n_ch) or st.dtype != dtype \
                or st.shape[0] < self.batch:
            st = self._stage = np.empty((self.batch, self.nfft, n_ch), dtype)
        return st[slot]

    def warmup_seconds(self, fs: float) -> float:
        return self.nfft / fs

    def snapshot_seconds(self) -> float | None:
        return self.hop / self.fs_in if self.fs_in else None


def beam_power_reference(frames: np.ndarray, fs: float, positions: np.ndarray,
                         cone_deg: np.ndarray, band: tuple[float, float], c: float,
                         window: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Plain numpy CBF of one frame (nfft, C) for cone beams: reference for tests and bench.

    Returns ``(freqs (F,), Y (F, B) complex)``, same conventions as :class:`CBF`.
    """
    nfft = frames.shape[0]
    w = np.ones(nfft) if window is None else window
    spec = np.fft.rfft(frames * w[:, None], axis=0)
    f = np.fft.rfftfreq(nfft, 1 / fs)
    sel = (f >= band[0]) & (f <= band[1])
    x = positions[:, 0] - positions[:, 0].mean()
    tau = np.cos(np.deg2rad(cone_deg))[:, None] * x[None, :] / c
    steer = np.exp(-2j * math.pi * f[sel, None, None] * tau[None])
    return f[sel], np.einsum("fbc,fc->fb", steer, spec[sel])
