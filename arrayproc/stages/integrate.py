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

from collections.abc import Iterator

import numpy as np

from ..block import Block
from ..chain import Param, Stage, positive, register
from ..errors import ConfigError
from ..kernels.beamform import abs2, window_sums


def _circ_mean_deg(a: np.ndarray, axis: int = -1) -> np.ndarray:
    r = np.deg2rad(a)
    return np.mod(np.rad2deg(np.arctan2(np.sin(r).mean(axis), np.cos(r).mean(axis))), 360.0)


@register
class Integrate(Stage):
    """Incoherent integration of N_B snapshots (thesis eq. 2.22); see module doc."""

    kind = "integrate"
    params = {
        "snapshots": Param("int", 8, "N_B, snapshots per sum", check=positive),
        "mode": Param("str", "blockwise", "disjoint sums or a sliding sum",
                      choices=("blockwise", "sliding")),
        "mean": Param("bool", False, "divide the sum by N_B"),
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
            if b.domain != ("snapshot", "freq", "beam"):
                raise ConfigError(f"stage {self.name!r}: needs ('snapshot', 'freq', 'beam') "
                                  f"blocks (from cbf), got {b.domain}")
            y = b.data
            p = np.empty(y.shape, np.float32)
            if np.iscomplexobj(y):
                abs2(np.ascontiguousarray(y, np.complex64).reshape(-1), p.reshape(-1))
            else:
                p[...] = y
            times = np.asarray(b.meta.get("times", np.full(y.shape[0], b.t_centre)), float)
            heads = np.asarray(b.meta.get("headings", np.zeros(y.shape[0])), float)
            if "starts" in b.meta and b.meta.get("hop"):
                ks = np.asarray(b.meta["starts"], np.int64) // int(b.meta["hop"])
            else:
                ks = count + np.arange(y.shape[0], dtype=np.int64)
            count = int(ks[-1]) + 1 if ks.size else count
            if tail_p is not None and (tail_p.shape[1:] != p.shape[1:] or (
                    tail_k.size and ks.size and ks[0] != tail_k[-1] + 1)):
                tail_p = None  # axes changed or snapshots missing: start afresh
                tail_t, tail_h, tail_k = np.zeros(0), np.zeros(0), np.zeros(0, np.int64)
            buf = p if tail_p is None or tail_p.shape[0] == 0 else np.concatenate([tail_p, p])
            tb = np.concatenate([tail_t, times])
            hb = np.concatenate([tail_h, heads])
            kb = np.concatenate([tail_k, ks])
            if self.mode == "blockwise" and kb.size:
                # windows on the absolute snapshot grid (snapshot k·N starts one), so a run
                # started anywhere (a segment with warm-up) integrates the same snapshots
                lead = min(int((-kb[0]) % n), kb.size)
                buf, tb, hb, kb = buf[lead:], tb[lead:], hb[lead:], kb[lead:]
            t_n = buf.shape[0]
            k = 0 if t_n < n else (t_n - n) // step + 1
            if k:
                out = np.empty((k,) + buf.shape[1:], np.float32)
                window_sums(buf.reshape(t_n, -1), n, step, out.reshape(k, -1))
                if self.mean:
                    out /= n
                starts = np.arange(k) * step
                win_idx = starts[:, None] + np.arange(n)[None, :]
                t_out = tb[win_idx].mean(axis=1)
                h_out = _circ_mean_deg(hb[win_idx], axis=1)
                meta = dict(b.meta)
                meta.update(times=t_out, headings=h_out, snapshots=n, integration=self.mode,
                            integration_mean=self.mean)
                d = float(b.meta.get("nfft", 0)) / b.fs  # one snapshot's duration, s
                t0 = float(tb[0] - 0.5 * d)
                span = float(tb[win_idx[-1, -1]] - tb[0]) + d
                yield b.replace(data=out, t0=t0, span=span, index=index, meta=meta)
                index += k
            used = k * step
            tail_p = buf[used:].copy() if used < t_n else buf[:0]
            tail_t, tail_h, tail_k = tb[used:], hb[used:], kb[used:]


def check_power_block(stage: Stage, b: Block) -> None:
    """Raise a ConfigError naming ``stage`` unless ``b`` is a power block from ``integrate``."""
    if b.domain != ("snapshot", "freq", "beam") or np.iscomplexobj(b.data):
        raise ConfigError(f"stage {stage.name!r}: needs power blocks from 'integrate', "
                          f"got {b.domain}")
