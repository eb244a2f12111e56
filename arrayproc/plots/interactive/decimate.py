"""Bounding the size of what the report embeds: products reduced before they go into the page.

A BTR or LOFAR of an hour-long run holds hundreds of millions of values, more than a browser
page can carry. Each reducer here returns the reduced array and a sentence saying what was
done, which the page prints under its section:

* images are averaged over blocks of consecutive rows (time) in linear power and returned to
  dB (:func:`block_mean_db`), so levels stay levels;
* the LOFAR's frequency axis is reduced by the maximum over blocks of bins
  (:func:`block_max`): a tonal one bin wide survives, which a mean would dilute;
* beams and point sets are thinned by an even stride (:func:`stride`).

numpy's reshape-and-reduce does the work; nothing here is specific to the report except the
limits.
"""

from __future__ import annotations

import numpy as np

#: At most this many BTR rows (time) and beams in the page.
BTR_MAX = (600, 361)
#: Values of all the LOFAR beams the page keeps together (float32 each).
LOFAR_MAX_VALUES = 1_500_000
#: At most this many LOFAR bins and rows per beam.
LOFAR_MAX_BINS = 512
LOFAR_MAX_ROWS = 400
#: Points of a scatter (bearings, contacts, track points) and rows of a table.
POINTS_MAX = 20_000
TABLE_MAX = 2_000
#: Range-Doppler maps kept, and the cells of each (range rates, ranges).
RD_MAX_MAPS = 24
RD_MAX = (256, 512)


def factor(n: int, n_max: int) -> int:
    """The smallest block length k with ceil(n / k) <= n_max (1 when n fits)."""
    return max(1, -(-int(n) // max(1, int(n_max))))


def _blocks(x: np.ndarray, axis: int, k: int) -> np.ndarray:
    """x with ``axis`` split into blocks of k (the last block padded with NaN)."""
    x = np.moveaxis(np.asarray(x, float), axis, -1)
    n = x.shape[-1]
    m = -(-n // k)
    pad = np.full(x.shape[:-1] + (m * k - n,), np.nan)
    return np.concatenate([x, pad], axis=-1).reshape(x.shape[:-1] + (m, k))


def block_mean_db(p_db: np.ndarray, axis: int, n_max: int) -> tuple[np.ndarray, int]:
    """Average dB levels over blocks of consecutive values along ``axis`` in linear power,
    10·log10(mean(10^(L/10))), so that at most ``n_max`` remain. Returns (array, block)."""
    k = factor(np.shape(p_db)[axis], n_max)
    if k == 1:
        return np.asarray(p_db, float), 1
    b = _blocks(p_db, axis, k)
    with np.errstate(all="ignore"):
        top = np.nanmax(b, axis=-1, keepdims=True)
        m = top[..., 0] + 10 * np.log10(np.nanmean(10 ** ((b - top) / 10), axis=-1))
    return np.moveaxis(m, -1, axis), k


def block_max(x: np.ndarray, axis: int, n_max: int) -> tuple[np.ndarray, int]:
    """Maximum over blocks of consecutive values along ``axis`` so that at most ``n_max``
    remain. Returns (array, block)."""
    k = factor(np.shape(x)[axis], n_max)
    if k == 1:
        return np.asarray(x, float), 1
    with np.errstate(all="ignore"):
        m = np.nanmax(_blocks(x, axis, k), axis=-1)
    return np.moveaxis(m, -1, axis), k


def block_centres(x: np.ndarray, k: int) -> np.ndarray:
    """The mean of each block of k consecutive axis values (the axis of a reduced array)."""
    if k == 1:
        return np.asarray(x, float)
    return np.nanmean(_blocks(x, 0, k), axis=-1)


def stride(n: int, n_max: int) -> np.ndarray:
    """Indices of an even thinning of n items to at most ``n_max``."""
    return np.arange(0, int(n), factor(n, n_max))


def note(what: str, k: int, how: str) -> str:
    """The sentence the page prints for one reduction ('' when nothing was reduced)."""
    return f"{what}: {how} over blocks of {k}." if k > 1 else ""
