"""The Meteor-M flight records through the calibrated presets (issue 30 "Must show"; physics.md §3.2).

One orbit every 4 s at zero attitude, raw sensed angles (oblateness kept), harmonic amplitudes as in
§5.1 — what tools/calibrate_environment.py fits on seeds 1–6 and 101–106 together. Here three seeds of
each set (the whole figures, with their seed spread, are in pmv_ros/data/environment_calibration.json).

A regression test (marked so): the presets were fitted to these very figures. It guards them against
drift in two ways: each seed's figures equal the calibration's own for that seed (0.01′: the No.2-2
curve's CSV keeps 6 decimals), and the three-seed means stay inside the issue's intervals widened by two
standard errors of a three-seed mean (σ_seed/√3, σ_seed the calibration's six-seed spread on that set).
What the climatology sampled at the horizon does by itself is tested independently of the fit in
tests/physics/test_climatology_sampling.py.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmv_ros.apps.report import harmonic_spectrum
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.instrument.oblateness import closed_form_oblateness
from pmv_ros.runtime.common import parameters
from pmv_ros.runtime.common.assembly import SENSOR_PARAMS, build_models

REPO = Path(__file__).resolve().parents[2]
CALIBRATION = json.loads((REPO / "pmv_ros" / "data" / "environment_calibration.json").read_text())


def _figures(preset: str, seeds) -> dict:
    """Per-seed figures of one preset, arcmin: pitch k=2, roll k=1, pitch k=20, pitch k=15…25 mean and max, σ."""
    document = yaml.safe_load((REPO / "config" / f"{preset}.yaml").read_text())
    rows = []
    for seed in seeds:
        values = parameters.preset_values(document, "sensor_node", SENSOR_PARAMS, {"sim.fast_time": True, "seed": seed})
        orbit, _, model = build_models(values)
        t = np.arange(0.0, orbit.period_s, 4.0)
        reading = model.sense(t, np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), t.size))
        _, roll = harmonic_spectrum(t, reading.sensed_roll_rad, orbit.period_s, 40)
        _, pitch = harmonic_spectrum(t, reading.sensed_pitch_rad, orbit.period_s, 40)
        _, _, model_pitch = closed_form_oblateness(reading.argument_of_latitude_rad, orbit.altitude_m,
                                                   orbit.inclination_rad)
        rows.append({"pitch_k2": pitch[1], "roll_k1": roll[0], "pitch_k20": pitch[19],
                     "hump_mean": np.mean(pitch[14:25]), "hump_max": np.max(pitch[14:25]),
                     "sigma": np.nanstd(reading.sensed_pitch_rad - model_pitch),
                     "lost": int(np.sum(reading.chord_status == 2)),
                     "roll_holes": int(np.sum(~np.isfinite(reading.sensed_roll_rad)))})
    return {k: np.array([r[k] for r in rows]) / (1 if k in ("lost", "roll_holes") else ARCMIN_RAD) for k in rows[0]}


SETS = {(1, 2, 3): "1-6", (101, 102, 103): "101-106"}
#: The figures' names in the calibration's JSON.
JSON_NAMES = {"pitch_k2": "pitch_k2", "roll_k1": "roll_k1", "pitch_k20": "pitch_k20", "hump_mean": "pitch_hump_mean",
              "hump_max": "pitch_hump_max", "sigma": "pitch_sigma"}


def _error(seeds, preset: str, figure: str) -> float:
    """Two standard errors of a 3-seed mean, from the calibration's 6-seed spread on the seeds' set, arcmin."""
    return 2.0 * CALIBRATION["fit"][SETS[seeds]][preset][figure]["spread"] / math.sqrt(3.0)


@pytest.mark.regression
@pytest.mark.parametrize("seeds", list(SETS), ids=list(SETS.values()))
def test_the_meteor_records_with_the_climatology_as_a_horizon_level(seeds):
    m2, m22 = _figures("meteor_m2", seeds), _figures("meteor_m2_2", seeds)
    assert m2["lost"].sum() == 0 and m22["lost"].sum() == 0
    calibrated = CALIBRATION["fit"][SETS[seeds]]
    for preset, figures in (("meteor_m2", m2), ("meteor_m2_2", m22)):
        for name, key in JSON_NAMES.items():
            if name == "roll_k1" and figures["roll_holes"].any():
                # No.2-2's roll has a 13° hole (the stored curve loses a chord pair there): the calibration's
                # figure came from a fit of every k ≤ 40 at once through it (a noise gain of ≈ 26 at k = 1); the
                # report's fit (statistics.fit_harmonics) differs there by design — not a calibration target.
                assert np.isfinite(figures[name]).all()
                continue
            expected = [calibrated[preset][key]["per_seed"][calibrated["seeds"].index(seed)] for seed in seeds]
            np.testing.assert_allclose(figures[name], expected, rtol=0, atol=0.01, err_msg=f"{preset} {name}")
    k2 = m2["pitch_k2"].mean()
    # No.2 pitch k = 2, record ≈ 9′ (oblateness alone 8.64′): 8 … 10′; the climatology line of sight gave 10.9′.
    assert 8.0 - _error(seeds, "meteor_m2", "pitch_k2") <= k2 <= 10.0 + _error(seeds, "meteor_m2", "pitch_k2")
    # No.2 roll k = 1, record "a bit above 2′" (oblateness 2.73′): 2 … 3.3′.
    roll = m2["roll_k1"].mean()
    assert 2.0 - _error(seeds, "meteor_m2", "roll_k1") <= roll <= 3.3 + _error(seeds, "meteor_m2", "roll_k1")
    # No.2 pitch k = 20 ≤ 0.8′ and the mean of k = 15 … 25 ≤ 0.8′: the working curve suppresses the hump.
    assert m2["pitch_k20"].mean() <= 0.8 + _error(seeds, "meteor_m2", "pitch_k20")
    assert m2["hump_mean"].mean() <= 0.8 + _error(seeds, "meteor_m2", "pitch_hump_mean")
    # The per-sample scatter (oblateness removed) exceeds twice the k = 20 amplitude: the height error.
    assert m2["sigma"].mean() > 2.0 * m2["pitch_k20"].mean()
    # No.2-2: largest pitch k = 15 … 25 in 2.5 … 10′ and ≥ 4× No.2's (the record's k = 20 ratio ≈ 12×).
    hump = m22["hump_max"].mean()
    assert 2.5 - _error(seeds, "meteor_m2_2", "pitch_hump_max") <= hump <= 10.0
    assert hump >= 4.0 * m2["hump_max"].mean()
    # No.2-2 pitch k = 2 at 0.35 … 0.7 of No.2's (record ≈ 0.5) on each set. Its weather part is full size
    # under the over-correcting curve, so a seed's figure scatters (calibration: 1.4 … 8.9′); the band is
    # widened by the 3-seed standard error of that figure over No.2's k = 2.
    ratio = m22["pitch_k2"].mean() / k2
    slack = _error(seeds, "meteor_m2_2", "pitch_k2") / k2
    assert 0.35 - slack <= ratio <= 0.7 + slack
    assert ratio < 0.9  # and always below No.2's: the curve over-corrects




def _calibration_tool():
    spec = importlib.util.spec_from_file_location("pmv_calibrate_environment",
                                                  REPO / "tools" / "calibrate_environment.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_calibration_combines_runs_with_lost_chords_linearly():
    # The tool flies No.2-2 once with the working curve and forms the gain-s curve as β_raw + s·(β_working −
    # β_raw), harmonic by harmonic. On the session date the Sun blinds the roll pair for ≈ 55 samples, so the
    # harmonics of those runs come from a gappy least-squares fit: they must stay complex coefficients (the
    # amplitudes of report.harmonic_spectrum, 1e-9′), so that the combination equals the harmonics of the
    # combined series — combining amplitudes would assume every harmonic in phase.
    tool = _calibration_tool()
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 6090.0, 4.0)
    period = 6090.0
    raw = 9.0 * np.cos(4 * np.pi * t / period + 0.3) + rng.normal(0.0, 1.0, t.size)
    working = 3.0 * np.cos(4 * np.pi * t / period - 1.2) + rng.normal(0.0, 1.0, t.size)
    raw[700:755] = working[700:755] = np.nan
    c_raw, c_working = tool._harmonics(t, period, raw), tool._harmonics(t, period, working)
    np.testing.assert_allclose(np.abs(c_raw), harmonic_spectrum(t, raw, period, 40)[1], rtol=0, atol=1e-9)
    combined = raw + 1.92 * (working - raw)
    np.testing.assert_allclose(np.abs(c_raw + 1.92 * (c_working - c_raw)),
                               harmonic_spectrum(t, combined, period, 40)[1],
                               rtol=0, atol=1e-9)
