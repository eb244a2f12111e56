"""Framing a stream of contiguous time blocks into overlapping frames on the stream's absolute
sample grid."""

from __future__ import annotations

import numpy as np


class FrameBuffer:
    """Cuts a stream of contiguous time blocks into frames of ``nfft`` samples every ``hop``.

    Frames are positioned on the stream's absolute sample grid (frame k starts at sample
    k·hop of the stream), so results never depend on how the reader cut the blocks. Only the
    samples given are used (a block's padding is cut off by the caller).
    """

    def __init__(self, nfft: int, hop: int) -> None:
        self.nfft, self.hop = int(nfft), int(hop)
        self._buf: np.ndarray | None = None
        self._buf_start = 0  # absolute sample index of _buf[0]
        self._next = None  # absolute sample index of the next frame start

    def push(self, x: np.ndarray, sample0: int) -> tuple[np.ndarray, np.ndarray]:
        """Add ``x`` (n, n_ch), the stream's samples from absolute sample index ``sample0``;
        return the complete frames (k, nfft, n_ch) and their start samples (k,)."""
        s0 = int(sample0)
        if self._next is None:
            self._next = -(-s0 // self.hop) * self.hop  # first grid point at or after s0
        contiguous = self._buf is not None and self._buf_start + self._buf.shape[0] == s0
        if not contiguous or self._buf.shape[0] == 0:
            self._buf, self._buf_start = x, s0
        else:
            self._buf = np.concatenate([self._buf, x])
        off = self._next - self._buf_start
        avail = self._buf.shape[0] - off
        k = 0 if avail < self.nfft else (avail - self.nfft) // self.hop + 1
        if k:
            view = np.lib.stride_tricks.sliding_window_view(self._buf[off:], self.nfft, axis=0)
            frames = view[: (k - 1) * self.hop + 1: self.hop].transpose(0, 2, 1)
        else:
            frames = np.zeros((0, self.nfft, self._buf.shape[1]), dtype=self._buf.dtype)
        starts = self._next + self.hop * np.arange(k)
        self._next += k * self.hop
        drop = max(0, min(self._next - self._buf_start, self._buf.shape[0]))
        frames = np.ascontiguousarray(frames)  # detach from the buffer before trimming it
        self._buf = self._buf[drop:]
        self._buf_start += drop
        return frames, starts
