"""Unit sample points and weights of the deterministic sample-point filters.

Each set is ``(U, wm, wc)``: points ``U`` (m, n) in the whitened space (a point of the filter is
``x + L U_i`` with ``L Lᵀ = P``), mean weights ``wm`` and covariance weights ``wc``.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.polynomial.hermite_e import hermegauss

from arrayproc.errors import ConfigError


def unscented_points(n: int, alpha: float = 1.0, beta: float = 0.0,
                     kappa: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scaled unscented points (Julier & Uhlmann 2004; van der Merwe's scaling): 0 and
    ±√(n+λ) e_i with λ = α²(n+κ) − n. Default κ = 3 − n (Julier & Uhlmann's choice)."""
    if kappa is None:
        kappa = 3.0 - n
    lam = alpha * alpha * (n + kappa) - n
    if n + lam <= 0:
        raise ConfigError("tracker: UKF needs alpha²(n + kappa) > 0")
    c = np.sqrt(n + lam)
    U = np.zeros((2 * n + 1, n))
    U[1:n + 1] = c * np.eye(n)
    U[n + 1:] = -c * np.eye(n)
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + 1.0 - alpha * alpha + beta
    return U, wm, wc


def cubature_points(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Third-degree spherical-radial cubature points ±√n e_i, weights 1/(2n) (Arasaratnam &
    Haykin 2009)."""
    U = np.vstack([np.sqrt(n) * np.eye(n), -np.sqrt(n) * np.eye(n)])
    w = np.full(2 * n, 0.5 / n)
    return U, w, w.copy()


def gauss_hermite_points(n: int, order: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tensor-product Gauss-Hermite points of ``order`` per axis (order**n points), exact for
    polynomials of degree 2·order − 1 in each coordinate under N(0, I) (Arasaratnam, Haykin &
    Elliott 2007)."""
    if not 2 <= int(order) <= 10:
        raise ConfigError("tracker: gh_order must be between 2 and 10")
    z, w = hermegauss(int(order))
    w = w / np.sqrt(2.0 * np.pi)
    U = np.array(list(itertools.product(z, repeat=n)))
    W = np.prod(np.array(list(itertools.product(w, repeat=n))), axis=1)
    return U, W, W.copy()
