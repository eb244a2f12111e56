"""Our UKF against filterpy's UKF, step by step, on the L-R paper's Case I."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.evaluate.montecarlo import LRScenario
from arrayproc.geo.angles import wrap_pi
from arrayproc.track.filters import UKF
from arrayproc.track.init import init_from_bearing
from arrayproc.track.models.bearing import Bearing, bearing_residual, bearing_sigma_mean
from arrayproc.track.models.motion import constant_turn, constant_velocity
from arrayproc.track.state import Context

filterpy = pytest.importorskip("filterpy")
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter  # noqa: E402


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


@pytest.mark.parametrize("case", [1, 2])
@pytest.mark.parametrize("alpha,beta,kappa", [(1.0, 0.0, None), (0.5, 2.0, 0.0)])
def test_ukf_matches_filterpy_step_by_step(case, alpha, beta, kappa):
    scn = LRScenario(case=case)
    g = scn.geometry()
    model = constant_velocity() if case == 1 else constant_turn()
    n = model.ndim
    k_ = 3.0 - n if kappa is None else kappa
    ukf = UKF(alpha=alpha, beta=beta, kappa=kappa)
    meas = Bearing(sigma_deg=scn.sigma_deg)
    rng = np.random.default_rng(7)
    theta = np.arctan2(g["rel"][:, 0], g["rel"][:, 1])
    z = wrap_pi(theta + rng.standard_normal(theta.size) * math.radians(scn.sigma_deg))
    x0, P0 = init_from_bearing(math.degrees(z[0]), g["own"][0], scn.prior, n)
    ours = ukf.initialize(x0, P0)

    pts = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=k_)

    def fx(x, dt, o0, o1):
        return model.function(x, dt, Context(o1, o0))

    def hx(x):
        return np.array([math.atan2(x[0], x[1])])

    fp = UnscentedKalmanFilter(dim_x=n, dim_z=1, dt=scn.dt, hx=hx, fx=fx, points=pts,
                               z_mean_fn=bearing_sigma_mean, residual_z=bearing_residual)
    fp.x = x0.copy()
    fp.P = P0.copy()
    fp.R = np.array([[math.radians(scn.sigma_deg) ** 2]])
    fp.Q = model.covariance(scn.dt)
    for k in range(1, theta.size):
        ctx = Context(g["own"][k], g["own"][k - 1])
        ours = ukf.predict(ours, model, scn.dt, ctx)
        fp.predict(o0=g["own"][k - 1], o1=g["own"][k])
        assert _rel(ours.x, fp.x) < 1e-9
        assert _rel(ours.P, fp.P) < 1e-9
        ours, _ = ukf.update(ours, z[k], meas, ctx)
        fp.update(np.array([z[k]]))
        assert _rel(ours.x, fp.x) < 1e-9, k
        assert _rel(ours.P, fp.P) < 1e-9, k
        # elementwise on the diagonal (variances span 10 decades)
        np.testing.assert_allclose(np.diag(ours.P), np.diag(fp.P), rtol=1e-9)
        for blk in (slice(0, 2), slice(2, 4), slice(4, n)):
            if fp.x[blk].size:
                np.testing.assert_allclose(ours.x[blk], fp.x[blk], rtol=1e-9,
                                           atol=1e-9 * np.abs(fp.x[blk]).max())
