"""The sensor flying the radiance environment, built from the presets as the node builds it (issue 5).

physics.md §3.1: the latitude/season, weather and layer-height errors add up
(root sum of squares); §5.1: oblateness shows as roll at k = 1 and pitch at
k = 2 of the orbital frequency. Samples every 4 s over one orbit, as in the
Meteor-M harmonic analysis.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmv_ros.core.constants import ARCMIN_RAD
from pmv_ros.core.oblateness import closed_form_oblateness
from pmv_ros.core import parameters
from pmv_ros.core.assembly import SENSOR_PARAMS, build_models
from pmv_ros.report import harmonic_spectrum

REPO = Path(__file__).resolve().parents[1]


def preset_values(name: str, **overrides) -> dict:
    """The sensor node's parameter values from a preset file, as rclpy would merge them, in fast time."""
    document = yaml.safe_load((REPO / "config" / f"{name}.yaml").read_text())
    given = {"sim.fast_time": True, **{k.replace("__", "."): v for k, v in overrides.items()}}
    return parameters.preset_values(document, "sensor_node", SENSOR_PARAMS, given)


def fly_one_orbit(values: dict):
    """Sensed roll/pitch (rad) over one orbit at zero attitude, every 4 s, and the orbit."""
    orbit, _, model = build_models(values)
    t = np.arange(0.0, orbit.period_s, 4.0)
    reading = model.sense(t, np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), t.size))
    return t, reading, orbit


def methodical_sigma_arcmin(values: dict) -> tuple[float, float]:
    t, reading, orbit = fly_one_orbit(values)
    _, model_roll, model_pitch = closed_form_oblateness(reading.argument_of_latitude_rad, orbit.altitude_m,
                                                        orbit.inclination_rad)
    return (float(np.nanstd(reading.sensed_roll_rad - model_roll)) / ARCMIN_RAD,
            float(np.nanstd(reading.sensed_pitch_rad - model_pitch)) / ARCMIN_RAD)


def test_switching_off_weather_and_height_reduces_the_kondor_residual():
    full = methodical_sigma_arcmin(preset_values("kondor"))
    climatology_only = methodical_sigma_arcmin(preset_values("kondor", environment__weather=False,
                                                             environment__height_variation=False))
    # Expected: a few arcmin with everything on; the corrected latitude/season part alone is
    # about 1–2′ (the correction removes most of a smooth gradient, physics.md §4).
    assert 2.0 < full[0] < 10.0 and 2.0 < full[1] < 10.0
    assert climatology_only[0] < 0.5 * full[0] and climatology_only[1] < 0.5 * full[1]


def test_each_component_adds_error():
    base = dict(environment__weather=False, environment__height_variation=False)
    climatology_only = methodical_sigma_arcmin(preset_values("kondor", **base))
    with_weather = methodical_sigma_arcmin(preset_values("kondor", environment__height_variation=False))
    with_height = methodical_sigma_arcmin(preset_values("kondor", environment__weather=False))
    for index in (0, 1):
        assert with_weather[index] > climatology_only[index]
        assert with_height[index] > climatology_only[index]


@pytest.mark.parametrize("preset", ["kondor", "meteor_m2"])
def test_everything_off_but_oblateness_leaves_only_its_signature(preset):
    values = preset_values(preset, radiance__source="uniform")
    t, reading, orbit = fly_one_orbit(values)
    _, roll = harmonic_spectrum(t, reading.sensed_roll_rad, orbit.period_s, 30)
    _, pitch = harmonic_spectrum(t, reading.sensed_pitch_rad, orbit.period_s, 30)
    # roll at k = 1, pitch at k = 2 (physics.md §5.1), everything else two orders smaller
    assert np.argmax(roll) == 0 and np.argmax(pitch) == 1
    assert roll[0] / ARCMIN_RAD > 2.0 and pitch[1] / ARCMIN_RAD > 4.0
    assert np.max(np.delete(roll, 0)) < 0.02 * roll[0]
    assert np.max(np.delete(pitch, [1, 3])) < 0.02 * pitch[1]  # k = 4 is the next term of the oblateness itself
    assert np.all(reading.chord_valid)


def test_meteor_m2_2_flies_the_over_correcting_curve():
    # physics.md §3.2 item 1: No.2-2 flies the rig curve scaled by s > 1 (an inference from its record);
    # the corrected − uncorrected difference is then s × the working curve's, chord by chord.
    scale = json.loads((REPO / "pmv_ros" / "data" / "environment_calibration.json").read_text())["fitted"]["curve_scale"]
    assert 1.0 < scale <= 2.0
    _, working, _ = fly_one_orbit(preset_values("meteor_m2_2", sensor__correction="calibrated"))
    _, wrong, _ = fly_one_orbit(preset_values("meteor_m2_2"))
    np.testing.assert_allclose(wrong.crossing_nadir_uncorrected_rad, working.crossing_nadir_uncorrected_rad)
    # POP_s = POP₀ + s·(POP − POP₀): per chord, wrong − s × working is the constant (1 − s)·POP₀
    # (which cancels in every pair); 0.01′ allows the CSV's 6-decimal rounding.
    excess = (wrong.crossing_nadir_rad - wrong.crossing_nadir_uncorrected_rad) \
        - scale * (working.crossing_nadir_rad - working.crossing_nadir_uncorrected_rad)
    assert np.ptp(excess) < 0.01 * ARCMIN_RAD
    assert abs(np.mean(excess)) > 1.0 * ARCMIN_RAD  # and it is not the working curve
    # "none" stays available: no correction at all.
    _, none, _ = fly_one_orbit(preset_values("meteor_m2_2", sensor__correction="none"))
    np.testing.assert_allclose(none.sensed_pitch_rad, none.sensed_pitch_uncorrected_rad)
