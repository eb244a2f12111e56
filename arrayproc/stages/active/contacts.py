"""From matched-filter peaks to contacts: bistatic range, bearings, absolute Doppler (thesis
eq. (4.9)) and the merging of one echo seen on neighbouring beams.

Range. The lag tau of a peak (s after the transmission) is the bistatic path: c tau = |s - p|
+ |s - a| with p the projector and a the array's reference point, s the scatterer. With the
scatterer at range r from a along the beam's horizontal unit vector u (body frame), |r u - p|
= c tau - r gives

    r = ((c tau)^2 - |p|^2) / (2 (c tau - u . p)),

with u . p = p_x cos(cone) for a line array (the port and starboard solutions differ only by
p_y sin(cone); the projector's starboard offset is taken as 0 in this term, exact for a
projector towed on the array's axis). The platform moves during the travel time: with speed U
along the array axis, p is the projector's position at transmission in the body frame of the
reception, p - (U tau, 0, 0) (80 m at 20 km and 3 m/s: forty range cells of the thesis's
BPSK).

Absolute Doppler, thesis eq. (4.9). Range rates here are positive *opening* (docs/architecture.md).
A still scatterer seen by a platform moving at U along the array axis closes at U cos(cone)
(two-way mean of the projector's and the array's legs, both towed at U), so its measured range
rate is -U cos(cone), and

    rdot_abs = rdot + U cos(cone)

is zero for it: the thesis's rdot_abs = rdot~ - U cos(theta) with its Doppler counted positive
closing. In a turn the projector's leg (at the transmission, with the heading then and the
projector's own swing) and the array's (at the reception) differ, and the own closing depends
on the side the scatterer is on: :func:`ownship_closing_sides` gives both,
:func:`absolute_doppler` uses their mean.
"""

from __future__ import annotations

import numpy as np


def bistatic_range(path: np.ndarray, cone_deg: np.ndarray, projector: np.ndarray,
                   speed: float | np.ndarray = 0.0, c: float = 1500.0) -> np.ndarray:
    """Range (m) from the array's reference point at reception of scatterers at bistatic
    path ``path``.

    Parameters
    ----------
    path : ndarray
        c tau, m (projector -> scatterer -> array).
    cone_deg : ndarray
        Cone angle of the beam, deg.
    projector : (3,) ndarray
        Projector offset in the body frame (forward, starboard, down), m.
    speed : float or ndarray
        Platform speed along the array axis, m/s: during the travel time tau = path / c the
        platform advances by speed tau, so at transmission the projector was at
        p - (speed tau, 0, 0) in the body frame of the reception.
    c : float
        Sound speed, m/s.

    Returns
    -------
    ndarray
        Range, m (nan where the path is shorter than the direct path).
    """
    L = np.asarray(path, float)
    p = np.asarray(projector, float)
    px = p[0] - np.asarray(speed, float) * L / c
    up = px * np.cos(np.deg2rad(np.asarray(cone_deg, float)))
    p2 = px * px + p[1] ** 2 + p[2] ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        r = (L * L - p2) / (2.0 * (L - up))
    return np.where(L > np.sqrt(p2), r, np.nan)


def bistatic_path(r: np.ndarray, cone_deg: np.ndarray, projector: np.ndarray,
                  speed: float | np.ndarray = 0.0, c: float = 1500.0) -> np.ndarray:
    """Inverse of :func:`bistatic_range`: c tau (m) of a scatterer at range r and cone angle
    (the projector's starboard offset taken as 0, as there)."""
    r = np.asarray(r, float)
    p = np.asarray(projector, float)
    a = np.deg2rad(np.asarray(cone_deg, float))
    v = np.asarray(speed, float)
    L = 2.0 * r
    for _ in range(6):  # fixed point: the projector's transmit position depends on L
        px = p[0] - v * L / c
        L = r + np.sqrt((r * np.cos(a) - px) ** 2 + (r * np.sin(a)) ** 2 + p[2] ** 2)
    return L


