"""The horizon radiance profile of physics.md §3 (pmv_ros.physics.radiance)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.radiance import (
    CO2_RADIANCE_RU,
    LINEAR_RAMP,
    RampShape,
    atmosphere_radiance,
    disc_radiance,
    line_of_sight_radiance,
    mw_cm2_sr_from_ru,
    ru_from_mw_cm2_sr,
)


def test_radiance_unit_conversions_follow_physics_md_section_3():
    # physics.md §3: 1 r.u. = 2.5 mW/(cm²·sr); the maximum 10 mW/(cm²·sr) = 4 r.u.;
    # the Model B extremes 4 and 8.75 mW/(cm²·sr) are 1.6 and 3.5 r.u.
    assert ru_from_mw_cm2_sr(2.5) == pytest.approx(1.0)
    assert ru_from_mw_cm2_sr(10.0) == pytest.approx(4.0)
    assert ru_from_mw_cm2_sr([4.0, 8.75]) == pytest.approx([1.6, 3.5])
    assert mw_cm2_sr_from_ru(2.4) == pytest.approx(6.0)


def test_profile_layers_from_space_down():
    heights = np.array([80e3, 60.001e3, 59.9e3, 45e3, 40e3, 20e3, 0.0])
    radiance = atmosphere_radiance(heights, 3.0, window_height_m=40e3)
    # space above the 60 km CO₂ top, B_a = 0.3 J in the CO₂ layer, B_a at h_w, the linear ramp midway, B_m at 0.
    assert radiance.tolist() == pytest.approx([0.0, 0.0, 0.3, 0.3, 0.3, 0.3 + 0.5 * 2.7, 3.0])


def test_ramp_is_monotone_between_surface_and_window_height():
    h = np.linspace(0.0, 40e3, 401)
    for b_m in (1.0, 4.0):
        values = atmosphere_radiance(h, b_m)
        assert np.all(np.diff(values) <= 1e-12)
        assert values[0] == pytest.approx(b_m) and values[-1] == pytest.approx(CO2_RADIANCE_RU)


def test_window_layer_above_the_co2_top_becomes_the_top_of_the_atmosphere():
    radiance = atmosphere_radiance([70e3, 75e3, 81e3], 2.0, window_height_m=80e3, co2_top_height_m=60e3)
    assert radiance[2] == 0.0
    assert radiance[0] > radiance[1] > CO2_RADIANCE_RU


def test_window_layer_at_the_surface_is_a_step():
    radiance = atmosphere_radiance([1.0, 0.0], 2.0, window_height_m=0.0)
    assert radiance.tolist() == [CO2_RADIANCE_RU, 2.0]


def test_power_ramp_tabulation_is_close_to_the_exact_shape():
    u = np.linspace(0.0, 1.0, 1001)
    for p in (0.25, 0.5, 2.0, 4.0):
        shape = RampShape.power(p)
        # 17 knots: the piecewise-linear table is within 0.016 of (1 − u)^p everywhere (0.02 allowed).
        assert np.max(np.abs(shape(u) - (1.0 - u) ** p)) < 0.02
    assert RampShape.power(1.0) == LINEAR_RAMP


@pytest.mark.parametrize("heights, values, fragment", [
    ((0.0, 0.5), (1.0, 0.0), "rise strictly from 0 to 1"),
    ((0.0, 0.5, 0.5, 1.0), (1.0, 0.5, 0.4, 0.0), "rise strictly"),
    ((0.0, 1.0), (0.9, 0.0), "fall monotonically from 1 to 0"),
    ((0.0, 0.5, 1.0), (1.0, 0.2, 0.4), "fall monotonically"),
    ((0.0,), (1.0,), "at least 2 knots"),
    ((0.0, math.nan), (1.0, 0.0), "finite"),
])
def test_bad_ramp_shapes_are_rejected(heights, values, fragment):
    with pytest.raises(ValueError, match=fragment):
        RampShape(heights, values)


def test_bad_power_exponent_is_rejected():
    with pytest.raises(ValueError, match="outside the allowed range"):
        RampShape.power(0.0)


def test_disc_radiance_gradient_and_jump():
    d = np.array([0.0, 100e3, 299e3, 300e3, 1000e3])
    radiance = disc_radiance(d, 2.0, gradient_ru_per_m=1e-6, jump_ru=0.4, jump_distance_m=300e3)
    assert radiance.tolist() == pytest.approx([2.0, 2.1, 2.299, 2.7, 3.4])


def test_line_of_sight_hits_the_disc_below_zero_height():
    radiance = line_of_sight_radiance([10e3, -1.0, -50e3], [np.nan, 0.0, 500e3], 2.0, gradient_ru_per_m=1e-6)
    assert radiance.tolist() == pytest.approx([0.3 + 0.75 * 1.7, 2.0, 2.5])
