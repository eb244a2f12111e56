"""Fixtures of the plot tests: one short simulated towed run shared by the report and
display tests."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def towed_run(tmp_path_factory):
    """Products of SIM_SECONDS of the bundled towed scenario (its recording has the truth)."""
    from tests.plots.report_data import passive_run
    return passive_run(tmp_path_factory.mktemp("towed"))
