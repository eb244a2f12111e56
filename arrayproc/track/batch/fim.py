"""Fisher information, Cramér-Rao bounds and observability measures of the batch TMA methods.

- Bearings-only TMA: thesis eq. (3.53) with the Jacobian of appendix C.2 (eqs. (C.8)-(C.11)).
  The bearing ``h_b = atan2(dx, dy)`` has gradient ``[dy/r², −dx/r²]`` in the target position
  (the thesis prints ``r`` for ``r²`` and a stray ``c`` in (C.11); see
  :mod:`arrayproc.track.crlb`, whose :func:`~arrayproc.track.crlb.bearing_gradient` is used
  here); the velocity columns are the position columns times the time since the window start
  (eq. (3.41)).
- Time-delay TMA: eq. (3.53) with the Jacobian of appendix C.3 (eqs. (C.12)-(C.15)):
  ``∂h_m/∂(x, y) = (p_b − e_bn)/(c r_bn) − (p_b − e_b,ref)/(c r_b,ref)`` (the thesis's
  (C.15) repeats ``r_y`` in the y row's norm: a misprint), and the velocity rows are the
  position rows times the time since the window start (eq. (3.41)).
- Both optionally with the source at its emission time (eq. (M5) of :mod:`.motion`: the
  gradient w.r.t. the emission point times ``M⁻¹``, and the emission time in place of the
  measurement time), and the delays with a depth difference (ranges ``√(d_h² + Δz²)``).
- Compact array (compact-array paper eqs. (1)-(4)): parameters ``(x0, y0, γ, v)``; the
  information of the bearings is ``Gᵀ C⁻¹ G`` with the full bearing-error covariance C, the
  speed prior adds ``1/σ_v²`` on v (Bayesian information, Van Trees).
- Observability: the FIM is positive definite or the state is not observable (thesis
  3.3.3.2); the condition number ``K(J) = ‖J‖₂ ‖J⁻¹‖₂`` (eq. (3.54)); the range standard
  deviation (eq. (3.55)), written with squared coordinates and the covariance ``σ_xy``
  (the thesis prints ``x σ_x²`` for ``x² σ_x²`` and ``σ_xy²`` for the covariance):
  ``σ_r = √(x² σ_x² + y² σ_y² + 2 x y σ_xy) / √(x² + y²)``.

Where the FIM is not positive definite (the smallest eigenvalue of the scale-free matrix
``D^{-1/2} J D^{-1/2}``, ``D = diag J``, below :data:`PD_TOL`) the bound is NaN ("blanked").
"""

from __future__ import annotations

import numpy as np

from ..crlb import bearing_gradient
from .motion import emission_derivative, emission_points

__all__ = ["PD_TOL", "bo_jacobian", "td_jacobian", "bo_fim", "td_fim", "compact_jacobian",
           "compact_fim", "crlb_from_fim", "condition_number", "range_sigma",
           "innovation_coefficients", "whiten"]

#: Smallest eigenvalue of the unit-diagonal FIM below which it is taken as not positive
#: definite (the eigenvalues of a unit-diagonal 4×4 matrix lie in [0, 4]; round-off of an
#: exactly singular FIM stays near 1e-15).
PD_TOL = 1e-10


