"""Covariance ellipses on plan-view plots (positions in km)."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.patches import Ellipse

__all__ = ["cov_ellipse"]


def cov_ellipse(ax: Any, mean: np.ndarray, cov: np.ndarray, nsig: float = 2.0,
                **kw: Any) -> None:
    """Draw the ``nsig``-σ ellipse of a 2×2 position covariance on a km plan view.

    Parameters
    ----------
    ax : matplotlib Axes
        Axes in km, x east / y north.
    mean : (2,) array
        Centre, m.
    cov : (2, 2) array
        Covariance, m² (symmetrised; negative eigenvalues clipped to 0).
    nsig : float
        Number of standard deviations of the semi-axes.
    **kw
        Passed to :class:`matplotlib.patches.Ellipse` (edge colour, line width, ...).
    """
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    w = np.clip(w, 0.0, None)
    ang = np.degrees(np.arctan2(v[1, 1], v[0, 1]))
    ax.add_patch(Ellipse(np.asarray(mean) / 1e3, 2 * nsig * np.sqrt(w[1]) / 1e3,
                         2 * nsig * np.sqrt(w[0]) / 1e3, angle=ang, fill=False, **kw))
