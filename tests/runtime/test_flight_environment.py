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
from flights import fly_one_orbit, preset_values

from pmv_ros.apps.report import harmonic_spectrum
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.instrument.oblateness import closed_form_oblateness

REPO = Path(__file__).resolve().parents[2]


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
    # Expected: a few arcmin with everything on; the corrected latitude/season part alone is small: a
    # horizon level per chord (physics.md §3.2 item 3) is what the rig curve corrects (a Model-A level).
    assert 2.0 < full[0] < 10.0 and 2.0 < full[1] < 10.0
    assert climatology_only[0] < 0.5 * full[0] and climatology_only[1] < 0.5 * full[1]


def uncorrected_sigma_arcmin(values: dict) -> tuple[float, float]:
    t, reading, orbit = fly_one_orbit(values)
    _, model_roll, model_pitch = closed_form_oblateness(reading.argument_of_latitude_rad, orbit.altitude_m,
                                                        orbit.inclination_rad)
    return (float(np.nanstd(reading.sensed_roll_uncorrected_rad - model_roll)) / ARCMIN_RAD,
            float(np.nanstd(reading.sensed_pitch_uncorrected_rad - model_pitch)) / ARCMIN_RAD)


def test_each_component_adds_error():
    # The layer height adds error the curve cannot correct. The weather is a horizon level per chord
    # (physics.md §3.2 item 3): it adds error to the raw chain, and the working curve — made for a uniform
    # horizon of any level — takes nearly all of it out again (within 0.3′ of the climatology alone).
    base = dict(environment__weather=False, environment__height_variation=False)
    climatology_only = methodical_sigma_arcmin(preset_values("kondor", **base))
    with_weather = methodical_sigma_arcmin(preset_values("kondor", environment__height_variation=False))
    with_height = methodical_sigma_arcmin(preset_values("kondor", environment__weather=False))
    raw_climatology = uncorrected_sigma_arcmin(preset_values("kondor", **base))
    raw_weather = uncorrected_sigma_arcmin(preset_values("kondor", environment__height_variation=False))
    for index in (0, 1):
        assert with_height[index] > climatology_only[index] + 0.5
        assert raw_weather[index] > raw_climatology[index] + 1.0
        assert abs(with_weather[index] - climatology_only[index]) < 0.3


@pytest.mark.parametrize("preset", ["kondor", "meteor_m2"])
def test_everything_off_but_oblateness_leaves_only_its_signature(preset):
    # (no Sun/Moon exclusion: on the Meteor session date the Sun crosses a chord's arc for ≈ 5 min)
    values = preset_values(preset, radiance__source="uniform", sensor__bright_body_exclusion_deg=0.0)
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
    # physics.md §3.2 item 1: No.2-2 flies the working curve with a gain error, POP × s, 1 < s ≤ 2 (an
    # inference from its record); the corrected − uncorrected difference is then s × the working curve's,
    # chord by chord.
    scale = json.loads((REPO / "pmv_ros" / "data"
                        / "environment_calibration.json").read_text())["fitted"]["curve_scale"]
    assert 1.0 < scale <= 2.0
    _, working, _ = fly_one_orbit(preset_values("meteor_m2_2", sensor__correction="calibrated"))
    _, wrong, _ = fly_one_orbit(preset_values("meteor_m2_2"))
    np.testing.assert_allclose(wrong.crossing_nadir_uncorrected_rad, working.crossing_nadir_uncorrected_rad)
    # 0.001′ allows the CSV's 6-decimal rounding (5e-7′ per point, times s).
    excess = (wrong.crossing_nadir_rad - wrong.crossing_nadir_uncorrected_rad) \
        - scale * (working.crossing_nadir_rad - working.crossing_nadir_uncorrected_rad)
    # (Chords the Sun or the Moon blinds on the session date are NaN in both and left out.)
    assert np.mean(np.isfinite(excess)) > 0.9
    assert np.nanmax(np.abs(excess)) < 0.001 * ARCMIN_RAD
    # and it is not the working curve: the correction differs by (s − 1) × the working one, arcmin on average
    assert np.nanmean(np.abs(wrong.crossing_nadir_rad - working.crossing_nadir_rad)) > 1.0 * ARCMIN_RAD
    # "none" stays available: no correction at all.
    _, none, _ = fly_one_orbit(preset_values("meteor_m2_2", sensor__correction="none"))
    np.testing.assert_allclose(none.sensed_pitch_rad, none.sensed_pitch_uncorrected_rad)


# --------------------------------------------------------------------------
# The flight environment against the Meteor-M records (physics.md §3.2, issue 11)
# --------------------------------------------------------------------------

CALIBRATION = json.loads((REPO / "pmv_ros" / "data" / "environment_calibration.json").read_text())
FEW_SEEDS = (1, 2, 3)


def record_figures(preset: str, seeds=FEW_SEEDS, **overrides) -> dict:
    """Mean over seeds of the record's figures: one orbit every 4 s, raw sensed − true, oblateness kept, arcmin."""
    rows = []
    for seed in seeds:
        t, reading, orbit = fly_one_orbit(preset_values(preset, seed=seed, **overrides))
        _, roll = harmonic_spectrum(t, reading.sensed_roll_rad, orbit.period_s, 40)
        _, pitch = harmonic_spectrum(t, reading.sensed_pitch_rad, orbit.period_s, 40)
        _, _, model_pitch = closed_form_oblateness(reading.argument_of_latitude_rad, orbit.altitude_m,
                                                   orbit.inclination_rad)
        rows.append({"pitch_k2": pitch[1], "roll_k1": roll[0], "pitch_k20": pitch[19],
                     "hump_mean": np.mean(pitch[14:25]), "hump_max": np.max(pitch[14:25]),
                     "sigma": np.nanstd(reading.sensed_pitch_rad - model_pitch)})
    return {k: float(np.mean([r[k] for r in rows])) / ARCMIN_RAD for k in rows[0]}


