"""Bearing tracks that carry the received frequencies of their tonals: the mirrored bearing
hypotheses of :mod:`arrayproc.track.manage.mirrored` and K tonal slots per track, a stacked
filter of the :class:`~arrayproc.track.manage.manager.TrackManager` like any other.

State of a track (d = 4 + 3K):

- ``x[:4]`` the mirrored pair [β_s, β_p, β̇_s, β̇_p] (deg, deg/s), run by the hypothesis bank
  (:class:`~arrayproc.track.manage.bank.StackedBank`);
- ``x[4 + 2k], x[5 + 2k]`` = [f_k, ḟ_k] (Hz, Hz/s): the received frequency of tonal k and its
  rate, NaN when slot k is empty; nearly constant rate with frequency-acceleration noise
  ``q_freq`` (BLK eq. 6.2.2-12 on one axis), times the scan's ``q_scale``;
- ``x[4 + 2K + k]`` the age of slot k (s since its last update); a slot older than
  ``max_age_s`` is emptied.

The covariance is block diagonal (bearing block, one 2 × 2 block per slot): the bearing and the
received frequency are measured independently and are linked by no state (a bearing-space
track has no range).

Received frequency and Doppler: the frequency of a tonal at the array is
f = f0 (1 − ṙ / c) (:class:`~arrayproc.track.models.bearing_frequency.BearingFrequency`,
L-R eq. (7)); the ownship's part of ṙ is −v_o · u with u the unit line of sight, known from
the navigation and the track's bearing. The prediction adds the change of the ownship term
over the step,

    Δf = h_f([u, −v_o(t)], f) − h_f([u, −v_o(t − Δt)], f) = f (v_o(t) − v_o(t − Δt)) · u / c,

so a tonal keeps its slot through an ownship turn (the turn shifts a 400 Hz tonal by
≈ 0.7 Hz at 5 kn); the target's own Doppler drift is the slot's rate ḟ.

Measurements Z (m, 5): [cone θ, port bearing, starboard bearing, frequency, σ_θ at broadside]
(deg, Hz, deg; the frequency NaN for a broadband bearing). Each row carries its own cone σ
(:func:`line_sigma_deg` for a line, whose beam widens as the wavelength), widened by
1 / max(sin θ, s_min) towards end-fire (thesis eq. 2.9) in :func:`tonal_bearing_bank`.

Innovation of a pair: the bank's bearing innovation (best hypothesis) and the frequency
innovation of the track's slot nearest in d², ν_f = z_f − f_k, S_f = P_ff,k + σ_f². When the
measurement has no frequency or the track no tonal, ν_f = 0 and S_f = 1/(2π) Hz², so that the
pair's likelihood is its bearing likelihood alone (ln det 2πS_f = 0). The update feeds the
bearing to the bank and the frequency to the matched slot; a frequency that matches no slot
within the 1-dof χ² gate takes an empty slot (a new tonal of the track).

Written here, as no tracking package (Stone Soup included) has a track of a variable set of
tonal frequencies beside mirrored bearing hypotheses.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from arrayproc.track.manage.associate import (
    Association,
    gate_threshold,
    gnn,
    mahalanobis,
)
from arrayproc.track.manage.bank import StackedBank
from arrayproc.track.manage.tracks import Track
from arrayproc.track.models.bearing_frequency import BearingFrequency

__all__ = ["TonalBank", "TonalGNN", "tonal_slots", "TonalDistinct", "birth_tonals",
           "tonal_bearing_bank", "line_sigma_deg", "NO_FREQ_VAR"]

#: S_f of a pair without frequency information: ln det(2π S_f) = 0, the bearing likelihood
NO_FREQ_VAR = 1.0 / (2.0 * math.pi)
_NB = 4  # components of the mirrored bearing pair


def line_sigma_deg(freq_hz: np.ndarray, snr_db: np.ndarray, k_deg_hz: float, floor_deg: float
                   ) -> np.ndarray:
    """Cone-angle σ (deg) at broadside of line contacts: σ = k / (f √(S/N)), floored.

    A line array's bearing precision is its beam width over √SNR (the CRLB of a plane wave's
    direction, thesis eq. 2.9 at broadside): the beam width scales as the wavelength c / f, so
    k (deg·Hz) folds in c, the aperture and the integration. S/N = 10^(snr_db / 10) − 1
    (``snr_db`` is the line over its TPSW background, (S + N) / N).

    Parameters
    ----------
    freq_hz, snr_db : ndarray
        The lines' frequencies (Hz) and SNR (dB).
    k_deg_hz : float
        k, deg·Hz.
    floor_deg : float
        Smallest σ, deg.
    """
    sn = np.maximum(10.0 ** (np.asarray(snr_db, float) / 10.0) - 1.0, 1e-3)
    return np.maximum(k_deg_hz / (np.asarray(freq_hz, float) * np.sqrt(sn)), floor_deg)


def tonal_bearing_bank(q: float, min_sin: float = 0.2) -> StackedBank:
    """The mirrored bearing hypotheses of :func:`~arrayproc.track.manage.mirrored.mirrored_bank`
    on measurements Z (m, 5) that carry their own broadside σ (column 4): hypothesis 0 reads
    the starboard bearing, 1 the port bearing, R = (σ / max(sin θ, s_min))²."""
    from arrayproc.track.filters.stacked import StackedEKF
    from arrayproc.track.manage.mirrored import LOG_FLOOR
    from arrayproc.track.models.motion import ConstantVelocity
    from arrayproc.track.models.position import BearingDeg

    def members(Z: np.ndarray) -> np.ndarray:
        return np.asarray(Z, float)[:, [2, 1]][:, :, None]

    def noise(Z: np.ndarray) -> np.ndarray:
        Z = np.asarray(Z, float)
        s = Z[:, 4] / np.maximum(np.sin(np.deg2rad(Z[:, 0])), min_sin)
        return (s * s)[:, None, None]

    return StackedBank(StackedEKF(ConstantVelocity(q1=float(q), axes=1), BearingDeg()), 2,
                       members, noise, floor=LOG_FLOOR)


def tonal_slots(x: np.ndarray, n_tonals: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (…, K) Hz (NaN: empty slot) and their rates (…, K) Hz/s of states x
    (…, 4 + 3K)."""
    x = np.asarray(x, float)
    return x[..., _NB:_NB + 2 * n_tonals:2], x[..., _NB + 1:_NB + 2 * n_tonals:2]


