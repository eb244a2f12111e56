"""Source position from the delays of one event: maximum-likelihood TDOA localisation.

The delays τ_i of the elements relative to the reference (thesis eq. (3.25) in 3-D, model and
Jacobian in :mod:`arrayproc.geo.tdoa`) are Gaussian with covariance C (the common-reference
model :func:`arrayproc.geo.tdoa.reference_covariance` built from the per-delay σ). The ML
position minimises the whitened residuals

    ‖ L⁻¹ (τ − τ(s)) ‖²,   C = L Lᵀ,

solved by ``scipy.optimize.least_squares`` from several starts: of eight points along the
plane-wave direction of the event (a linear least-squares fit of τ = −(p_i − p_ref)·u/c) and its
opposite at ranges 0.5-30 m, the ``n_starts`` of lowest cost, inside a box of ±``max_range``
around the array. The covariance is the inverse
Fisher information at the solution, (Jᵀ J)⁻¹ = (Hᵀ C⁻¹ H)⁻¹ (thesis eq. (C.8)), optionally scaled
by the fit (``cov_scale = "fit"``: by χ²/dof; ``"inflate"``: by max(1, χ²/dof)).

Delays are rejected when their normalised correlation is below ``min_corr`` or their σ is not
finite; an event with fewer than ``min_pairs`` usable delays, or whose solution lies on the
search box, is not localised.

Planar and line arrays cannot fix a 3-D position (a planar array cannot tell the two sides of
its plane, a line array sees only a cone); for them :func:`solve_direction` gives the far-field
direction: in-plane slowness by linear least squares, the out-of-plane part from |u| = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from arrayproc.geo import tdoa

COV_SCALES = ("none", "fit", "inflate")


@dataclass(frozen=True)
class LocaliseConfig:
    """Rules of :func:`localise_event`.

    Attributes
    ----------
    min_corr : float
        Smallest normalised correlation of a usable delay.
    min_pairs : int
        Fewest usable delays (at least 3 for 3 unknowns).
    cov_scale : str
        ``none``, ``fit`` or ``inflate`` (see the module docstring).
    max_range : float
        Half-size of the search box around the array centre, m.
    sigma_floor : float
        Added in quadrature to every σ, s (model and timing errors the estimator's σ ignores).
    n_starts : int
        The solver runs from this many of the eight starts, those of lowest cost.
    """

    min_corr: float = 0.3
    min_pairs: int = 4
    cov_scale: str = "none"
    max_range: float = 100.0
    sigma_floor: float = 0.0
    n_starts: int = 3


@dataclass(frozen=True)
class Solution:
    """One localised event.

    Attributes
    ----------
    position : (3,) ndarray
        m, frame of the element positions.
    cov : (3, 3) ndarray
        m².
    tdoa_rms_s : float
        RMS of the delay residuals at the solution, s.
    n_used : int
        Delays used.
    chi2 : float
        Whitened residual sum of squares.
    """

    position: np.ndarray
    cov: np.ndarray
    tdoa_rms_s: float
    n_used: int
    chi2: float


def array_rank(elements: np.ndarray, tol: float = 1e-3) -> int:
    """Dimension spanned by the element positions: 1 line, 2 planar, 3 volumetric.

    Parameters
    ----------
    elements : (n, 3) array
        Element positions, m.
    tol : float
        Singular values below ``tol`` times the largest count as zero.

    Returns
    -------
    int
    """
    p = np.asarray(elements, float)
    sv = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    if sv.size == 0 or sv[0] == 0:
        return 0
    return int(np.sum(sv > tol * sv[0]))


def _usable(tau: np.ndarray, sigma: np.ndarray, corr: np.ndarray, reference: int,
            min_corr: float) -> np.ndarray:
    use = (np.asarray(corr) >= min_corr) & np.isfinite(sigma) & (np.asarray(sigma) > 0) \
        & np.isfinite(tau)
    use[reference] = False
    return use


def _direction_lls(tau: np.ndarray, elements: np.ndarray, reference: int, c: float,
                   use: np.ndarray) -> np.ndarray:
    A = -(elements[use] - elements[reference]) / c
    k, *_ = np.linalg.lstsq(A, tau[use], rcond=None)
    nk = np.linalg.norm(k)
    return k / nk if nk > 0 else np.array([0.0, 0.0, 1.0])


def localise_event(tau: np.ndarray, sigma: np.ndarray, corr: np.ndarray, elements: np.ndarray,
                   reference: int, c: float, cfg: LocaliseConfig = LocaliseConfig()
                   ) -> Solution | None:
    """ML 3-D position of one event from its delays (see the module docstring).

    Parameters
    ----------
    tau, sigma, corr : (n,) arrays
        Delays (s), their standard deviations (s) and normalised correlations, per element.
    elements : (n, 3) array
        Element positions, m (the position comes out in this frame).
    reference : int
        Reference element of the delays.
    c : float
        Sound speed, m/s.
    cfg : LocaliseConfig
        Rejection and covariance rules.

    Returns
    -------
    Solution or None
        None when the event is rejected.
    """
    tau = np.asarray(tau, float)
    sigma = np.asarray(sigma, float)
    el = np.asarray(elements, float)
    use = _usable(tau, sigma, corr, reference, cfg.min_corr)
    m = int(use.sum())
    if m < max(3, cfg.min_pairs):
        return None
    sig = np.sqrt(sigma[use] ** 2 + cfg.sigma_floor**2)
    C = tdoa.reference_covariance(sig)
    Linv = np.linalg.inv(np.linalg.cholesky(C))
    idx = np.flatnonzero(use)
    t_u = tau[use]

    def resid(s: np.ndarray) -> np.ndarray:
        return Linv @ (t_u - tdoa.predicted_delays(s, el, reference, c)[idx])

    def jac(s: np.ndarray) -> np.ndarray:
        return -Linv @ tdoa.jacobian(s, el, reference, c)[idx]

    centre = el.mean(axis=0)
    box = cfg.max_range
    lo, hi = centre - box, centre + box
    u = _direction_lls(tau, el, reference, c, use)
    starts = np.array([centre + sign * r * u for sign in (1.0, -1.0)
                       for r in (0.5, 2.0, 8.0, 30.0)])
    starts = np.clip(starts, lo + 1e-6, hi - 1e-6)
    # cost of every start at once; the solver runs from the best few
    pred = tdoa.predicted_delays(starts, el, reference, c)[:, idx]
    cost0 = np.sum((Linv @ (t_u[None, :] - pred).T) ** 2, axis=0)
    best = None
    for k in np.argsort(cost0)[:cfg.n_starts]:
        sol = least_squares(resid, starts[k], jac=jac, bounds=(lo, hi), method="trf",
                            x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
        if best is None or sol.cost < best.cost:
            best = sol
    s = best.x
    if np.any(np.abs(s - centre) > 0.999 * box):
        return None
    J = jac(s)
    try:
        cov = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return None
    chi2 = float(2 * best.cost)
    dof = m - 3
    if cfg.cov_scale != "none" and dof > 0:
        f = chi2 / dof
        cov = cov * (f if cfg.cov_scale == "fit" else max(1.0, f))
    res = t_u - tdoa.predicted_delays(s, el, reference, c)[idx]
    return Solution(s, cov, float(np.sqrt(np.mean(res**2))), m, chi2)


def solve_direction(tau: np.ndarray, sigma: np.ndarray, corr: np.ndarray,
                    elements: np.ndarray, reference: int, c: float,
                    min_corr: float = 0.3) -> tuple[np.ndarray, np.ndarray, int] | None:
    """Far-field direction from the delays of a planar or line array (or any array).

    The direction u solves τ_i = −(p_i − p_ref)·u/c by weighted least squares in the
    subspace the elements span; the remaining component follows from |u| = 1 with a positive
    sign along the array's normal (for a planar array the mirror image through the plane is
    equally likely; for a line array only the cone angle is meaningful).

    Parameters
    ----------
    tau, sigma, corr : (n,) arrays
        Delays (s), σ (s), normalised correlations.
    elements : (n, 3) array
        Element positions, m.
    reference : int
        Reference element.
    c : float
        Sound speed, m/s.
    min_corr : float
        Smallest usable correlation.

    Returns
    -------
    (u, cov_u, n_used) or None
        Unit vector towards the source, covariance of its in-subspace estimate (3, 3), number
        of delays used; None with fewer usable delays than the subspace's dimension.
    """
    tau = np.asarray(tau, float)
    sigma = np.asarray(sigma, float)
    el = np.asarray(elements, float)
    use = _usable(tau, sigma, corr, reference, min_corr)
    d = el[use] - el[reference]
    _, sv, vt = np.linalg.svd(el - el.mean(axis=0))
    rank = int(np.sum(sv > 1e-3 * sv[0])) if sv.size and sv[0] > 0 else 0
    if rank == 0 or use.sum() < rank:
        return None
    B = vt[:rank].T  # (3, rank) basis of the span
    A = -(d @ B) / c
    C = tdoa.reference_covariance(sigma[use])
    Ci = np.linalg.inv(C)
    N = A.T @ Ci @ A
    a = np.linalg.solve(N, A.T @ Ci @ tau[use])  # in-span part of u (A carries the 1/c)
    u_in = B @ a
    n_in = float(np.linalg.norm(u_in))
    if n_in > 1.0:
        u = u_in / n_in
    else:
        u = u_in.copy()
        if rank < 3:
            normal = vt[rank] if rank == 2 else vt[1]
            u = u + np.sqrt(1.0 - n_in**2) * normal
    cov_u = B @ np.linalg.inv(N) @ B.T
    return u, cov_u, int(use.sum())