def ownship_closing_sides(cone_deg: np.ndarray, speed_tx: np.ndarray | float,
                          speed_rx: np.ndarray | float | None = None,
                          dheading_deg: np.ndarray | float = 0.0,
                          turn_rate_dps: np.ndarray | float = 0.0,
                          projector: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Closing speed (m/s) of a still scatterer due to the platform's own motion, to port and
    to starboard: the two-way mean of the projector's leg (at the transmission) and the
    array's (at the reception).

    The scatterer lies at cone angle ``cone`` from the array's axis at the reception, at true
    bearing b = h_rx -/+ cone (port / starboard). In the body frame of the transmission
    (forward x, starboard y) its direction from the projector is at rho = b - h_tx =
    dh -/+ cone from the bow (dh = h_rx - h_tx; far field: the same direction as from the
    array). The projector, at p in the body frame of a platform turning at omega (heading
    rate, rad/s, positive to starboard), moves at U_tx x + omega z x p = (U_tx - omega p_y,
    omega p_x); the array's reference point moves at U_rx along its axis. So

        closing = (U_tx cos(rho) + omega (p_x sin(rho) - p_y cos(rho)) + U_rx cos(cone)) / 2,

    U cos(cone) on a straight leg at constant speed (the thesis's eq. (4.9) term, the same
    for both sides). In a turn the sides differ: by U_tx sin(cone) sin(dh) from the heading
    change and by 2 omega p_x sin(cone) cos(dh) from the projector's swing (a projector 60 m
    ahead in a 1 deg/s turn moves sideways at 1.05 m/s).

    Parameters
    ----------
    cone_deg : ndarray
        Cone angle at the reception, deg.
    speed_tx : float or ndarray
        Platform speed at the transmission, m/s.
    speed_rx : float or ndarray, optional
        Platform speed at the reception, m/s (default: ``speed_tx``).
    dheading_deg : float or ndarray
        Heading at the reception minus heading at the transmission, deg.
    turn_rate_dps : float or ndarray
        Heading rate at the transmission, deg/s (positive: turning to starboard).
    projector : (3,) ndarray, optional
        Projector position in the body frame (forward, starboard, down), m (default: at the
        array's reference point).

    Returns
    -------
    port, stbd : ndarray
        Closing speed for a scatterer to port and to starboard, m/s (positive closing).
    """
    a = np.deg2rad(np.asarray(cone_deg, float))
    u_tx = np.asarray(speed_tx, float)
    u_rx = u_tx if speed_rx is None else np.asarray(speed_rx, float)
    dh = np.deg2rad(np.asarray(dheading_deg, float))
    w = np.deg2rad(np.asarray(turn_rate_dps, float))
    p = np.zeros(3) if projector is None else np.asarray(projector, float)
    out = []
    for rho in (dh - a, dh + a):
        out.append(0.5 * (u_tx * np.cos(rho) + w * (p[0] * np.sin(rho) - p[1] * np.cos(rho))
                          + u_rx * np.cos(a)))
    return out[0], out[1]


def ownship_closing(cone_deg: np.ndarray, speed_tx: np.ndarray | float,
                    speed_rx: np.ndarray | float | None = None,
                    dheading_deg: np.ndarray | float = 0.0,
                    turn_rate_dps: np.ndarray | float = 0.0,
                    projector: np.ndarray | None = None) -> np.ndarray:
    """Own closing speed (m/s) without the side: the mean of the port and starboard values of
    :func:`ownship_closing_sides` (same parameters), U cos(cone) on a straight leg.

    Returns
    -------
    ndarray
        Closing speed, m/s (positive closing).
    """
    port, stbd = ownship_closing_sides(cone_deg, speed_tx, speed_rx, dheading_deg,
                                       turn_rate_dps, projector)
    return 0.5 * (port + stbd)


def absolute_doppler(range_rate: np.ndarray, cone_deg: np.ndarray,
                     speed: np.ndarray | float, speed_rx: np.ndarray | float | None = None,
                     dheading_deg: np.ndarray | float = 0.0,
                     turn_rate_dps: np.ndarray | float = 0.0,
                     projector: np.ndarray | None = None) -> np.ndarray:
    """rdot_abs = rdot + own closing (m/s; thesis eq. (4.9), opening-positive convention), the
    side-averaged own closing of :func:`ownship_closing`.

    Parameters
    ----------
    range_rate : ndarray
        Measured range rate, m/s, positive opening.
    cone_deg : ndarray
        Cone angle, deg.
    speed, speed_rx, dheading_deg, turn_rate_dps, projector
        As ``speed_tx`` and the others of :func:`ownship_closing_sides`; with the defaults
        the closing is U cos(cone).

    Returns
    -------
    ndarray
        Absolute Doppler, m/s (0 for a still scatterer).
    """
    return np.asarray(range_rate, float) + ownship_closing(cone_deg, speed, speed_rx,
                                                           dheading_deg, turn_rate_dps,
                                                           projector)


def bearings(heading_deg: np.ndarray | float, cone_deg: np.ndarray) -> tuple[np.ndarray,
                                                                              np.ndarray]:
    """Port and starboard true bearings (deg, [0, 360)) of a cone angle: heading -+ cone."""
    h = np.asarray(heading_deg, float)
    c = np.asarray(cone_deg, float)
    return np.mod(h - c, 360.0), np.mod(h + c, 360.0)


def merge(range_m: np.ndarray, cone_deg: np.ndarray, level: np.ndarray, range_gate: float,
          cone_gate: float, rate: np.ndarray | None = None, rate_gate: float = np.inf,
          snr: np.ndarray | None = None) -> np.ndarray:
    """Indices of the contacts kept when one echo shows on several beams (array main lobe and
    sidelobes): greedy non-maximum suppression, strongest ``level`` first; a contact is
    dropped when a kept one lies within ``range_gate`` m and ``cone_gate`` deg and either has
    its range rate (within ``rate_gate`` m/s) or at least its SNR.

    One echo seen through the main lobe and the sidelobes of several beams has the same lag
    and the same range rate on all of them: its images are folded whatever their SNR. A
    contact at another range rate is a different echo or a false alarm; it is folded only by
    a kept contact of at least its SNR. With equal noise on every beam the higher peak has
    the higher SNR and this is plain suppression on ``level``. Where the noise differs between
    beams (the direct blast's sidelobe plateau on the beams it reaches), a false alarm on a
    loud beam has a higher peak than an echo on a quiet one at the same path, and would
    otherwise remove it (docs/validation/active.md, "Bracket mode").

    Parameters
    ----------
    range_m, cone_deg, level : (n,) ndarray
        Candidates' range (m; any distance, the cfar stage passes the path c tau), cone angle
        (deg) and level (any increasing measure, e.g. peak power).
    range_gate, cone_gate : float
        Gates, m and deg.
    rate : (n,) ndarray, optional
        Candidates' range rate, m/s.
    rate_gate : float
        Range rates closer than this are the same echo's, m/s.
    snr : (n,) ndarray, optional
        Candidates' SNR (any increasing measure). Without ``rate`` or ``snr``: suppression on
        the gates in range and cone alone.

    Returns
    -------
    ndarray of int
        Kept indices, strongest first.
    """
    order = np.argsort(-np.asarray(level, float), kind="stable")
    kept: list[int] = []
    r = np.asarray(range_m, float)
    c = np.asarray(cone_deg, float)
    both = rate is not None and snr is not None
    v = np.asarray(rate, float) if both else None
    q = np.asarray(snr, float) if both else None
    for i in order:
        if not np.isfinite(r[i]):
            continue
        ok = True
        for j in kept:
            if (abs(r[i] - r[j]) <= range_gate and abs(c[i] - c[j]) <= cone_gate
                    and (not both or abs(v[i] - v[j]) <= rate_gate or q[j] >= q[i])):
                ok = False
                break
        if ok:
            kept.append(int(i))
    return np.array(kept, np.int64)