class TonalBank:
    """Mirrored bearing hypotheses with K tonal slots per track (module doc).

    Parameters
    ----------
    bank : StackedBank
        The mirrored bearing bank (:func:`tonal_bearing_bank`).
    n_tonals : int
        Slots K per track.
    sigma_hz : float
        σ_f of a line's frequency, Hz.
    q_freq : float
        Frequency-acceleration noise spectral density, Hz²/s³.
    max_age_s : float
        A slot not updated for this long is emptied, s.
    sound_speed : float
        c, m/s (the ownship Doppler term).
    own_velocity : callable, optional
        ``own_velocity(t)`` (n,) s → (n, 2) m/s, the ownship velocity (east, north); without
        it the ownship Doppler term is left out.
    """

    def __init__(self, bank: StackedBank, n_tonals: int, sigma_hz: float, q_freq: float,
                 max_age_s: float, sound_speed: float = 1500.0,
                 own_velocity: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self.bank = bank
        self.n_hypotheses = bank.n_hypotheses
        self.K = int(n_tonals)
        self.sigma_hz = float(sigma_hz)
        self.q_freq = float(q_freq)
        self.max_age_s = float(max_age_s)
        self.own_velocity = own_velocity
        self.doppler = BearingFrequency(sound_speed=float(sound_speed))
        self.gate1 = gate_threshold(0.999, 1)

    @property
    def ndim(self) -> int:
        """State dimension 4 + 3K."""
        return _NB + 3 * self.K

    # -- layout
    def _fi(self, k: int) -> int:
        return _NB + 2 * k

    def _age(self, k: int) -> int:
        return _NB + 2 * self.K + k

    def initial(self, xb: np.ndarray, Pb: np.ndarray, freqs: Any, sigma_rate_hz_s: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """A track's state from its bearing pair (xb, Pb) and the frequencies (Hz) of its first
        tonals (none or NaN: no tonal yet)."""
        x = np.full(self.ndim, np.nan)
        P = np.zeros((self.ndim, self.ndim))
        x[:_NB], P[:_NB, :_NB] = xb, Pb
        x[self._age(0):] = 0.0
        f = np.atleast_1d(np.asarray(freqs, float))
        for k, v in enumerate(f[np.isfinite(f)][: self.K]):
            self._fill(x, P, k, float(v), sigma_rate_hz_s)
        return x, P

    def _fill(self, x: np.ndarray, P: np.ndarray, k: int, f: float, sigma_rate: float) -> None:
        i = self._fi(k)
        x[i], x[i + 1], x[self._age(k)] = f, 0.0, 0.0
        P[i:i + 2, i:i + 2] = np.diag([self.sigma_hz ** 2, sigma_rate ** 2])

    def _empty(self, x: np.ndarray, P: np.ndarray, k: int) -> None:
        i = self._fi(k)
        x[i] = x[i + 1] = np.nan
        P[i:i + 2, i:i + 2] = 0.0

    # -- predict
    def _ownship_shift(self, f: np.ndarray, X: np.ndarray, dt: np.ndarray, ctx: Any
                       ) -> np.ndarray:
        """Δf (n, K) of the ownship's velocity change over each track's step (module doc)."""
        t = getattr(ctx, "t", None)
        if self.own_velocity is None or t is None:
            return np.zeros_like(f)
        n = X.shape[0]
        v_now = self.own_velocity(np.full(n, float(t)))
        v_prev = self.own_velocity(float(t) - np.asarray(dt, float))
        # the mean over both mirror hypotheses: the part of Δv along the array axis (the
        # cross-axis part's sign is the side, unresolved until the turn ends)
        out = np.zeros_like(f)
        pts = np.empty((n, 2))
        for h in range(2):
            beta = np.deg2rad(X[:, h])
            u = np.stack([np.sin(beta), np.cos(beta)], 1)
            for k in range(f.shape[1]):
                fk = np.nan_to_num(f[:, k])
                self.doppler.function_points(np.column_stack([u, -v_now, fk]), None, pts)
                hf = pts[:, 1].copy()
                self.doppler.function_points(np.column_stack([u, -v_prev, fk]), None, pts)
                out[:, k] += 0.5 * (hf - pts[:, 1])
        return out

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any = None,
                W: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The bank's prediction of the bearing pairs; each filled slot
        [f, ḟ] ← [f + ḟ Δt + Δf_own, ḟ], P ← F P Fᵀ + s q_f [[Δt³/3, Δt²/2], [Δt²/2, Δt]];
        ages + Δt, slots older than ``max_age_s`` emptied."""
        X = np.array(X, float)
        P = np.array(P, float)
        dt = np.asarray(dt, float).reshape(-1)
        Xb, Pb = self.bank.predict(X[:, :_NB], np.ascontiguousarray(P[:, :_NB, :_NB]), dt, ctx)
        f, _ = tonal_slots(X, self.K)
        shift = self._ownship_shift(f, Xb, dt, ctx)
        s = float(getattr(ctx, "q_scale", 1.0)) * self.q_freq
        X[:, :_NB], P[:, :_NB, :_NB] = Xb, Pb
        for k in range(self.K):
            i, a = self._fi(k), self._age(k)
            on = np.isfinite(X[:, i])
            X[:, a] += dt
            X[on, i] += X[on, i + 1] * dt[on] + shift[on, k]
            B = P[:, i:i + 2, i:i + 2]
            p00 = B[:, 0, 0] + 2 * dt * B[:, 0, 1] + dt * dt * B[:, 1, 1] + s * dt ** 3 / 3
            p01 = B[:, 0, 1] + dt * B[:, 1, 1] + s * dt ** 2 / 2
            p11 = B[:, 1, 1] + s * dt
            P[on, i, i], P[on, i, i + 1], P[on, i + 1, i], P[on, i + 1, i + 1] = \
                p00[on], p01[on], p01[on], p11[on]
            for n in np.flatnonzero(on & (X[:, a] > self.max_age_s)):
                self._empty(X[n], P[n], k)
        return X, P

    # -- innovation and update
    def _freq_match(self, X: np.ndarray, P: np.ndarray, fz: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest slot (n, m) (−1 none), ν_f and S_f (n, m) of every pair (module doc)."""
        f, _ = tonal_slots(X, self.K)
        var = np.stack([P[:, self._fi(k), self._fi(k)] for k in range(self.K)], 1) \
            + self.sigma_hz ** 2
        nu = fz[None, :, None] - f[:, None, :]                     # (n, m, K)
        d2 = np.where(np.isfinite(nu), nu * nu / var[:, None, :], np.inf)
        k = np.argmin(d2, axis=-1)
        ok = np.isfinite(np.take_along_axis(d2, k[..., None], -1)[..., 0])
        nu_f = np.where(ok, np.take_along_axis(nu, k[..., None], -1)[..., 0], 0.0)
        S_f = np.where(ok, np.take_along_axis(np.broadcast_to(var[:, None, :], nu.shape),
                                              k[..., None], -1)[..., 0], NO_FREQ_VAR)
        return np.where(ok, k, -1), nu_f, S_f

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any = None,
                   W: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """ν (n, m, 2) [bearing deg, frequency Hz] and S (n, m, 2, 2) of every pair."""
        Z = np.asarray(Z, float).reshape(-1, 5)
        nb, Sb = self.bank.innovation(X[:, :_NB], np.ascontiguousarray(P[:, :_NB, :_NB]), Z,
                                      ctx, W)
        _k, nu_f, S_f = self._freq_match(X, P, Z[:, 3])
        nu = np.concatenate([nb, nu_f[..., None]], -1)
        S = np.zeros(nu.shape + (2,))
        S[..., 0, 0] = Sb[..., 0, 0]
        S[..., 1, 1] = S_f
        return nu, S

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray,
               W: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Tracks X (a, d) updated with ``Z[idx]``: the bank with the bearings, the matched
        slot with the frequency (Kalman gain on [f, ḟ] with H = [1, 0]) or an empty slot
        when none matches. Returns X, P, the bearing mixture log-likelihood and W."""
        Z = np.asarray(Z, float).reshape(-1, 5)
        idx = np.asarray(idx, np.int64)
        X, P = np.array(X, float), np.array(P, float)
        Xb, Pb, tot, Wn = self.bank.update(X[:, :_NB], np.ascontiguousarray(P[:, :_NB, :_NB]),
                                           Z, ctx, idx, W)
        X[:, :_NB], P[:, :_NB, :_NB] = Xb, Pb
        fz = Z[idx, 3]
        k, nu_f, S_f = self._freq_match(X, P, fz)
        a = np.arange(idx.size)
        kk, nf, sf = k[a, a], nu_f[a, a], S_f[a, a]
        for r in np.flatnonzero(np.isfinite(fz)):
            if kk[r] >= 0 and nf[r] ** 2 / sf[r] <= self.gate1:
                self.update_slot(X[r], P[r], int(kk[r]), float(fz[r]))
            else:
                self.adopt(X[r], P[r], float(fz[r]))
        return X, P, tot, Wn

    def update_slot(self, x: np.ndarray, P: np.ndarray, k: int, f: float) -> None:
        """Kalman update, in place, of slot k of one track with a measured frequency f."""
        i = self._fi(k)
        B = P[i:i + 2, i:i + 2]
        s = B[0, 0] + self.sigma_hz ** 2
        g = B[:, 0] / s
        x[i:i + 2] += g * (f - x[i])
        P[i:i + 2, i:i + 2] = B - np.outer(g, B[0])
        x[self._age(k)] = 0.0

    def adopt(self, x: np.ndarray, P: np.ndarray, f: float, sigma_rate: float = 0.02
              ) -> bool:
        """A new tonal f in an empty slot of one track, in place (the oldest slot when none
        is empty); True when a slot took it."""
        f_all, _ = tonal_slots(x, self.K)
        empty = np.flatnonzero(~np.isfinite(f_all))
        k = int(empty[0]) if empty.size else int(np.argmax(x[self._age(0):]))
        self._fill(x, P, k, f, sigma_rate)
        return True


class TonalDistinct:
    """The duplicate rule's ``distinct`` test of tonal tracks
    (:class:`~arrayproc.track.manage.delete.DeletionRule`), and the transfer of tonals when
    two tracks of one source merge.

    Two confirmed tracks whose tonals are all farther apart than the 1-dof χ² gate
    (d² = Δf² / (P_a + P_b + 2σ_f²)), or of which one holds tonals and the other none, are
    two sources at one bearing (a crossing) — unless both their mirror bearings stay within
    ``together_deg`` of each other for ``together_scans`` consecutive scans: one source whose
    tonals (or broadband peak and tonals) started two tracks, which the duplicate test then
    merges. Tracks sharing a tonal, or both without any, are left to the duplicate test.
    :meth:`absorb` gives the surviving track of a merged pair the other's tonals.

    Parameters
    ----------
    filt : TonalBank
        The tracks' filter (slot layout, σ_f).
    together_deg : float
        Bearing difference (deg) under which two tracks are together.
    together_scans : int
        Consecutive scans together after which tracks with disjoint tonals are one source.
    """

    def __init__(self, filt: TonalBank, together_deg: float, together_scans: int) -> None:
        self.filt = filt
        self.together_deg = float(together_deg)
        self.together_scans = int(together_scans)
        self.counts: dict[tuple[int, int], int] = {}

    def disjoint(self, xa: np.ndarray, Pa: np.ndarray, xb: np.ndarray, Pb: np.ndarray) -> bool:
        """Both states hold tonals and none of one matches one of the other."""
        K = self.filt.K
        fa, _ = tonal_slots(xa, K)
        fb, _ = tonal_slots(xb, K)
        ia, ib = np.flatnonzero(np.isfinite(fa)), np.flatnonzero(np.isfinite(fb))
        if ia.size == 0 or ib.size == 0:
            return False
        va = np.array([Pa[self.filt._fi(k), self.filt._fi(k)] for k in ia])
        vb = np.array([Pb[self.filt._fi(k), self.filt._fi(k)] for k in ib])
        d2 = (fa[ia][:, None] - fb[ib][None, :]) ** 2 / (
            va[:, None] + vb[None, :] + 2 * self.filt.sigma_hz ** 2)
        return bool(d2.min() > self.filt.gate1)

    def __call__(self, a: Track, b: Track) -> bool:
        key = (min(a.id, b.id), max(a.id, b.id))
        d = (np.asarray(a.x[:2]) - np.asarray(b.x[:2]) + 180.0) % 360.0 - 180.0
        n = self.counts.get(key, 0) + 1 if np.all(np.abs(d) <= self.together_deg) else 0
        self.counts[key] = n
        return not self.shared(a.x, a.P, b.x, b.P) and n < self.together_scans

    def shared(self, xa: np.ndarray, Pa: np.ndarray, xb: np.ndarray, Pb: np.ndarray) -> bool:
        """Both states hold a tonal of the other (or neither holds any: two broadband tracks,
        the bearing test alone)."""
        fa, _ = tonal_slots(xa, self.filt.K)
        fb, _ = tonal_slots(xb, self.filt.K)
        na, nb = np.isfinite(fa).any(), np.isfinite(fb).any()
        if not (na or nb):
            return True
        return bool(na and nb and not self.disjoint(xa, Pa, xb, Pb))

    def absorb(self, tracks: list[Track]) -> None:
        """After a scan: each track deleted while together with a live one (3 scans or
        more) hands it the tonals it does not hold."""
        by_id = {tr.id: tr for tr in tracks}
        for (i, j), n in list(self.counts.items()):
            a, b = by_id.get(i), by_id.get(j)
            if a is None or b is None or a.alive == b.alive:
                if a is None or b is None or not (a.alive or b.alive):
                    del self.counts[(i, j)]
                continue
            gone, keep = (a, b) if b.alive else (b, a)
            del self.counts[(i, j)]
            if n < 3:
                continue
            fg, _ = tonal_slots(gone.x, self.filt.K)
            for f in fg[np.isfinite(fg)]:
                fk, _ = tonal_slots(keep.x, self.filt.K)
                held = fk[np.isfinite(fk)]
                if held.size == 0 or np.abs(held - f).min() > 3.0 * self.filt.sigma_hz:
                    self.filt.adopt(keep.x, keep.P, float(f))


@dataclasses.dataclass
class _Scan:
    """One scan's association in progress (states updated in place)."""

    filt: TonalBank
    X: np.ndarray
    P: np.ndarray
    Z: np.ndarray
    ctx: Any
    W: np.ndarray | None
    hit: np.ndarray
    meas: np.ndarray
    used: np.ndarray
    in_gate: np.ndarray


class TonalGNN:
    """Global nearest neighbour on bearing and frequency together
    (:func:`~arrayproc.track.manage.associate.gnn` on d² = ν_β²/S_β + ν_f²/S_f, χ² gate of
    2 dof) between the tracks
    and the scan's lines, then GNN on bearing (1 dof) between the tracks and the scan's
    broadband rows, the confirmed tracks first (tier 1), then the tentative ones on what is
    left (tier 2: a young track does not take a line from an established one). A track takes
    at most one line and one broadband row per scan (its source's tonal and broadband peak,
    two measurements of its bearing), so that the broadband peak of a source whose track took
    its line does not feed another track.

    A line left unassigned that lies in the bearing gate of exactly one track updates the tonal
    of that track it matches (frequency only), or, when it matches none and lies within
    d² ≤ ``adopt_d2`` of the track's bearing, joins the track as a new tonal: a source's
    several lines feed one track instead of starting one each. Of the measurements left for
    the initiator, those of one scan within ``merge_deg`` of each other in cone angle (a
    source's broadband peak and its lines) start one track: the first line among them (the
    initiator takes as its tonals those of the others near it, :func:`birth_tonals`), or the
    broadband row when none is a line.

    Parameters
    ----------
    gate_prob : float
        P_G of the gates.
    adopt_d2 : float
        Bearing d² under which an unassigned line joins the only track near it.
    merge_deg : float
        Cone-angle gap under which measurements left for the initiator start one track.
    """

    def __init__(self, gate_prob: float = 0.999, adopt_d2: float = 1.0,
                 merge_deg: float = 4.0) -> None:
        self.gate_prob = float(gate_prob)
        self.adopt_d2 = float(adopt_d2)
        self.merge_deg = float(merge_deg)
        self._g2 = gate_threshold(self.gate_prob, 2)
        self._g1 = gate_threshold(self.gate_prob, 1)

    #: confirmed flags (n,) of the live tracks of the coming scan, in the manager's order
    #: (set by the caller before each step; None: one tier)
    confirmed: np.ndarray | None = None

    def __call__(self, filt: TonalBank, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
                 W: np.ndarray | None = None) -> Association:
        n, m = X.shape[0], Z.shape[0]
        hit, meas, used = np.zeros(n, bool), np.full(n, -1, np.int64), np.zeros(m, bool)
        in_gate = np.zeros(m, bool)
        is_line = np.isfinite(Z[:, 3])
        conf = self.confirmed if self.confirmed is not None and self.confirmed.size == n \
            else np.ones(n, bool)
        st = _Scan(filt, X, P, Z, ctx, W, hit, meas, used, in_gate)
        for tier in (np.flatnonzero(conf), np.flatnonzero(~conf)):
            if tier.size == 0:
                continue
            self._assign(st, tier, is_line, self._g2)
            self._other_lines(st, tier)
            self._assign(st, tier, ~is_line, self._g1)
        self._births = (getattr(ctx, "t", None), Z, self.births(Z, used | in_gate))
        return Association(st.X, st.P, st.W, hit, meas, in_gate, used)

    @staticmethod
    def _assign(st: _Scan, tier: np.ndarray, kind: np.ndarray, gate: float) -> None:
        """GNN of the tracks ``tier`` with the scan's unused measurements of one ``kind``,
        then their update."""
        cols = np.flatnonzero(kind & ~st.used)
        Zs = np.ascontiguousarray(st.Z[cols])
        Wt = None if st.W is None else st.W[tier]
        nu, S = st.filt.innovation(st.X[tier], st.P[tier], Zs, st.ctx, Wt)
        d2, logdet = mahalanobis(nu, S)
        st.in_gate[cols] |= (d2 <= gate).any(0)
        pairs = gnn(d2, logdet, gate) if cols.size else []
        if not pairs:
            return
        ii = tier[np.array([p[0] for p in pairs])]
        jj = np.array([p[1] for p in pairs])
        Xu, Pu, _tot, Wu = st.filt.update(st.X[ii], st.P[ii], Zs, st.ctx, jj,
                                          None if st.W is None else st.W[ii])
        st.X[ii], st.P[ii] = Xu, Pu
        if st.W is not None:
            st.W[ii] = Wu
        st.meas[ii] = np.where(st.hit[ii], st.meas[ii], cols[jj])  # the line when it had one
        st.hit[ii] = True
        st.used[cols[jj]] = True

    def _other_lines(self, st: _Scan, tier: np.ndarray) -> None:
        """Unassigned lines in the bearing gate of exactly one track of ``tier``: its matching
        tonal updated (frequency only), or a new tonal within ``adopt_d2`` (class doc)."""
        Z = st.Z
        cols = np.flatnonzero(~st.used & np.isfinite(Z[:, 3]))
        if cols.size == 0:
            return
        Wt = None if st.W is None else st.W[tier]
        nu, S = st.filt.innovation(st.X[tier], st.P[tier], np.ascontiguousarray(Z[cols]),
                                   st.ctx, Wt)
        d2b = nu[..., 0] ** 2 / S[..., 0, 0]                        # bearing only (n, c)
        for c, j in enumerate(cols):
            near = np.flatnonzero(d2b[:, c] <= self._g1)
            if near.size != 1:
                continue
            i = int(tier[near[0]])
            k, nf, sf = st.filt._freq_match(st.X[i:i + 1], st.P[i:i + 1], Z[j:j + 1, 3])
            if k[0, 0] >= 0 and nf[0, 0] ** 2 / sf[0, 0] <= self._g1:
                st.filt.update_slot(st.X[i], st.P[i], int(k[0, 0]), float(Z[j, 3]))
            elif d2b[near[0], c] <= self.adopt_d2:
                st.filt.adopt(st.X[i], st.P[i], float(Z[j, 3]))
            else:
                continue
            st.used[j] = st.in_gate[j] = True

    def births(self, Z: np.ndarray, taken: np.ndarray) -> np.ndarray:
        """Measurements of scan Z that may start a track: of each cluster of free ones (not
        ``taken``) within ``merge_deg`` in cone angle, the first line, else the first."""
        ok = np.zeros(Z.shape[0], bool)
        free = np.flatnonzero(~taken)
        free = free[np.argsort(Z[free, 0], kind="stable")]
        for grp in np.split(free, np.flatnonzero(np.diff(Z[free, 0]) > self.merge_deg) + 1):
            if grp.size:
                lines = grp[np.isfinite(Z[grp, 3])]
                ok[lines[0] if lines.size else grp[0]] = True
        return ok

    def may_start(self, Z: np.ndarray, j: int, t: float) -> bool:
        """True when measurement j of the scan at t may start a track (:meth:`births` of this
        scan's association; every measurement free when no track was live)."""
        last = getattr(self, "_births", None)
        if last is None or last[0] != t or last[1] is not Z:
            last = (t, Z, self.births(Z, np.zeros(Z.shape[0], bool)))
            self._births = last
        return bool(last[2][j])


def birth_tonals(Z: np.ndarray, j: int, n_tonals: int, adopt_d2: float = 1.0) -> np.ndarray:
    """Frequencies (Hz) a track born from measurement j of scan Z (m, 5) starts with: its own
    and those of the scan's other lines whose cone angle is within d² ≤ ``adopt_d2`` of it
    (Δθ² / (σ_j² + σ_k²), the rows' broadside σ), distinct, at most ``n_tonals``."""
    d2 = (Z[:, 0] - Z[j, 0]) ** 2 / (Z[:, 4] ** 2 + Z[j, 4] ** 2)
    f = Z[d2 <= adopt_d2, 3]
    f = f[np.isfinite(f)]
    own = Z[j, 3]
    out = [own] if np.isfinite(own) else []
    for v in f:
        if all(abs(v - o) > 1.0 for o in out):
            out.append(float(v))
    return np.array(out[:n_tonals], float)
