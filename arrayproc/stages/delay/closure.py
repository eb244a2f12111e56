"""Source hypotheses from the peaks of every pair: association by delay closure over triplets.

One source heard at arrival times t_i gives the pair delays τ_ab = t_b − t_a, which close over
every triplet of channels:

    τ_ab + τ_bc = τ_ac.                                                        (C1)

Against the reference channel r this says that the delays of the reference pairs fix every
other pair's, τ_ab = τ_rb − τ_ra. A source hypothesis is one peak of each reference pair
(r, j), j ≠ r, from the K kept (:mod:`.peaks`); its triplet (r, a, b) closes when pair (a, b)
holds a peak within the tolerance of the implied lag,

    |τ̂_ab − (τ_rb − τ_ra)| ≤ g √(σ_ra² + σ_rb² + σ_ab²) + ε,                      (C2)

g = ``n_sigma`` and ε = ``floor`` s (multipath and the refinement's last step). Its score is
Σ ρ over its reference peaks and its closing peaks (the correlation of every pair at the lags the
hypothesis implies: the steered response of PHAT-weighted pairs when ρ comes from PHAT
peaks) and its closure the fraction of the (n − 1)(n − 2)/2 triplets through r that close.
All K^(n−1) hypotheses of a snapshot are scored at once (numpy over hypotheses × pairs × peaks);
the best is taken, its peaks (reference and closing) are marked, and the next best of the
hypotheses left that brings reference peaks of its own (more than half of them unmarked) is
taken, scored on its unmarked peaks only (a peak an earlier source explains adds nothing), up
to ``max_sources``. Where two sources share a reference peak (they merge on that
pair, within the main lobe 1/B) the shared delay is biased towards the other source; it is
replaced by its closure estimate τ_rj = τ_ri + τ̂_ij through the channels i and the closing
peaks the source has to itself (eq. (C1); the median over them), or, for a later source
without such a path, left out (NaN delay, ρ = 0: the other source masks this channel). The
first is always kept (as the one-peak estimator always gives a row); the others only with a
closure of at least ``min_closure``.
Ties fall to the hypothesis with the smaller lags, so the result does not depend on the order
in which the peaks are listed. Written on numpy: no library associates TDOA peaks this way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SourceHypotheses", "closure_hypotheses"]


@dataclass(frozen=True)
class SourceHypotheses:
    """The sources of one snapshot, strongest first.

    Attributes
    ----------
    tau, sigma, corr : (H, n_ch) ndarray
        Delay of every channel after the reference (s), its σ (s) and peak correlation
        (0, 0 and 1 on the reference), as the one-source ``delays`` row.
    closure : (H,) ndarray
        Fraction of the triplets through the reference that close (eq. (C2)); 1 with fewer
        than three channels.
    score : (H,) ndarray
        Σ ρ of the hypothesis's reference and closing peaks.
    shared : (H, n_ch) ndarray of bool
        The reference peak is also another hypothesis's (the sources overlap on that pair).
    tau_closure : (H, n_ch) ndarray
        Each delay from the closure instead, the median of τ_ri + τ̂_ij over the channels i
        whose reference peak is not shared and the closing peaks no earlier source took (NaN
        where none closes; eq. (C1)).
    """

    tau: np.ndarray
    sigma: np.ndarray
    corr: np.ndarray
    closure: np.ndarray
    score: np.ndarray
    shared: np.ndarray | None = None
    tau_closure: np.ndarray | None = None


def _reference_view(pairs: np.ndarray, reference: int, n_ch: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index of pair (r, j) for each j ≠ r, the sign that turns its lag into τ_rj, and the
    other channels j."""
    others = np.array([j for j in range(n_ch) if j != reference], np.int64)
    where = {(int(a), int(b)): p for p, (a, b) in enumerate(pairs)}
    idx = np.empty(others.size, np.int64)
    sign = np.empty(others.size)
    for q, j in enumerate(others):
        if (reference, j) in where:
            idx[q], sign[q] = where[(reference, int(j))], 1.0
        else:
            idx[q], sign[q] = where[(int(j), reference)], -1.0
    return idx, sign, others


