"""Initial hypotheses of the recursive TDOA tracker from its first usable row of delays: the
plane-wave direction, its mirror sides and a bank of range priors (module doc of
:mod:`arrayproc.track.delays`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arrayproc.errors import FormatError
from arrayproc.track.models.base import MotionModel
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.static import StaticPosition
from arrayproc.track.state import GaussianState

__all__ = ["initial_hypotheses", "motion_model"]


def motion_model(d: dict[str, Any]) -> MotionModel:
    """The motion model of ``delays.motion``: static (eq. (3.40)) or CV (L-R eqs. (2)-(4))."""
    if d["motion"] == "static":
        return StaticPosition(q=float(d["q"]))
    return ConstantVelocity(q1=float(d["q"]))


def initial_hypotheses(tau: np.ndarray, sigma: np.ndarray, elements: np.ndarray, ref: int,
                       sound_speed: float, heading_rad: float | None, own_vel: np.ndarray,
                       d: dict[str, Any]) -> tuple[list[GaussianState], list[str]]:
    """Initial states from one row of delays: plane-wave direction + range prior.

    Parameters
    ----------
    tau : (N,) array
        Delays to the reference (s), NaN where missing.
    sigma : (N,) array
        Their σ (s).
    elements : (N, 3) array
        Element positions relative to the reference element (m), world axes.
    ref : int
        Reference element.
    sound_speed : float
        m/s.
    heading_rad : float or None
        Forward direction of a line array (rad; None: from the last element to the reference).
    own_vel : (2,) array
        Observer velocity (m/s), for the CV relative velocity.
    d : dict
        The ``delays`` settings (:data:`~arrayproc.track.delays.config.DELAYS_DEFAULTS`).

    Returns
    -------
    states : list of GaussianState
        One per hypothesis: per side (two mirrors for a line array with ``side = "auto"``)
        one per range of the bank (or the one range prior).
    sides : list of str
        ``"port"``, ``"starboard"`` or ``""`` (2-D array), per hypothesis.
    """
    from arrayproc.track.batch.td_tma import plane_wave_directions

    el = np.asarray(elements, float)
    ok = np.isfinite(tau) & np.isfinite(sigma) & (sigma > 0)
    ok[ref] = False
    pw = plane_wave_directions(np.where(ok, tau, np.nan)[None], el[None, :, :2], ref,
                               sound_speed,
                               None if heading_rad is None else np.array([heading_rad]))
    dd = el[ok, :2] - el[ref, :2]
    s_mean = float(np.sqrt(np.mean(np.asarray(sigma, float)[ok] ** 2)))
    if "bearing" in pw:
        beta = [float(pw["bearing"][0])]
        sides = [""]
        s_fit = sound_speed * s_mean / max(float(np.sqrt(np.linalg.eigvalsh(dd.T @ dd)[0])),
                                           1e-9)
    else:
        th, h = float(pw["cone"][0]), float(pw["heading"][0])
        a = np.array([math.sin(h), math.cos(h)])
        s_fit = sound_speed * s_mean / max(float(np.linalg.norm(dd @ a)), 1e-9) \
            / max(math.sin(th), 0.05)
        cand = {"port": h - th, "starboard": h + th}
        sides = ["port", "starboard"] if d["side"] == "auto" else [d["side"]]
        beta = [cand[s] for s in sides]
    if not all(math.isfinite(b) for b in beta):
        raise FormatError("delays: the first usable row gives no plane-wave direction")
    s_b = max(math.radians(d["sigma_bearing_deg"]), s_fit)
    if d.get("range_bank"):
        r0, r1, nb = d["range_bank"]
        rho = (r1 / r0) ** (1.0 / (nb - 1))
        ranges = r0 * rho ** np.arange(nb)
        sig_r = ranges * (rho - 1.0) / 2.0
    else:
        ranges, sig_r = np.array([float(d["range_m"])]), np.array([float(d["sigma_range_m"])])
    cv = d["motion"] == "cv"
    out, names = [], []
    for b, side in zip(beta, sides, strict=True):
        u = np.array([math.sin(b), math.cos(b)])
        v = np.array([math.cos(b), -math.sin(b)])
        for r, sr in zip(ranges, sig_r, strict=True):
            Pxy = sr * sr * np.outer(u, u) + (r * s_b) ** 2 * np.outer(v, v)
            if cv:
                x = np.r_[r * u, -np.asarray(own_vel, float)[:2]]
                P = np.zeros((4, 4))
                P[:2, :2] = Pxy
                P[2:, 2:] = d["sigma_speed_mps"] ** 2 * np.eye(2)
            else:
                x, P = r * u, Pxy
            out.append(GaussianState(x, P))
            names.append(side)
    return out, names
