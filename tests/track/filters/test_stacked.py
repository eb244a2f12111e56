"""One filter, one track or many: the EKF's stacked form (batched NumPy over X (n, d),
P (n, d, d)) against its one-track form (numba kernels) on the same models."""

from __future__ import annotations

import numpy as np

from arrayproc.track.filters import make_filter
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.state import Context


def test_stacked_ekf_equals_one_track_ekf():
    """Static observer at the origin (relative = world state): predict and update of five
    stacked tracks equal five one-track runs to rounding (rtol 1e-12: the same equations,
    summed in another order by BLAS)."""
    rng = np.random.default_rng(0)
    ekf = make_filter("ekf")
    motion = ConstantVelocity(q1=1e-3)
    meas = Bearing(sigma_deg=1.0)
    X = np.c_[rng.uniform(-5000, 5000, (5, 2)), rng.uniform(-3, 3, (5, 2))]
    A = rng.standard_normal((5, 4, 4))
    P = A @ A.transpose(0, 2, 1) + np.diag([1e4, 1e4, 1.0, 1.0])
    ctx = Context(np.zeros(4))
    Z = rng.uniform(-np.pi, np.pi, (5, 1))
    Xp, Pp = ekf.predict_stacked(X, P, motion, np.full(5, 10.0))
    Xu, Pu, ll = ekf.update_stacked(Xp, Pp, Z, np.arange(5), meas, ctx)
    for i in range(5):
        st = ekf.predict(ekf.initialize(X[i], P[i]), motion, 10.0, ctx)
        np.testing.assert_allclose(Xp[i], st.x, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(Pp[i], st.P, rtol=1e-12, atol=1e-9)
        up, l1 = ekf.update(st, Z[i], meas, ctx)
        np.testing.assert_allclose(Xu[i], up.x, rtol=1e-10, atol=1e-8)
        np.testing.assert_allclose(Pu[i], up.P, rtol=1e-10, atol=1e-8)
        assert abs(ll[i] - l1) <= 1e-10 * max(1.0, abs(l1))
