"""Element positions of a towed array estimated from the navigation track by threading.

Threading model (as in PAMGuard's): a water-pulled array follows the path its tow point
took, so element n, a distance x_n along the array from the reference point (x_n < 0 aft),
is where the reference point was when it had travelled x_n less along its path. From
``/nav`` fixes p_i at times t_i the path is the polyline through the fixes, parametrised by
its cumulative chord length S_i; at time t the reference point is at S(t) (linear in t
between fixes) and element n at the point of the polyline at S(t) + x_n, offset y_n to
starboard of the interpolated heading there. Before the first fix the path is extended
backwards along the first heading (the array has not yet been towed along a known path).

Positions are returned in the body frame of the reference point's heading at t, the frame
the beamformers steer in, so a straight track gives back the nominal layout.
"""

from __future__ import annotations

import numpy as np

from arrayproc.geo.nav import Nav


def _path_param(nav: Nav) -> np.ndarray:
    """Cumulative chord length S_i (m) of the nav polyline at its fixes."""
    step = np.hypot(*np.diff(nav.position, axis=0).T)
    return np.concatenate([[0.0], np.cumsum(step)])


def _point_at(nav: Nav, s_fix: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Polyline point (…, 2) and heading (…,) deg at path parameters s (extrapolated
    backwards along the first fix's heading, forwards along the last)."""
    hd_u = np.rad2deg(np.unwrap(np.deg2rad(nav.heading)))
    x = np.interp(s, s_fix, nav.position[:, 0])
    y = np.interp(s, s_fix, nav.position[:, 1])
    h = np.interp(s, s_fix, hd_u)
    for end, idx in ((s < s_fix[0], 0), (s > s_fix[-1], -1)):
        if np.any(end):
            d = s[end] - s_fix[idx]
            hr = np.deg2rad(nav.heading[idx])
            x[end] = nav.position[idx, 0] + d * np.sin(hr)
            y[end] = nav.position[idx, 1] + d * np.cos(hr)
    return np.stack([x, y], -1), h


def threaded_positions(nav: Nav, body: np.ndarray, t: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Threaded element positions at times t.

    Parameters
    ----------
    nav : Nav
        Reference-point track (at least two fixes; a static track returns the nominal layout).
    body : (ch, 3) ndarray
        Nominal element positions in the body frame (x forward, y starboard, z down), m.
    t : (n,) ndarray
        Times, s.

    Returns
    -------
    body_t : (n, ch, 3) ndarray
        Element positions in the body frame of the reference heading at each time, m.
    world : (n, ch, 3) ndarray
        The same in the world frame (x east, y north, z down), m.
    """
    t = np.atleast_1d(np.asarray(t, float))
    body = np.asarray(body, float)
    ref, hd, dp, _ = nav.at(t)
    if nav.time.size < 2:
        h = np.deg2rad(hd)[:, None]
        bt = np.repeat(body[None], t.size, 0)
    else:
        s_fix = _path_param(nav)
        s_ref = np.interp(t, nav.time, s_fix)
        p, h_el = _point_at(nav, s_fix, s_ref[:, None] + body[None, :, 0])
        he = np.deg2rad(h_el)
        wx = p[..., 0] + body[None, :, 1] * np.cos(he)
        wy = p[..., 1] - body[None, :, 1] * np.sin(he)
        h = np.deg2rad(hd)[:, None]
        dx, dy = wx - ref[:, :1], wy - ref[:, 1:]
        bt = np.empty((t.size,) + body.shape)
        bt[..., 0] = dx * np.sin(h) + dy * np.cos(h)
        bt[..., 1] = dx * np.cos(h) - dy * np.sin(h)
        bt[..., 2] = body[None, :, 2]
    world = np.empty_like(bt)
    world[..., 0] = ref[:, :1] + bt[..., 0] * np.sin(h) + bt[..., 1] * np.cos(h)
    world[..., 1] = ref[:, 1:] + bt[..., 0] * np.cos(h) - bt[..., 1] * np.sin(h)
    world[..., 2] = dp[:, None] + bt[..., 2]
    return bt, world
