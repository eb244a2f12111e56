"""The passive target picture end to end (``simulate → process → track → tma`` with the
shipped files, :mod:`arrayproc.evaluate.target_picture`): the default suite runs the reduced
scenario (4 min, one source, a turn) and checks the scores' structure and that they are
those of a working chain; the slow suite runs the five scenarios against the acceptance
targets (docs/validation/target_picture.md)."""

from __future__ import annotations

import math

import pytest

from arrayproc.evaluate.scenarios.target_picture import SCENARIOS, SHORT_TURN
from arrayproc.evaluate.target_picture import (
    SIGMA_MAX,
    evaluate,
    markdown_table,
    reseeded,
    run_scenario,
    score_scenario,
    summary,
)

#: measured (docs/results/target_picture.json): the acceptance targets not yet reached
XFAIL_HELD = ("6 of 11 eligible sources held < 80 %: towship_masking abeam 48 %, bow 73 %; "
              "endfire_turn target 75 %; long_four coaster 46 %, fisher 67 %, tanker 52 % "
              "(sources inside the tow ship's beam; tonals under the 12 dB line threshold)")
XFAIL_SIGMA = ("4 of 11 eligible sources beyond 3σ: towship_masking abeam 114.7σ, endfire_turn "
               "target 4.53σ, long_four fisher 8.95σ, tanker 50.1σ")
XFAIL_RANGE = ("5 of 11 eligible sources beyond 25 %: towship_masking abeam −97 %, quarter −35 %, "
               "endfire_turn target +28 %, long_four fisher +208 %, tanker −68 %")


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    d = tmp_path_factory.mktemp("tp")
    run = run_scenario("short_turn", str(d), text=SHORT_TURN)
    return run, score_scenario("short_turn", run)


def test_reduced_scenario_end_to_end(short):
    run, res = short
    assert set(run["paths"]) >= {"scenario", "rec", "prod", "tracks", "tma"}
    assert run["paths"]["tma"] is not None
    assert res["scenario"] == "short_turn" and res["window_s"][1] > 200.0
    (s,) = res["sources"]  # the tow ship is not a scored contact
    assert s["source"] == "contact"
    assert s["eligible"] and s["tonal_db"] > 12.0     # its lines are over the lines threshold
    assert s["lines"] > 100 and s["line_cone_deg"] < 2.0
    assert s["held"] >= 0.8 and s["track"] >= 0
    assert len(res["false_tracks"]) <= 1
    t = s["tma"]
    assert t is not None and t["track_id"] == s["track"]
    assert t["method"] in ("bearings", "bearings_frequency")
    assert math.isfinite(t["sigma"]) and 0.0 <= t["sigma"] <= SIGMA_MAX and t["d2"] > 0.0
    assert abs(t["range_err_pct"]) < 100.0 and 0.0 < t["range_sigma_pct"] < 100.0
    tab = markdown_table([res])
    assert "| short_turn | contact |" in tab and tab.count("\n") == 3
    sm = summary([res])
    assert sm["sources"] == 1 and sm["eligible"] == 1


def test_reseeded_changes_the_seed_line_alone():
    """Another noise draw of a scenario: its top-level seed moves by the offset, every other
    line stays (geometry, levels, the sources' own keys)."""
    for name, text in SCENARIOS.items():
        new = reseeded(text, 200)
        old_lines, new_lines = text.splitlines(), new.splitlines()
        diff = [(a, b) for a, b in zip(old_lines, new_lines, strict=True) if a != b]
        assert len(diff) == 1, name
        (a, b), = diff
        assert int(b.split("=")[1]) == int(a.split("=")[1]) + 200
    assert reseeded(SHORT_TURN, 0) == SHORT_TURN
    with pytest.raises(ValueError, match="seed"):
        reseeded("[scenario]\nduration = 10.0\n", 100)


def _missed(res, key):
    return {f"{r['scenario']}/{s['source']}": (s["held"] if key == "held" else
                                                (s["tma"] or {}).get(
                                                    "sigma" if key == "sigma" else
                                                    "range_err_pct"))
            for r in res for s in r["sources"] if s["eligible"] and not s["pass"][key]}


@pytest.fixture(scope="module")
def five(tmp_path_factory):
    return evaluate(list(SCENARIOS), str(tmp_path_factory.mktemp("tp5")), jobs=2)


@pytest.mark.slow
def test_five_scenarios_every_eligible_source_has_a_track(five):
    assert all(s["track"] >= 0 and s["held"] > 0 for r in five for s in r["sources"]
               if s["eligible"])


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=XFAIL_HELD)
def test_five_scenarios_every_eligible_source_held_80pct(five):
    assert not _missed(five, "held")


@pytest.mark.slow
def test_five_scenarios_at_most_one_false_track(five):
    assert max(len(r["false_tracks"]) for r in five) <= 1, \
        {r["scenario"]: r["false_tracks"] for r in five}


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=XFAIL_SIGMA)
def test_five_scenarios_tma_within_3_sigma(five):
    assert not _missed(five, "sigma")


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=XFAIL_RANGE)
def test_five_scenarios_tma_range_within_25pct(five):
    assert not _missed(five, "range")
