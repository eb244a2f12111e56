"""End to end: simulated towed array → passive chain → bearings and LOFAR against truth.

Scenario: :mod:`arrayproc.evaluate.scenarios.thesis_passive` (32 hydrophones towed at 5 kn, two
tonal and one broadband moving source at −10 dB per hydrophone). Checks: bearings rows follow
the truth cone angles within 0.5° RMS (broadband rows for the broadband source, line rows for
the tonal sources); the LOFAR of the beam nearest each tonal source shows its line within one
bin of the Doppler-shifted truth frequency.
"""

from __future__ import annotations

import pytest

from arrayproc.evaluate.scenarios.thesis_passive import SOURCES, run_e2e
from arrayproc.evaluate.scenarios.thesis_passive import score_e2e as evaluate


def check(res: dict) -> None:
    for name, *_, tonal in SOURCES:
        r = res[name]
        assert r["detected"] >= 0.9, (name, r)
        assert r["rms_deg"] < 0.5, (name, r)
        if tonal is not None:
            assert r["lofar_within_one_bin"] == 1.0, (name, r)
    assert res["rms_all_deg"] < 0.5, res


def test_towed_passive_e2e_short(tmp_path):
    rec, g = run_e2e(tmp_path, 50.0)
    res = evaluate(rec, g)
    print(res)
    check(res)


@pytest.mark.slow
def test_towed_passive_e2e_full(tmp_path):
    rec, g = run_e2e(tmp_path, 180.0)
    res = evaluate(rec, g)
    print(res)
    check(res)
