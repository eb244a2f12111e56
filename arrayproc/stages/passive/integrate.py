"""``integrate``: incoherent integration of beamformed snapshots, thesis eq. (2.22).

    S_inco(θ, f) = Σ_{b=1}^{N_B} |Ξ_b(θ, f)|²

over ``snapshots`` = N_B consecutive CBF snapshots. ``mode = "blockwise"`` sums disjoint groups
of N_B snapshots (one output per N_B inputs), aligned on the absolute snapshot grid (snapshot
number = first sample // hop, a multiple of N_B starts a group), so that a run started
anywhere integrates the same groups; ``mode = "sliding"`` emits, for every input
snapshot from the N_B-th on, the sum over the last N_B (one output per input). For white
Gaussian noise the sum is Gamma distributed with shape N_B and scale E|Ξ|² (eq. 2.24).

Input: complex blocks ``("snapshot", "freq", "beam")`` from ``cbf``. Output: float32 power
blocks of the same domain; ``meta["times"]`` is the mean of the integrated snapshots' centre
times (s) and ``meta["headings"]`` their circular-mean heading (deg). With ``mean = true`` the
sum is divided by N_B (an average power: Gamma of shape N_B and scale E|Ξ|²/N_B).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, Integration
from arrayproc.dsp import workers
from arrayproc.stages.passive._kernels import abs2, power_sums


def _circ_mean_deg(a: np.ndarray, axis: int = -1) -> np.ndarray:
    r = np.deg2rad(a)
    return np.mod(np.rad2deg(np.arctan2(np.sin(r).mean(axis), np.cos(r).mean(axis))), 360.0)


@register
class Integrate(Stage):
    """Incoherent integration of N_B snapshots (thesis eq. 2.22); see module doc."""

    kind = "integrate"
    accepts = frozenset({Domain.BEAMS, Domain.POWER})
    produces = Domain.POWER
    params = {
        "snapshots": Param("int", 8, "N_B, snapshots per sum", check=positive),
        "mode": Param("str", "blockwise", "blockwise (disjoint sums) or sliding (one sum per "
                      "input snapshot)",
                      choices=("blockwise", "sliding")),
        "mean": Param("bool", False, "divide the sum by N_B"),
        "threads": Param("int", 0, "worker threads, each on a part of the (freq, beam) cells "
                         "(0: all cores)"),
    }

    def warmup_seconds(self, fs: float) -> float:
        """A full window of snapshots before the segment (a blockwise window may start up to
        N_B − 1 snapshots earlier than the segment's first output)."""
        dt = self.snapshot_seconds()
        return 0.0 if dt is None else self.snapshots * dt

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        n = self.snapshots
        step = n if self.mode == "blockwise" else 1
        tail_p: np.ndarray | None = None  # powers not yet fully used (T, F, B)
        tail_t = np.zeros(0)
        tail_h = np.zeros(0)
        tail_k = np.zeros(0, np.int64)
        index = 0
        count = 0  # running snapshot number when the input carries no sample grid
        for b in blocks:
            y = b.data
            if np.iscomplexobj(y):  # powers are taken inside the sums, never stored whole
                y = np.ascontiguousarray(y, np.complex64)
            else:  # already powers: they join the carried-over rows
                y = np.ascontiguousarray(y, np.float32)
            times = np.asarray(b.meta.times, float)
            heads = np.asarray(b.meta.headings, float)
            if b.meta.starts is not None and b.meta.hop:
                ks = np.asarray(b.meta.starts, np.int64) // int(b.meta.hop)
            else:
                ks = count + np.arange(y.shape[0], dtype=np.int64)
            count = int(ks[-1]) + 1 if ks.size else count
            if tail_p is not None and (tail_p.shape[1:] != y.shape[1:] or (
                    tail_k.size and ks.size and ks[0] != tail_k[-1] + 1)):
                tail_p = None  # axes changed or snapshots missing: start afresh
                tail_t, tail_h, tail_k = np.zeros(0), np.zeros(0), np.zeros(0, np.int64)
            head = tail_p if tail_p is not None else np.zeros((0,) + y.shape[1:], np.float32)
            if not np.iscomplexobj(y):
                head, y = np.concatenate([head, y]), np.zeros((0,) + y.shape[1:], np.complex64)
            tb = np.concatenate([tail_t, times])
            hb = np.concatenate([tail_h, heads])
            kb = np.concatenate([tail_k, ks])
            lead = 0
            if self.mode == "blockwise" and kb.size:
                # windows on the absolute snapshot grid (snapshot k·N starts one), so a run
                # started anywhere (a segment with warm-up) integrates the same snapshots
                lead = min(int((-kb[0]) % n), kb.size)
                tb, hb, kb = tb[lead:], hb[lead:], kb[lead:]
            if lead >= head.shape[0]:  # the rows in use: head[lead:] then |y[..]|²
                y = y[lead - head.shape[0]:]
                head = head[:0]
            else:
                head = head[lead:]
            t_n = head.shape[0] + y.shape[0]
            k = 0 if t_n < n else (t_n - n) // step + 1
            if k:
                out = np.empty((k,) + y.shape[1:], np.float32)
                self._sums(head, y, n, step, out)
                if self.mean:
                    out /= n
                starts = np.arange(k) * step
                win_idx = starts[:, None] + np.arange(n)[None, :]
                t_out = tb[win_idx].mean(axis=1)
                h_out = _circ_mean_deg(hb[win_idx], axis=1)
                meta = dataclasses.replace(b.meta, times=t_out, headings=h_out,
                                           integration=Integration(n, self.mode, self.mean))
                d = float(b.meta.nfft) / b.fs  # one snapshot's duration, s
                t0 = float(tb[0] - 0.5 * d)
                span = float(tb[win_idx[-1, -1]] - tb[0]) + d
                yield b.replace(data=out, domain=Domain.POWER, t0=t0, span=span, index=index,
                                meta=meta)
                index += k
            used = k * step  # the rows not yet used are carried over, as powers
            rest_y = y[max(0, used - head.shape[0]):]
            p = np.empty(rest_y.shape, np.float32)
            abs2(rest_y.reshape(-1), p.reshape(-1))
            tail_p = np.concatenate([head[used:], p])
            tail_t, tail_h, tail_k = tb[used:], hb[used:], kb[used:]

    def _sums(self, head: np.ndarray, y: np.ndarray, n: int, step: int,
              out: np.ndarray) -> None:
        """``out`` = the window sums of the rows [head; |y|²] (kernels.beamform.power_sums),
        the (freq, beam) cells split over the worker threads."""
        m = out[0].size
        acc = self.__dict__.get("_acc")
        if acc is None or acc.size < m:
            acc = self._acc = np.empty(m)
        args = (head.reshape(head.shape[0], m), y.reshape(y.shape[0], m), n, step)
        o2 = out.reshape(out.shape[0], m)
        n_thr = max(1, min(workers.count(self.threads), m // 4096))
        edges = [m * i // n_thr for i in range(n_thr + 1)]
        if n_thr == 1:
            power_sums(*args, 0, m, o2, acc)
            return
        list(workers.pool(n_thr).map(
            lambda i: power_sums(*args, edges[i], edges[i + 1], o2, acc), range(n_thr)))


