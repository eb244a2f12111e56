"""Plain-numpy reference of the RPF (SPL paper section 4) driven by the same random stream as
the numba kernels (SplitMix64, documented draw order in arrayproc.track.filters._pf_kernels).

Written independently of the kernels: vectorised numpy over particles, a Python replica of the
generator, textbook forms of each equation (two-pass covariance, np.cumsum/searchsorted
resampling, np.linalg.cholesky).
"""

from __future__ import annotations

import math

import numpy as np

M64 = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15


def splitmix64_block(seed: int, start: int, n: int) -> np.ndarray:
    """Outputs start+1 … start+n of SplitMix64 seeded with ``seed`` (vectorised, uint64)."""
    with np.errstate(over="ignore"):
        k = np.arange(start + 1, start + n + 1, dtype=np.uint64)
        z = np.uint64(seed) + k * np.uint64(GOLDEN)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


class Stream:
    """Python replica of the kernels' random stream."""

    def __init__(self, seed: int) -> None:
        self.seed = int(seed)
        self.count = 0
        self._buf = np.empty(0)
        self._pos = 0

    def uniforms(self, n: int) -> np.ndarray:
        z = splitmix64_block(self.seed, self.count, n)
        self.count += n
        return ((z >> np.uint64(11)).astype(np.float64) + 1.0) * 2.0**-53

    def uniform(self) -> float:
        return float(self.uniforms(1)[0])

    def disc(self) -> tuple[float, float, float]:
        while True:
            u, v = 2.0 * self.uniforms(2) - 1.0
            q = u * u + v * v
            if 0.0 < q < 1.0:
                return float(u), float(v), float(q)

    def normal_pair(self) -> tuple[float, float]:
        u, v, q = self.disc()
        f = math.sqrt(-2.0 * math.log(q) / q)
        return u * f, v * f

    def normal_pairs(self, n: int) -> np.ndarray:
        return np.array([self.normal_pair() for _ in range(n)]).reshape(n, 2)

    def epanechnikov(self, n: int) -> np.ndarray:
        out = np.empty((n, 4))
        for i in range(n):
            x1, x2, q1 = self.disc()
            x3, x4, q2 = self.disc()
            t = math.sqrt((1.0 - q1) / q2)
            r = math.sqrt(float(np.median(self.uniforms(3))))
            out[i] = np.array([x1, x2, x3 * t, x4 * t]) * r
        return out


def prior(st: Stream, n, obs0, theta0, sig_theta, pr):
    uniform = len(pr) > 7 and pr[7] != 0
    z = np.empty((n, 5))
    for i in range(n):  # per particle: two normal pairs, then the course's uniform if used
        z[i, :4] = np.concatenate([st.normal_pair(), st.normal_pair()])
        z[i, 4] = st.uniform() if uniform else 0.0
    r = np.maximum(pr[0] + pr[1] * z[:, 0], pr[6])
    b = theta0 + sig_theta * z[:, 1]
    s = pr[2] + pr[3] * z[:, 2]
    if uniform:  # same mean and standard deviation as the normal course prior
        c = theta0 + pr[4] + math.sqrt(3.0) * pr[5] * (2.0 * z[:, 4] - 1.0)
    else:
        c = theta0 + pr[4] + pr[5] * z[:, 3]
    return np.stack([obs0[0] + r * np.sin(b), obs0[1] + r * np.cos(b), s * np.sin(c),
                     s * np.cos(c)], axis=1)


def propagate(st: Stream, x, dt, sigma_a):
    a = sigma_a * st.normal_pairs(x.shape[0])
    f = np.array([[1, 0, dt, 0], [0, 1, 0, dt], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    g = np.array([[dt * dt / 2, 0], [0, dt * dt / 2], [dt, 0], [0, dt]])
    return x @ f.T + a @ g.T


def loglik(x, obs, theta, sig_theta, level, sig_level, use_theta, use_level, sl_par, tl_prof):
    d = x[:, :2] - obs
    out = np.zeros(x.shape[0])
    if use_theta:
        e = np.mod(theta - np.arctan2(d[:, 0], d[:, 1]) + np.pi, 2 * np.pi) - np.pi
        out -= e**2 / (2 * sig_theta**2)
    if use_level:
        r0, dr, tl = tl_prof
        grid = r0 + dr * np.arange(tl.size)
        v = np.maximum(np.hypot(x[:, 2], x[:, 3]), 1e-6)
        sl = sl_par[0] + sl_par[1] * np.log10(v / sl_par[2])
        r = np.hypot(d[:, 0], d[:, 1])
        tlr = np.interp(r, grid, tl) + 10 * np.log10(np.maximum(r, grid[-1]) / grid[-1])
        out -= (level - (sl - tlr)) ** 2 / (2 * sig_level**2)
    return out


def mean_cov(x, w):
    w = w / w.sum()
    m = w @ x
    d = x - m
    return m, (w[:, None] * d).T @ d


def resample(st: Stream, w, method: str):
    n = w.size
    cum = np.cumsum(w / w.sum())
    if method == "systematic":
        u = st.uniform()
        p = (np.arange(n) + 1.0 - u) / n
    else:
        e = -np.log(st.uniforms(n + 1))
        p = np.cumsum(e)[:n] / e.sum()
    return np.minimum(np.searchsorted(cum, p, side="left"), n - 1)


def bandwidth(n, nx=4):
    c = math.pi ** (nx / 2) / math.gamma(nx / 2 + 1)        # unit-ball volume
    a = (8.0 / c * (nx + 4) * (2 * math.sqrt(math.pi)) ** nx) ** (1.0 / (nx + 4))
    return a * n ** (-1.0 / (nx + 4))


def rpf(theta, level, use_level, times, obs, seed, n, n_thr, sigma_a, sig_theta, sig_level,
        pr, sl_par, tl_prof, method="systematic"):
    """Whole RPF run (reference of ``kernels.pf.rpf_run`` with use_theta0 = False)."""
    st = Stream(seed)
    x = prior(st, n, obs[0], theta[0], sig_theta, pr)
    w = np.full(n, 1.0 / n)
    h = bandwidth(n)
    est = np.empty((times.size, 4))
    cov = np.empty((times.size, 4, 4))
    flags = np.zeros(times.size, bool)
    for k in range(times.size):
        if k > 0:
            x = propagate(st, x, times[k] - times[k - 1], sigma_a)
        ut = k > 0
        neff = float(n)
        if ut or use_level:
            ll = loglik(x, obs[k], theta[k], sig_theta, level[k], sig_level, ut, use_level,
                        sl_par, tl_prof)
            v_max = pr[8] if len(pr) > 8 else 0.0
            fast = np.hypot(x[:, 2], x[:, 3]) > v_max
            if v_max > 0 and np.any(~fast & (w > 0)):
                ll[fast] = -np.inf
            w = w * np.exp(ll - ll.max())
            w = w / w.sum()
            neff = 1.0 / np.sum(w**2)
        if neff < n_thr * n:
            _, p = mean_cov(x, w)
            d = np.linalg.cholesky(p + 1e-10 * np.diag(np.diag(p)))
            idx = resample(st, w, method)
            eps = st.epanechnikov(n)
            x = x[idx] + h * eps @ d.T
            w = np.full(n, 1.0 / n)
            flags[k] = True
        est[k], cov[k] = mean_cov(x, w)
    return est, cov, flags