def test_the_presets_fly_the_flight_sessions():
    # physics.md §3.2 item 5.
    for preset, day in (("kondor", "2013-09-10"), ("meteor_m2", "2016-11-11"), ("meteor_m2_2", "2019-07-21")):
        assert preset_values(preset)["sim.epoch_utc"].startswith(day)


@pytest.mark.regression
def test_the_flight_records_over_a_few_seeds():
    """The figures of the Meteor-M records (issue 30 "Must show") that the calibration reaches, on 3 seeds.

    A regression test: the presets were fitted to these figures (tools/calibrate_environment.py, seeds
    1–6 and 101–106). Tolerances: the 3-seed mean scatters about the 6-seed one by ≈ σ_seed/√3 (σ_seed from
    the calibration's JSON); each bound below is the target widened by 35 % of the 6-seed figure. Targets
    the calibration reports as not reached within the physical bounds are checked against its best
    in-bounds figure instead. Not from the fit: the curve works at all (below).
    """
    m2 = record_figures("meteor_m2")
    m22 = record_figures("meteor_m2_2")
    figures = {"m2_pitch_k2": m2["pitch_k2"], "m2_roll_k1": m2["roll_k1"], "m2_pitch_k20": m2["pitch_k20"],
               "m2_pitch_hump_mean": m2["hump_mean"], "m2_sigma_over_2k20": m2["sigma"] / (2 * m2["pitch_k20"]),
               "m22_k2_ratio": m22["pitch_k2"] / m2["pitch_k2"], "m22_pitch_hump_max": m22["hump_max"],
               "m22_hump_ratio": m22["hump_max"] / m2["hump_max"]}
    fit = CALIBRATION["fit"]["1-6"]["targets"]
    for name, target in CALIBRATION["targets"].items():
        low, high = target["low"], target["high"] if target["high"] is not None else math.inf
        value = figures[name]
        if name in CALIBRATION["unreached"]["1-6"]:
            # best in bounds, not the record: within 35 % of the 6-seed figure (3 seeds against 6)
            assert value == pytest.approx(fit[name], rel=0.35), name
        else:
            slack = 0.35 * max(abs(fit[name]), 1e-3)
            assert low - slack <= value <= high + slack, (name, value)
    # Independent of the fit: the brightness correction works on No.2 — its k = 2 is far below what
    # the same orbit gives with no curve (physics.md §3.2 item 1: ≈ 25′).
    none = record_figures("meteor_m2", seeds=(1,), sensor__correction="none")
    assert none["pitch_k2"] > 1.6 * m2["pitch_k2"]


def test_no_chord_is_lost_to_the_weather_over_a_year():
    # physics.md §3.2 item 2: the weather keeps the horizon inside 1 … 4 r.u., so no chord's comparators
    # fail for lack of radiance. Six epochs two months apart (every season; the solstice months January and
    # July and the equinox months March and September among them), all three presets, one orbit each (the
    # Sun/Moon exclusion, which the presets also fly, is switched off here: it is not the weather).
    lost = 0
    for preset in ("kondor", "meteor_m2", "meteor_m2_2"):
        for month in range(1, 13, 2):
            _, reading, _ = fly_one_orbit(preset_values(preset, sim__epoch_utc=f"2021-{month:02d}-15T06:00:00Z",
                                                        sensor__bright_body_exclusion_deg=0.0, seed=month))
            lost += int(np.sum(~reading.chord_valid))
    assert lost == 0


def test_the_pitch_pair_is_a_comb_filter_and_the_roll_pair_is_not():
    """The aft chord re-sees the fore chord's horizon point ≈ 940 s later (issue 11).

    For weather seen through the raw chain (no curve, no climatology, no height variation) the pitch
    error is ≈ e(t) − e(t − Δ): nulls at k ≈ n·T/Δ. With the weather a horizon level per chord (physics.md
    §3.2 item 3, issue 22) e is the anomaly at the horizon point itself, so Δ ≈ 940 s and the nulls fall
    near k ≈ 6.5, 12.9, 19.4; the Earth's rotation under the orbit fills them partly. The roll pair sees
    independent ground: no nulls. RMS over 8 seeds; measured (issue 22) at k = 19, 20 against k = 15, 16:
    0.50 for pitch, 0.78 for roll.
    """
    pitch, roll = [], []
    for seed in range(1, 9):
        t, reading, orbit = fly_one_orbit(preset_values(
            "meteor_m2", seed=seed, sensor__correction="none", environment__climatology=False,
            environment__height_variation=False))
        pitch.append(harmonic_spectrum(t, reading.sensed_pitch_rad, orbit.period_s, 30)[1] ** 2)
        roll.append(harmonic_spectrum(t, reading.sensed_roll_rad, orbit.period_s, 30)[1] ** 2)
    pitch, roll = np.sqrt(np.mean(pitch, axis=0)), np.sqrt(np.mean(roll, axis=0))
    null, peak = [18, 19], [14, 15]  # k = 19, 20 and k = 15, 16 (index k − 1)
    assert pitch[null].mean() < 0.6 * pitch[peak].mean()
    assert roll[null].mean() > 0.65 * roll[peak].mean()
    assert pitch[null].mean() > 0.1 * pitch[peak].mean()  # partly filled, not a perfect null