def bo_jacobian(state: np.ndarray, tau: np.ndarray, obs: np.ndarray,
                sound_speed: float | None = None) -> np.ndarray:
    """Jacobian of the bearings w.r.t. the initial state (thesis eqs. (C.9)-(C.11)).

    Parameters
    ----------
    state : (..., 4) array_like
        Target state [x, y, vx, vy] at the window start (m, m/s).
    tau : (B,) array_like
        Measurement times since the window start (s).
    obs : (B, 2) array_like
        Observer position at each measurement (m, x east / y north).
    sound_speed : float, optional
        With a sound speed (m/s) the bearing is that of the emission point (eq. (M5) of
        :mod:`.motion`, exact derivative ``∂p_e/∂x = M⁻¹ [I, τ_e I]``); None: the thesis's
        model (source at the measurement time).

    Returns
    -------
    (..., B, 4) ndarray
        ``∂h_b/∂x`` (rad/m, rad/(m/s)).
    """
    state = np.asarray(state, float)
    tau = np.asarray(tau, float)
    obs = np.asarray(obs, float)
    lead = state.shape[:-1]
    s = state.reshape(-1, 4)
    if sound_speed:
        pos, tau_e = emission_points(s, tau, obs, sound_speed)              # (G, B, 2)
        minv = emission_derivative(s, pos, obs, sound_speed)               # (G, B, 2, 2)
    else:
        pos = s[:, None, :2] + tau[None, :, None] * s[:, None, 2:]
        tau_e = np.broadcast_to(tau, pos.shape[:2])
        minv = None
    g = bearing_gradient(pos.reshape(-1, 2), np.broadcast_to(obs, pos.shape).reshape(-1, 2))
    g = g[:, :2].reshape(pos.shape)
    if minv is not None:
        g = np.einsum("gbi,gbij->gbj", g, minv)
    jac = np.concatenate([g, tau_e[..., None] * g], axis=-1)
    return jac.reshape(lead + (tau.size, 4))


