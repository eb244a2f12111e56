"""Estimation accuracy over Monte Carlo runs: RMSE, NEES and the ratio to a Cramér-Rao bound.

- RMSE of errors e_r (run r) over the runs: sqrt((1/R) Σ_r ‖e_r‖²), the norm over the trailing
  ``components`` axes (e.g. the two position components), per remaining index (e.g. time).
- NEES (Bar-Shalom, Li & Kirubarajan 2001, section 5.4.2): ε_r = e_rᵀ P_r⁻¹ e_r; for a consistent
  estimator of dimension n its mean over R runs has mean n and, R ε̄ being χ²(R n), the
  two-sided 95 % band n ± 1.96 sqrt(2 n / R) (normal approximation of the χ²).
- CRLB ratio: RMSE / sqrt(trace of the bound), 1 for an efficient estimator.

numpy does the arithmetic; the formulas are kept here so that every reproduction computes them
the same way.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rmse", "nees", "nees_band", "crlb_rms", "crlb_ratio"]


def rmse(err: np.ndarray, components: int = 0, axis: int = 0) -> np.ndarray:
    """Root mean square of errors over the runs.

    Parameters
    ----------
    err : ndarray
        Errors, runs along ``axis``.
    components : int
        Trailing axes summed as a squared norm before averaging (0: scalar errors).
    axis : int
        Axis of the runs.

    Returns
    -------
    ndarray or float
        sqrt(mean over runs of ‖e‖²).
    """
    e2 = np.asarray(err, float) ** 2
    if components:
        e2 = e2.sum(axis=tuple(range(-components, 0)))
    return np.sqrt(np.mean(e2, axis=axis))


def nees(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ε = eᵀ P⁻¹ e (Bar-Shalom et al. 2001, section 5.4.2).

    Parameters
    ----------
    err : ndarray (..., n)
        Estimation errors.
    cov : ndarray (..., n, n)
        The estimator's reported covariances.

    Returns
    -------
    ndarray (...)
    """
    e = np.asarray(err, float)
    sol = np.linalg.solve(np.asarray(cov, float), e[..., None])[..., 0]
    return np.sum(e * sol, axis=-1)


def nees_band(n: int, runs: int, z: float = 1.96) -> tuple[float, float]:
    """Two-sided band of the mean NEES over ``runs`` runs of a consistent n-dimensional
    estimator, n ± z sqrt(2 n / runs) (normal approximation of χ²(runs·n) / runs)."""
    if runs < 1:
        return (float("nan"), float("nan"))
    h = z * np.sqrt(2.0 * n / runs)
    return (float(n - h), float(n + h))


def crlb_rms(bound: np.ndarray, components: slice | None = None) -> np.ndarray:
    """sqrt(trace) of CRLB matrices (..., n, n) over ``components`` (default all), the RMSE an
    efficient estimator reaches."""
    b = np.asarray(bound, float)
    if components is not None:
        b = b[..., components, components]
    return np.sqrt(np.trace(b, axis1=-2, axis2=-1))


def crlb_ratio(rmse_value: np.ndarray, bound_rms: np.ndarray) -> np.ndarray:
    """RMSE over the RMS bound (1: efficient; below 1 only by chance or bias-variance trade)."""
    return np.asarray(rmse_value, float) / np.asarray(bound_rms, float)
