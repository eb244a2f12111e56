"""Beamformer set-up warnings (stages/beamform/checks.py): a line off body x under cone-angle
beams, and a band above the spatial-aliasing limit c/(2d)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from arrayproc.io.geometry import line_array
from arrayproc.stages.beamform.checks import (
    typical_spacing,
    warn_cone_geometry,
    warn_spatial_aliasing,
)


def test_spacing_of_a_line_is_its_uniform_spacing():
    assert typical_spacing(line_array(32, 0.75)) == pytest.approx(0.75, rel=1e-12)


def test_spacing_of_a_planar_grid_is_its_pitch():
    g = np.stack(np.meshgrid(np.arange(5) * 0.3, np.arange(4) * 0.3), -1).reshape(-1, 2)
    p = np.c_[g, np.zeros(len(g))]
    assert typical_spacing(p, "3d") == pytest.approx(0.3, rel=1e-12)


def test_aliasing_limit_warns_just_above_c_over_2d():
    p = line_array(8, 0.5)  # c/(2d) = 1500 Hz
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_spatial_aliasing("stage 'cbf'", p, 1500.0, 1500.0)  # at the limit: silent
    with pytest.warns(UserWarning, match=r"c/\(2d\) = 1500 Hz"):
        warn_spatial_aliasing("stage 'cbf'", p, 1501.0, 1500.0)


@pytest.mark.parametrize("axis", [1, 2])
def test_line_off_body_x_warns(axis):
    p = np.zeros((8, 3))
    p[:, axis] = np.arange(8) * 0.5
    with pytest.warns(UserWarning, match="along body x"):
        warn_cone_geometry("stage 'cbf'", p)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_cone_geometry("stage 'cbf'", line_array(8, 0.5))