def _td_geometry(s: np.ndarray, tau: np.ndarray, elem: np.ndarray, ref: int,
                 sound_speed: float, retarded: bool, dz: np.ndarray | None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """Source points (G, B, 2), their times (G, B), M⁻¹ (G, B, 2, 2) or None, and Δz² (B, N)
    of the delay model (eqs. (3.51), (M5))."""
    dz2 = np.zeros(elem.shape[:2]) if dz is None else np.asarray(dz, float) ** 2
    if retarded:
        pos, tau_e = emission_points(s, tau, elem[:, ref], sound_speed, dz2[:, ref])
        minv = emission_derivative(s, pos, elem[:, ref], sound_speed, dz2[:, ref])
        return pos, tau_e, minv, dz2
    pos = s[:, None, :2] + tau[None, :, None] * s[:, None, 2:]
    return pos, np.broadcast_to(tau, pos.shape[:2]), None, dz2


def td_jacobian(state: np.ndarray, tau: np.ndarray, elem: np.ndarray, ref: int,
                sound_speed: float, retarded: bool = False,
                dz: np.ndarray | None = None) -> np.ndarray:
    """Jacobian of the delays w.r.t. the initial state (thesis eqs. (C.13)-(C.15)).

    Parameters
    ----------
    state : (4,) array_like
        [x, y, vx, vy] at the window start (m, m/s).
    tau : (B,) array_like
        Snapshot times since the window start (s).
    elem : (B, N, 2) array_like
        Element positions in the world frame at each snapshot (m).
    ref : int
        Index of the reference element.
    sound_speed : float
        m/s.
    retarded : bool
        Source at the emission time of what the reference element receives at ``τ_b``
        (eq. (M5) of :mod:`.motion`, exact derivative); False: the thesis's model.
    dz : (B, N) array_like, optional
        Depth differences element − source (m): ranges ``√(d_h² + Δz²)``; None: planar.

    Returns
    -------
    (B, N, 4) ndarray
        ``∂h_bn/∂x`` (s/m, s/(m/s)); zero for the reference element.
    """
    x = np.asarray(state, float).reshape(1, 4)
    tau = np.asarray(tau, float)
    elem = np.asarray(elem, float)
    pos, tau_e, minv, dz2 = _td_geometry(x, tau, elem, ref, sound_speed, retarded, dz)
    d = pos[0][:, None, :] - elem                                  # (B, N, 2)
    u = d / (sound_speed * np.sqrt(np.sum(d * d, -1) + dz2)[..., None])
    gpos = u - u[:, ref:ref + 1, :]                                # (B, N, 2)
    if minv is not None:
        gpos = np.einsum("bni,bij->bnj", gpos, minv[0])
    return np.concatenate([gpos, tau_e[0][:, None, None] * gpos], axis=-1)


def bo_fim(state: np.ndarray, tau: np.ndarray, obs: np.ndarray, sigma_rad: float,
           sound_speed: float | None = None) -> np.ndarray:
    """Fisher information of bearings-only TMA, thesis eq. (3.53)/(C.8).

    Parameters
    ----------
    state : (..., 4) array_like
        [x, y, vx, vy] at the window start (m, m/s); several states give several FIMs.
    tau : (B,) array_like
        Measurement times since the window start (s).
    obs : (B, 2) array_like
        Observer positions (m).
    sigma_rad : float or (B,) array_like
        Bearing standard deviation (rad).
    sound_speed : float, optional
        m/s: the source at its emission time (as :func:`bo_jacobian`).

    Returns
    -------
    (..., 4, 4) ndarray
        ``J = Σ_b ∇h_bᵀ ∇h_b / σ_b²`` (units of 1/m², 1/(m·m/s), …).
    """
    jac = bo_jacobian(state, tau, obs, sound_speed)
    w = 1.0 / np.broadcast_to(np.asarray(sigma_rad, float), (np.asarray(tau).size,)) ** 2
    return np.einsum("...bi,b,...bj->...ij", jac, w, jac)


def td_fim(state: np.ndarray, tau: np.ndarray, elem: np.ndarray, ref: int, sound_speed: float,
           sigma_s: float | np.ndarray, retarded: bool = False,
           dz: np.ndarray | None = None) -> np.ndarray:
    """Fisher information of time-delay TMA, thesis eq. (3.53)/(C.12).

    Parameters
    ----------
    state : (..., 4) array_like
        [x, y, vx, vy] at the window start (m, m/s); several states give several FIMs.
    tau : (B,) array_like
        Snapshot times since the window start (s).
    elem : (B, N, 2) array_like
        Element positions (m, world frame) at each snapshot.
    ref : int
        Reference element (its delay carries no information).
    sound_speed : float
        m/s.
    sigma_s : float or (B, N) array_like
        Delay standard deviation (s); ``inf`` for a missing delay.
    retarded, dz : bool, (B, N) array_like
        As :func:`td_jacobian`.

    Returns
    -------
    (..., 4, 4) ndarray
    """
    state = np.asarray(state, float)
    elem = np.asarray(elem, float)
    tau = np.asarray(tau, float)
    w = 1.0 / np.broadcast_to(np.asarray(sigma_s, float), elem.shape[:2]) ** 2
    lead = state.shape[:-1]
    s = state.reshape(-1, 4)
    pos, tau_e, minv, dz2 = _td_geometry(s, tau, elem, ref, sound_speed, retarded, dz)
    out = np.zeros((s.shape[0], 4, 4))
    for b in range(tau.size):          # accumulate snapshot by snapshot (bounded memory)
        d = pos[:, b, None, :] - elem[b][None]                     # (G, N, 2)
        u = d / (sound_speed * np.sqrt(np.sum(d * d, -1) + dz2[b])[..., None])
        g = u - u[:, ref:ref + 1, :]
        if minv is not None:
            g = np.einsum("gni,gij->gnj", g, minv[:, b])
        gg = np.einsum("gni,n,gnj->gij", g, w[b], g)               # (G, 2, 2)
        tb = tau_e[:, b, None, None]
        out[:, :2, :2] += gg
        out[:, :2, 2:] += tb * gg
        out[:, 2:, :2] += tb * gg
        out[:, 2:, 2:] += tb**2 * gg
    return out.reshape(lead + (4, 4))


def innovation_coefficients(times: np.ndarray, sigma_rad: float,
                            correlation_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Innovation form of an exponentially correlated error ``C_ij = σ² exp(−|t_i − t_j|/τ)``.

    The Ornstein-Uhlenbeck error is Markov: ``e_b = φ_b e_{b−1} + σ√(1 − φ_b²) ξ_b`` with
    ``φ_b = exp(−(t_b − t_{b−1})/τ)``, so ``eᵀC⁻¹e = Σ_b (scale_b (e_b − φ_b e_{b−1}))²``
    (compact-array paper eq. (4) with the paper's correlated bearing errors).

    Parameters
    ----------
    times : (B,) array_like
        Strictly increasing times (s).
    sigma_rad : float
        Bearing-error standard deviation (rad).
    correlation_s : float
        Correlation time τ (s); 0 gives the diagonal covariance.

    Returns
    -------
    phi, scale : (B,) ndarray
        ``φ_b`` (``φ_0 = 0``) and ``1/(σ√(1 − φ_b²))``.
    """
    t = np.asarray(times, float)
    phi = np.zeros(t.size)
    if correlation_s > 0 and t.size > 1:
        dt = np.diff(t)
        if np.any(dt <= 0):
            raise ValueError("times must be strictly increasing for a correlated covariance")
        phi[1:] = np.exp(-dt / correlation_s)
    return phi, 1.0 / (sigma_rad * np.sqrt(1.0 - phi**2))


def whiten(e: np.ndarray, phi: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Innovations ``scale_b (e_b − φ_b e_{b−1})`` along the first axis of ``e`` (C^{-1/2} e)."""
    e = np.asarray(e, float)
    prev = np.concatenate([np.zeros_like(e[:1]), e[:-1]], axis=0)
    shape = (-1,) + (1,) * (e.ndim - 1)
    return (e - phi.reshape(shape) * prev) * scale.reshape(shape)


def compact_jacobian(params: np.ndarray, speed: float, tau: np.ndarray,
                     array_xy: np.ndarray) -> np.ndarray:
    """Jacobian of the bearings of a straight-moving source w.r.t. ``(x0, y0, γ, v)``.

    Compact-array paper eqs. (1), (3): ``α_b = atan2(x0 + v sin γ τ_b − a_x,
    y0 + v cos γ τ_b − a_y)``.

    Parameters
    ----------
    params : (3,) array_like
        x0, y0 (m), heading γ (rad).
    speed : float
        v (m/s).
    tau : (B,) array_like
        Times since the window start (s).
    array_xy : (2,) array_like
        Array position (m).

    Returns
    -------
    (B, 4) ndarray
        Columns ∂α/∂x0, ∂α/∂y0 (rad/m), ∂α/∂γ (rad/rad), ∂α/∂v (rad/(m/s)).
    """
    x0, y0, g = (float(v) for v in np.asarray(params, float).reshape(3))
    tau = np.asarray(tau, float)
    a = np.asarray(array_xy, float).reshape(2)
    e = np.array([np.sin(g), np.cos(g)])
    pos = np.array([x0, y0])[None, :] + speed * tau[:, None] * e[None, :]
    grad = bearing_gradient(pos, a[None, :])[:, :2]                 # (B, 2)
    dg = speed * tau[:, None] * np.array([np.cos(g), -np.sin(g)])[None, :]
    dv = tau[:, None] * e[None, :]
    return np.column_stack([grad[:, 0], grad[:, 1], (grad * dg).sum(1), (grad * dv).sum(1)])


def compact_fim(params: np.ndarray, speed: float, tau: np.ndarray, array_xy: np.ndarray,
                sigma_rad: float, correlation_s: float = 0.0,
                sigma_speed_mps: float = 0.0) -> np.ndarray:
    """Fisher information on ``(x0, y0, γ, v)`` from correlated bearings and a speed prior.

    ``J = Gᵀ C⁻¹ G + diag(0, 0, 0, 1/σ_v²)`` (compact-array paper eq. (4) and its speed
    assumption). With ``sigma_speed_mps = 0`` the speed is known: the 3×3 block on
    ``(x0, y0, γ)`` is returned.

    Parameters
    ----------
    params : (3,) array_like
        x0, y0 (m), γ (rad).
    speed : float
        Speed (m/s) at which the bearings are evaluated.
    tau : (B,) array_like
        Times since the window start (s), strictly increasing when correlated.
    array_xy : (2,) array_like
        Array position (m).
    sigma_rad : float
        Bearing standard deviation (rad).
    correlation_s : float
        Exponential correlation time (s); 0 for a diagonal C.
    sigma_speed_mps : float
        Standard deviation of the speed prior (m/s); 0 for a known speed.

    Returns
    -------
    (4, 4) or (3, 3) ndarray
    """
    jac = compact_jacobian(params, speed, tau, array_xy)
    phi, scale = innovation_coefficients(tau, sigma_rad, correlation_s)
    wj = whiten(jac, phi, scale)
    fim = wj.T @ wj
    if sigma_speed_mps <= 0:
        return fim[:3, :3]
    fim[3, 3] += 1.0 / sigma_speed_mps**2
    return fim


def crlb_from_fim(fim: np.ndarray, tol: float = PD_TOL) -> tuple[np.ndarray, np.ndarray]:
    """CRLB ``J⁻¹`` (thesis 3.3.3.1), blanked where J is not positive definite.

    Parameters
    ----------
    fim : (..., n, n) array_like
        Fisher information matrices.
    tol : float
        Threshold on the smallest eigenvalue of the unit-diagonal matrix.

    Returns
    -------
    crlb : (..., n, n) ndarray
        Inverse FIM, NaN where not positive definite.
    positive_definite : (...) bool ndarray
    """
    f = np.asarray(fim, float)
    finite = np.all(np.isfinite(f), axis=(-2, -1))
    f = np.where(finite[..., None, None], 0.5 * (f + np.swapaxes(f, -1, -2)), 0.0)
    d = np.sqrt(np.abs(np.diagonal(f, axis1=-2, axis2=-1)))
    ok_diag = np.all(d > 0, axis=-1)
    dd = np.where(d > 0, d, 1.0)
    fn = f / (dd[..., :, None] * dd[..., None, :])
    lam = np.linalg.eigvalsh(fn)
    pd = ok_diag & finite & (lam[..., 0] > tol)
    eye = np.broadcast_to(np.eye(f.shape[-1]), f.shape)
    inv = np.linalg.inv(np.where(pd[..., None, None], fn, eye))
    inv = inv / (dd[..., :, None] * dd[..., None, :])
    return np.where(pd[..., None, None], inv, np.nan), pd


def condition_number(fim: np.ndarray) -> np.ndarray:
    """``K(J) = ‖J‖₂ ‖J⁻¹‖₂`` (thesis eq. (3.54)); ``inf`` where J is singular or indefinite.

    Parameters
    ----------
    fim : (..., n, n) array_like

    Returns
    -------
    (...) ndarray
        Ratio of the largest to the smallest eigenvalue of the symmetric J (``inf`` for a
        non-finite J, e.g. a source on an element).
    """
    f = np.asarray(fim, float)
    finite = np.all(np.isfinite(f), axis=(-2, -1))
    f = np.where(finite[..., None, None], f, 0.0)
    lam = np.linalg.eigvalsh(0.5 * (f + np.swapaxes(f, -1, -2)))
    with np.errstate(divide="ignore", invalid="ignore"):
        k = lam[..., -1] / lam[..., 0]
    return np.where(finite & (lam[..., 0] > 0), k, np.inf)


def range_sigma(rel_xy: np.ndarray, crlb: np.ndarray) -> np.ndarray:
    """Range standard deviation from the position bound, thesis eq. (3.55).

    Parameters
    ----------
    rel_xy : (..., 2) array_like
        Target position relative to the observer (m).
    crlb : (..., n, n) array_like
        Bound whose first two rows/columns are x, y (m²).

    Returns
    -------
    (...) ndarray
        σ_r (m); NaN where the bound is blanked.
    """
    p = np.asarray(rel_xy, float)
    c = np.asarray(crlb, float)
    x, y = p[..., 0], p[..., 1]
    var = (x * x * c[..., 0, 0] + y * y * c[..., 1, 1] + 2 * x * y * c[..., 0, 1]) / (x * x + y * y)
    return np.sqrt(np.where(var >= 0, var, np.nan))
