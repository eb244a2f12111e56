"""OSPA and GOSPA against their definitions (Schuhmacher et al. 2008 eq. (3); Rahmathullah et
al. 2017 eq. (1)) and the track scores on a constructed case."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.errors import ConfigError
from arrayproc.evaluate.metrics import gospa, ospa, over_time, track_scores

pts = st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=0, max_size=4)


def _brute_ospa(X, Y, c, p):
    m, n = len(X), len(Y)
    if m > n:
        X, Y, m, n = Y, X, n, m
    if n == 0:
        return 0.0
    best = min(sum(min(c, math.dist(X[i], Y[pi[i]])) ** p for i in range(m))
               for pi in itertools.permutations(range(n), m)) if m else 0.0
    return ((best + c ** p * (n - m)) / n) ** (1 / p)


def _brute_gospa(X, Y, c, p):
    """α = 2 via explicit assignment sets γ (Proposition 1)."""
    m, n = len(X), len(Y)
    best = math.inf
    for k in range(min(m, n) + 1):
        for xs in itertools.combinations(range(m), k):
            for ys in itertools.permutations(range(n), k):
                loc = sum(math.dist(X[i], Y[j]) ** p for i, j in zip(xs, ys))
                if any(math.dist(X[i], Y[j]) >= c for i, j in zip(xs, ys)):
                    continue
                best = min(best, loc + c ** p / 2 * (m + n - 2 * k))
    return best ** (1 / p)


@settings(max_examples=60, deadline=None)
@given(pts, pts, st.floats(1, 40), st.sampled_from([1.0, 2.0, 3.0]))
def test_ospa_and_gospa_equal_definitions(X, Y, c, p):
    assert ospa(np.array(X).reshape(-1, 2), np.array(Y).reshape(-1, 2), c, p) == \
        pytest.approx(_brute_ospa(X, Y, c, p), rel=1e-9, abs=1e-9)
    g = gospa(np.array(X).reshape(-1, 2), np.array(Y).reshape(-1, 2), c, p)
    assert g.distance == pytest.approx(_brute_gospa(X, Y, c, p), rel=1e-9, abs=1e-9)
    assert g.distance ** p == pytest.approx(g.localisation + g.missed + g.false, rel=1e-9,
                                            abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(pts, pts, pts)
def test_metric_axioms(X, Y, Z):
    a, b, z = (np.array(v).reshape(-1, 2) for v in (X, Y, Z))
    for f in (lambda u, v: ospa(u, v, 10.0, 2.0), lambda u, v: gospa(u, v, 10.0, 2.0).distance):
        assert f(a, b) == pytest.approx(f(b, a))
        assert f(a, a) == pytest.approx(0.0, abs=1e-12)
        assert f(a, z) <= f(a, b) + f(b, z) + 1e-9
    assert 0.0 <= ospa(a, b, 10.0, 2.0) <= 10.0


def test_closed_forms():
    X = np.array([[0.0, 0.0], [100.0, 0.0]])
    # one exact, one missed: GOSPA² = c²/2, OSPA² = c²/2
    g = gospa(X, X[:1], c=10.0, p=2.0)
    assert g.distance == pytest.approx(math.sqrt(50.0)) and g.n_missed == 1 and g.n_false == 0
    assert ospa(X, X[:1], 10.0, 2.0) == pytest.approx(math.sqrt(50.0))
    # a 3 m error: localisation 9
    g = gospa(X, X + [3.0, 0.0], c=10.0, p=2.0)
    assert g.localisation == pytest.approx(18.0) and g.distance == pytest.approx(math.sqrt(18))
    with pytest.raises(ConfigError):
        gospa(X, X, c=0.0)
    with pytest.raises(ConfigError):
        ospa(X, X, c=1.0, p=0.5)
    curves = over_time(np.array([[[0.0, 0.0], [np.nan, np.nan]]]), [np.zeros((1, 2)),
                                                                     np.zeros((1, 2))], 10.0)
    assert curves["gospa"][0] == 0.0
    assert curves["gospa"][1] == pytest.approx(math.sqrt(50.0))  # one false point


def test_track_scores_break_purity_false():
    T = 10
    truth = np.zeros((2, T, 1))
    truth[0, :, 0] = 10.0
    truth[1, :, 0] = 50.0
    det = np.ones((2, T), bool)
    # source 0: track 1 for t<6, track 2 after (one break); source 1: track 3 always;
    # track 4 is false (far from any source)
    tix = {1: np.arange(6), 2: np.arange(6, T), 3: np.arange(T), 4: np.arange(T)}
    tv = {1: np.full((6, 1), 10.5), 2: np.full((4, 1), 9.5), 3: np.full((T, 1), 50.2),
          4: np.full((T, 1), 90.0)}
    s = track_scores(truth, det, tix, tv, gate=3.0)
    np.testing.assert_allclose(s.held, [0.6, 1.0])
    assert list(s.principal) == [1, 3]
    assert list(s.breaks) == [1, 0]
    assert s.false_tracks == [4]
    assert s.purity[1] == 1.0 and s.purity[4] == 0.0