def closure_hypotheses(tau: np.ndarray, sigma: np.ndarray, corr: np.ndarray,
                       pairs: np.ndarray, n_ch: int, reference: int, max_sources: int = 2,
                       n_sigma: float = 4.0, floor: float = 2e-5, min_closure: float = 0.5,
                       resolve_shared: bool = True) -> SourceHypotheses:
    """Source hypotheses of one snapshot from the peaks of every pair (module docstring).

    Parameters
    ----------
    tau, sigma, corr : (P, K) arrays
        Peaks of every pair of ``pairs`` (NaN where absent): lag of b after a (s), σ (s), ρ.
    pairs : (P, 2) int array
        Every channel pair (a, b), a < b.
    n_ch : int
        Channels.
    reference : int
        Reference channel of the output delays.
    max_sources : int
        Most hypotheses returned.
    n_sigma, floor : float
        Closure tolerance g (σ) and ε (s) of eq. (C2).
    min_closure : float
        Least closure of every hypothesis after the first.
    resolve_shared : bool
        A delay whose reference peak two hypotheses share (the sources merge on that pair,
        and the peak lies between them) is replaced by its closure estimate ``tau_closure``
        where there is one, with σ² = (π/2) v̄/k (the median of k closure paths of mean
        variance v̄).

    Returns
    -------
    SourceHypotheses
        H ≤ ``max_sources`` hypotheses (0 when a reference pair has no peak).
    """
    tau = np.asarray(tau, float)
    sigma = np.asarray(sigma, float)
    corr = np.asarray(corr, float)
    pairs = np.asarray(pairs, np.int64)
    P, K = tau.shape
    ok = np.isfinite(tau) & np.isfinite(sigma) & np.isfinite(corr)
    ridx, rsign, others = _reference_view(pairs, reference, n_ch)
    nr = others.size
    empty = SourceHypotheses(np.zeros((0, n_ch)), np.zeros((0, n_ch)), np.zeros((0, n_ch)),
                             np.zeros(0), np.zeros(0))
    if nr == 0 or not ok[ridx].any(axis=1).all():
        return empty
    # every combination of one peak per reference pair: (M, nr) peak columns
    combo = np.stack(np.meshgrid(*[np.arange(K)] * nr, indexing="ij"), -1).reshape(-1, nr)
    rows = np.broadcast_to(ridx, combo.shape)
    valid = ok[rows, combo].all(axis=1)
    combo = combo[valid]
    t_ref = rsign * tau[ridx[None, :], combo]            # (M, nr) τ_rj
    s_ref = sigma[ridx[None, :], combo]
    c_ref = corr[ridx[None, :], combo].sum(axis=1)
    # the other pairs (a, b), neither the reference, and the reference slots of a and b
    slot = np.full(n_ch, -1, np.int64)
    slot[others] = np.arange(nr)
    rest = np.flatnonzero((pairs[:, 0] != reference) & (pairs[:, 1] != reference))
    qa, qb = slot[pairs[rest, 0]], slot[pairs[rest, 1]]
    implied = t_ref[:, qb] - t_ref[:, qa]                 # (M, nq)
    var_ref = s_ref[:, qa] ** 2 + s_ref[:, qb] ** 2
    used = np.zeros((P, K), bool)
    owner = np.full((P, K), -1, np.int64)                 # first source that took each peak
    alive = np.ones(combo.shape[0], bool)
    out: list[tuple] = []
    nq = rest.size
    tol = n_sigma * np.sqrt(var_ref[:, :, None] + sigma[rest][None] ** 2) + floor
    hit = (np.abs(tau[rest][None] - implied[:, :, None]) <= tol) & ok[rest][None]
    cq_all = np.where(hit, corr[rest][None], -np.inf)
    close_col = cq_all.argmax(axis=2)                     # (M, nq) best closing peak
    closed = hit.any(axis=2)
    n_closed = closed.sum(axis=1)
    frac = n_closed / nq if nq else np.ones(combo.shape[0])
    c_close = np.take_along_axis(cq_all, close_col[:, :, None], axis=2)[:, :, 0]
    c_refs = corr[ridx[None, :], combo]
    score = c_ref + np.where(closed, c_close, 0.0).sum(axis=1)
    while alive.any() and len(out) < max_sources:
        # a further source must bring reference peaks of its own (not re-use the earlier's)
        new_ref = ~used[ridx[None, :], combo]
        new_close = closed & ~used[rest[None, :], close_col]
        # explaining away: a peak an earlier source took adds nothing to a later one's score
        gain = (np.where(new_ref, c_refs, 0.0).sum(axis=1)
                + np.where(new_close, c_close, 0.0).sum(axis=1))
        cand = alive & ((frac >= min_closure) & (new_ref.sum(axis=1) > 0.5 * nr)
                        if out else True)
        if not cand.any():
            break
        c_idx = np.flatnonzero(cand)
        # highest score; ties to the smaller lags (independent of the order of the peaks)
        keys = [t_ref[c_idx, q] for q in range(nr - 1, -1, -1)] + [-gain[c_idx]]
        h = int(c_idx[np.lexsort(keys)[0]])
        out.append((t_ref[h], s_ref[h], c_refs[h], frac[h], score[h], h))
        for rows_, cols_ in ((ridx, combo[h]), (rest[closed[h]], close_col[h, closed[h]])):
            owner[rows_, cols_] = np.where(owner[rows_, cols_] < 0, len(out) - 1,
                                           owner[rows_, cols_])
            used[rows_, cols_] = True
        alive[h] = False
    H = len(out)
    T = np.zeros((H, n_ch))
    Sg = np.zeros((H, n_ch))
    Cr = np.ones((H, n_ch))
    for i, (t, s, c, _, _, _) in enumerate(out):
        T[i, others], Sg[i, others], Cr[i, others] = t, s, c
    picks = np.array([combo[o[5]] for o in out]).reshape(H, nr)
    shared, tc = _resolve_shared(out, picks, T, Sg, Cr, tau, sigma, owner, closed, close_col,
                                 rest, qa, qb, t_ref, s_ref, ridx, others, resolve_shared)
    return SourceHypotheses(T, Sg, Cr, np.array([o[3] for o in out], float),
                            np.array([o[4] for o in out], float), shared, tc)


