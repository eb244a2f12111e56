"""``arrayproc tma TRACKS.h5``: one batch TMA solution per confirmed track, over that track's
own rows, on a measurement-level two-target scenario with known truth
(:mod:`tests.track.batch._two_targets`): each solution within 3σ of its CRLB, bearings +
frequency bound smaller than bearings-only, NEES over seeds, CLI errors, determinism."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest
from scipy.stats import chi2

from arrayproc.app.cli import main
from arrayproc.data import data_path
from arrayproc.io.products import read_products
from arrayproc.io.recording import Recording
from arrayproc.track.batch.per_track import read_track_rows, run_tracks_tma
from arrayproc.track.batch.run import load_tma_config
from tests.track.batch import _two_targets as T

TRACKS_TOML = f"{data_path('tma')}/tracks.toml"
#: quicker global search for the repeated runs (the polish is the same)
QUICK = "popsize = 8\nmaxiter = 80\n"


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return T.build(tmp_path_factory.mktemp("two"), seed=0)


def _cfg(tmp_path, text, name="t.toml"):
    p = tmp_path / name
    p.write_text("[tma]\n" + text)
    return str(p)


def _rows(path):
    return read_products(str(path))["tma"]


def test_each_track_holds_its_own_rows(scene):
    """The tracker holds each source in one confirmed track; per-track TMA reads exactly the
    rows each track used (one source's rows, in time order)."""
    tr = read_track_rows(str(scene["tracks"]), load_tma_config(TRACKS_TOML))
    assert len(tr.tracks) == 2
    got = sorted(T.source_of(scene["tracks"], scene["rows"], k) for k in tr.tracks)
    assert got == [0, 1]
    for m in tr.tracks.values():
        src = scene["rows"]["source"][m["rows"]]
        assert np.all(src == src[0]) and m["rows"].size >= 120
        assert np.all(np.diff(m["time"]) > 0) and m["freq"] is None


def test_cli_per_track_within_3_sigma_and_frequency_shrinks_the_bound(scene, tmp_path, capsys):
    """`tma TRACKS.h5 -c tracks`: one preferred solution per track (bearings alone, then with
    the tracks' line frequencies, method auto), each within the 99.7 % NEES gate of its CRLB
    and within 25 % of its range; f0 within 3σ; the bearings + frequency position bound is
    smaller than the bearings-only one for both tracks."""
    area = {}
    for key, want in (("tracks", b"bearings"), ("tracks_f", b"bearings_frequency")):
        out = tmp_path / f"{key}_tma.h5"
        assert main(["tma", str(scene[key]), "-c", "tracks", "-o", str(out), "-q"]) == 0
        g = _rows(out)
        pref = np.flatnonzero(g["preferred"] == 1)
        assert sorted(g["track_id"][pref]) == sorted(set(g["track_id"]))
        assert len(pref) == 2
        for i in pref:
            src = T.source_of(scene["tracks"], scene["rows"], int(g["track_id"][i]))
            t0 = float(g["t0"][i])
            truth = T.truth_at(src, t0)
            assert g["method"][i] == want
            st = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
            d2 = T.nees(st, g["crlb"][i], src, t0)
            assert d2 < chi2.ppf(0.997, 4), (key, src, d2)
            with Recording(str(scene["rec"])) as rec:
                own = rec.nav.at(t0)[0][0]
            r_true = np.hypot(*(truth[:2] - own))
            assert abs(np.hypot(*(st[:2] - own)) / r_true - 1) < 0.25
            assert np.isfinite(g["range_sigma_m"][i]) and g["fim_cond"][i] > 1
            if want == b"bearings_frequency":
                assert abs(g["f0_hz"][i] - truth[4]) < 3 * g["sigma_f0_hz"][i]
            else:
                assert np.isnan(g["f0_hz"][i])
            area[(key, src)] = np.sqrt(np.linalg.det(g["crlb"][i][:2, :2]))
    for src in (0, 1):
        assert area[("tracks_f", src)] < 0.7 * area[("tracks", src)], area


def test_deterministic(scene, tmp_path):
    """The same tracks and configuration give the same bytes of every column."""
    cfg = _cfg(tmp_path, 'method = "auto"\n' + QUICK)
    outs = []
    for k in range(2):
        out = tmp_path / f"d{k}.h5"
        run_tracks_tma(str(scene["tracks_f"]), cfg, str(out))
        outs.append(_rows(out))
    for col in ("x", "y", "vx", "vy", "crlb", "cov", "f0_hz", "track_id", "cost"):
        assert np.array_equal(outs[0][col], outs[1][col], equal_nan=True), col


def _nees_over(seeds, tmp_path, text):
    """Mean NEES of each track's preferred solution over the seeds, by state dimension (4:
    bearings, 5: bearings + frequency), and the number of solutions."""
    cfg = _cfg(tmp_path, text)
    out: dict[int, list[float]] = {4: [], 5: []}
    for seed in seeds:
        sc = T.build(tmp_path / f"s{seed}", seed)
        for key in ("tracks", "tracks_f"):
            sols = run_tracks_tma(str(sc[key]), cfg, str(tmp_path / f"s{seed}/tma_{key}.h5"))
            mirrors = {id(s.mirror) for _, s in sols}
            for tid, s in sols:
                if id(s) not in mirrors:
                    src = T.source_of(sc["tracks"], sc["rows"], tid)
                    out[s.state.size].append(T.nees(s.state, s.crlb, src, s.t0))
    return {k: float(np.mean(v)) for k, v in out.items()}, {k: len(v) for k, v in out.items()}


def test_nees_small_set(tmp_path):
    """Mean NEES over 3 seeds × 2 tracks (6 solutions per method) within [0.4, 2.5] × the
    state dimension (4 bearings, 5 bearings + frequency); the slow test runs 50 seeds."""
    m, n = _nees_over(range(1, 4), tmp_path, 'method = "auto"\n' + QUICK)
    assert n == {4: 6, 5: 6}
    assert 0.4 * 4 < m[4] < 2.5 * 4, m
    assert 0.4 * 5 < m[5] < 2.5 * 5, m


@pytest.mark.slow
def test_nees_fifty_seeds(tmp_path):
    """Mean NEES over 50 seeds × 2 tracks within [0.5, 2] × the state dimension."""
    m, n = _nees_over(range(100, 150), tmp_path, 'method = "auto"\n')
    print(f"mean NEES over {n} solutions: {m}")
    assert n == {4: 100, 5: 100}
    assert 0.5 * 4 < m[4] < 2 * 4, m
    assert 0.5 * 5 < m[5] < 2 * 5, m


def _check_error(args, capsys, match, out):
    rc = main([str(a) for a in args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and err[0].startswith("arrayproc: error:"), err
    assert match in err[0], err[0]
    assert not out.exists()


def test_cli_errors(scene, tmp_path, capsys):
    """No confirmed track; bearings_frequency on tracks without frequencies; delays where
    the products carry none: one line, exit 2, no output."""
    out = tmp_path / "out" / "tma.h5"
    out.parent.mkdir()
    none = tmp_path / "none.h5"
    shutil.copy(scene["tracks"], none)
    with h5py.File(none, "a") as f:
        f["tracks/status"][...] = 0
    _check_error(["tma", none, "-c", "tracks", "-o", out], capsys, "no confirmed track", out)
    bf = _cfg(tmp_path, 'method = "bearings_frequency"\n', "bf.toml")
    _check_error(["tma", scene["tracks"], "-c", bf, "-o", out], capsys,
                 "no confirmed track", out)
    dl = _cfg(tmp_path, 'method = "delays"\n', "dl.toml")
    _check_error(["tma", scene["tracks"], "-c", dl, "-o", out], capsys, "delays group", out)


def test_plot_per_track(scene, tmp_path):
    """`plot TMA.h5` of a per-track group: the plan view with each track's solution and its
    CRLB ellipses, and the measured against fitted cone angles."""
    cfg = _cfg(tmp_path, 'method = "auto"\n' + QUICK)
    out = tmp_path / "tma.h5"
    run_tracks_tma(str(scene["tracks"]), cfg, str(out))
    png = tmp_path / "tma.png"
    assert main(["plot", str(out), "-o", str(png), "-q"]) == 0
    assert png.stat().st_size > 20_000


def test_same_as_the_products_path_on_the_endfire_turn(tmp_path):
    """One source crossing end-fire in the turn: the per-track solution over the track's rows
    equals the products path's over the products' rows (bearings: the bearings group;
    bearings + frequency: the lines group against the tracks' per-point measurements)."""
    from arrayproc.track.batch import scenarios as S
    from arrayproc.track.batch.run import run_tma
    from arrayproc.track.batch.synthetic import (
        Source,
        with_measurements,
        write_line_array_scenario,
    )
    from arrayproc.track.runner import run_tracker

    nav, _ = S.endfire_turn_track(n=626, dt=1.0)
    _, prod, rows = write_line_array_scenario(
        str(tmp_path), nav, {"a": Source(S.ENDFIRE_SOURCE, 300.0)}, np.arange(0.0, 626.0, 5.0),
        T.SIG_DEG, T.SIG_HZ, seed=3, lines=True)
    tracks, tracks_f = tmp_path / "tracks.h5", tmp_path / "tracks_f.h5"
    run_tracker(prod, f"{data_path('trackers')}/multi_target.toml", str(tracks))
    with_measurements(tracks, tracks_f, prod, rows["freq_hz"])
    quick = "popsize = 6\nmaxiter = 50\nmin_rows = 20\n"
    for method, trk in (("bearings", tracks), ("bearings_frequency", tracks_f)):
        cfg = _cfg(tmp_path, f'method = "{method}"\n' + quick, f"{method}.toml")
        a = run_tma(prod, cfg, str(tmp_path / f"p_{method}.h5"))[0]
        (tid, b), *_ = run_tracks_tma(str(trk), cfg, str(tmp_path / f"t_{method}.h5"))
        assert b.n_used == a.n_used == 126 - a.n_rejected
        np.testing.assert_allclose(b.state, a.state, rtol=1e-9)
        np.testing.assert_allclose(b.crlb, a.crlb, rtol=1e-9)
        e = a.state - T.TRUTH[0][:a.state.size]
        assert e @ np.linalg.solve(a.crlb, e) < chi2.ppf(0.997, a.state.size)


def test_tonal_labels_split_two_tonals_and_keep_one_doppler_sweep():
    """A slot that held 176 Hz and then 528 Hz is two tonals; one tonal's Doppler sweep over
    3 Hz in dense rows stays one; rows off (NaN, broadband) are −1."""
    from arrayproc.track.batch.per_track import tonal_labels
    sweep = np.linspace(175.5, 178.5, 60)
    f = np.r_[sweep, np.full(5, np.nan), np.linspace(528.0, 529.0, 30)]
    on = np.isfinite(f)
    lab = tonal_labels(f, on)
    assert np.all(lab[~on] == -1)
    assert np.unique(lab[:60]).size == 1 and np.unique(lab[65:]).size == 1
    assert lab[0] != lab[-1]
    # the tracks' rows pick the tonal with the most rows, not the slot with the most rows
    assert np.bincount(lab[on]).argmax() == lab[0]
