"""Gating, GNN and JPDA against brute-force enumeration and closed forms."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from arrayproc.errors import ConfigError
from arrayproc.track.manage.associate import gate_threshold, gnn, jpda, mahalanobis


@pytest.mark.parametrize("p,k", [(0.99, 1), (0.999, 2), (0.9, 3)])
def test_gate_is_chi2_quantile(p, k):
    assert gate_threshold(p, k) == pytest.approx(chi2.ppf(p, k), rel=1e-12)
    with pytest.raises(ConfigError):
        gate_threshold(1.0, k)


def test_mahalanobis_matches_inverse():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((3, 4, 2, 2))
    S = A @ A.transpose(0, 1, 3, 2) + np.eye(2)
    nu = rng.standard_normal((3, 4, 2))
    d2, ld = mahalanobis(nu, S)
    ref = np.einsum("nmi,nmij,nmj->nm", nu, np.linalg.inv(S), nu)
    np.testing.assert_allclose(d2, ref, rtol=1e-12)
    np.testing.assert_allclose(ld, np.log(np.linalg.det(2 * np.pi * S)), rtol=1e-12)


def _brute_gnn(cost, ok):
    """Largest set of gated pairs, then the smallest cost, over every partial injection."""
    n, m = cost.shape
    best_pairs: list = []
    best_key = [(0, math.inf)]

    def rec(i, used, acc, pairs):
        nonlocal best_pairs
        if i == n:
            key = (-len(pairs), acc)
            if key < best_key[0]:
                best_key[0] = key
                best_pairs = list(pairs)
            return
        rec(i + 1, used, acc, pairs)
        for j in range(m):
            if ok[i, j] and j not in used:
                rec(i + 1, used | {j}, acc + cost[i, j], pairs + [(i, j)])
    rec(0, frozenset(), 0.0, [])
    return best_pairs


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 4), st.integers(0, 5), st.integers(0, 10_000))
def test_gnn_equals_brute_force(n, m, seed):
    rng = np.random.default_rng(seed)
    d2 = rng.uniform(0, 12, (n, m))
    ld = rng.uniform(-1, 1, (n, m))
    gate = 9.0
    pairs = gnn(d2, ld, gate)
    ref = _brute_gnn(d2 + ld, d2 <= gate)
    # same number of pairs (maximal) and same total cost
    assert len(pairs) == len(ref)
    c = sum(d2[i, j] + ld[i, j] for i, j in pairs)
    cr = sum(d2[i, j] + ld[i, j] for i, j in ref)
    assert c == pytest.approx(cr, abs=1e-9)
    assert len({i for i, _ in pairs}) == len(pairs) == len({j for _, j in pairs})


def _brute_jpda(d2, ld, gate, pd, pg, lam):
    n, m = d2.shape
    beta = np.zeros((n, m + 1))
    tot = 0.0
    for ev in itertools.product(range(m + 1), repeat=n):
        js = [j for j in ev if j > 0]
        if len(js) != len(set(js)):
            continue
        if any(j > 0 and d2[i, j - 1] > gate for i, j in enumerate(ev)):
            continue
        w = 1.0
        for i, j in enumerate(ev):
            w *= (1 - pd * pg) if j == 0 else \
                pd * math.exp(-0.5 * (d2[i, j - 1] + ld[i, j - 1])) / lam
        tot += w
        for i, j in enumerate(ev):
            beta[i, j] += w
    return beta / tot


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 3), st.integers(0, 4), st.integers(0, 10_000))
def test_jpda_equals_brute_force(n, m, seed):
    rng = np.random.default_rng(seed)
    d2 = rng.uniform(0, 12, (n, m))
    ld = rng.uniform(-1, 2, (n, m))
    b = jpda(d2, ld, 9.0, 0.9, 0.99, 0.05)
    np.testing.assert_allclose(b, _brute_jpda(d2, ld, 9.0, 0.9, 0.99, 0.05), atol=1e-12)
    np.testing.assert_allclose(b.sum(1), 1.0)


def test_pda_single_track_closed_form():
    """One track: β_j = e_j / (b + Σ e), β_0 = b / (b + Σ e), e_j = P_D g_j / λ,
    b = 1 − P_D P_G (BWT eqs. 3.4.3-8/9 in the parametric form)."""
    d2 = np.array([[1.0, 4.0, 20.0]])
    ld = np.full((1, 3), 1.5)
    pd, pg, lam = 0.8, 0.99, 0.02
    b = jpda(d2, ld, 9.21, pd, pg, lam)
    e = pd * np.exp(-0.5 * (d2[0, :2] + 1.5)) / lam
    den = (1 - pd * pg) + e.sum()
    np.testing.assert_allclose(b[0], [(1 - pd * pg) / den, e[0] / den, e[1] / den, 0.0])