def _resolve_shared(out: list, picks: np.ndarray, T: np.ndarray, Sg: np.ndarray,
                    Cr: np.ndarray, tau: np.ndarray, sigma: np.ndarray, owner: np.ndarray,
                    closed: np.ndarray, close_col: np.ndarray, rest: np.ndarray,
                    qa: np.ndarray, qb: np.ndarray, t_ref: np.ndarray, s_ref: np.ndarray,
                    ridx: np.ndarray, others: np.ndarray, resolve_shared: bool
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The shared reference peaks of the hypotheses ``out`` and their closure estimates
    (eq. (C1)); with ``resolve_shared`` the rows T, Sg, Cr are corrected in place (module
    docstring). Returns (shared, tau_closure), (H, n_ch) each."""
    H, nr = picks.shape
    n_ch = T.shape[1]
    shared = np.zeros((H, n_ch), bool)
    tc = np.full((H, n_ch), np.nan)
    for i, o in enumerate(out):
        h = o[5]
        sh = np.zeros(nr, bool)
        for q in range(H):
            if q != i:
                sh |= picks[q] == picks[i]
        shared[i, others] = sh
        # τ_rj = τ_ri + τ_ij over the closing peaks of pairs (i, j), i unshared
        est: list[list[float]] = [[] for _ in range(nr)]
        var: list[list[float]] = [[] for _ in range(nr)]
        for p_i in np.flatnonzero(closed[h]):
            if owner[rest[p_i], close_col[h, p_i]] != i:  # another source's peak
                continue
            u, v = qa[p_i], qb[p_i]
            lag = tau[rest[p_i], close_col[h, p_i]]       # τ_v − τ_u
            v_l = sigma[rest[p_i], close_col[h, p_i]] ** 2
            if not sh[u]:
                est[v].append(t_ref[h, u] + lag)
                var[v].append(s_ref[h, u] ** 2 + v_l)
            if not sh[v]:
                est[u].append(t_ref[h, v] - lag)
                var[u].append(s_ref[h, v] ** 2 + v_l)
        for q in range(nr):
            if sh[q] and not est[q] and owner[ridx[q], picks[i, q]] != i:
                # another source's peak that none of this source's own peaks confirms
                T[i, others[q]], Sg[i, others[q]], Cr[i, others[q]] = np.nan, np.inf, 0.0
            if est[q]:
                tc[i, others[q]] = float(np.median(est[q]))
                if resolve_shared and sh[q]:
                    # a median of k estimates: variance about (π/2) v̄ / k
                    T[i, others[q]] = tc[i, others[q]]
                    Sg[i, others[q]] = float(np.sqrt(0.5 * np.pi * np.mean(var[q])
                                                     / len(var[q])))
    return shared, tc
