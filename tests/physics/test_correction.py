"""The brightness-correction table F(Del): the simulated rig, the shipped files, loading, applying."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.chain import DetectionStatus, scan_start_nadir_angle, sense_horizon_chords, sphere_chord
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.instrument.correction import (
    RIG_RADIANCES_RU,
    CorrectionTable,
    calibrated_correction_table,
    load_correction,
    rig_correction_table,
    simulate_rig,
)
from pmv_ros.physics.instrument.scenarios import model_a, run_pair


def test_rig_covers_one_to_four_radiance_units():
    # physics.md §3: horizon radiance 1 … 4 r.u. is the range the rig must cover.
    assert RIG_RADIANCES_RU[0] == 1.0 and RIG_RADIANCES_RU[-1] == 4.0


def test_rig_table_corrects_a_uniform_earth_onto_the_hard_horizon():
    # Under rig conditions the corrected crossing is the geometric one for every rig radiance.
    table = rig_correction_table(500e3)
    del_rad, gam_rad, geometric = simulate_rig(500e3)
    assert table(del_rad) == pytest.approx(gam_rad - geometric, abs=1e-12)
    assert np.all(np.diff(table.pop_rad) > 0.0)  # larger Del = darker = later crossing = larger POP


@pytest.mark.parametrize("altitude_km", [500, 835])
def test_shipped_tables_are_what_the_rig_gives_with_the_default_parameters(altitude_km):
    # tools/calibrate_chain.py wrote them; a stale file (parameters changed, table not regenerated) fails here.
    shipped = calibrated_correction_table(altitude_km * 1e3)
    fresh = rig_correction_table(altitude_km * 1e3)
    assert shipped.source.endswith(f"correction_rig_{altitude_km}km.csv")
    # The CSV keeps 6 decimals of arcmin.
    assert shipped.del_rad == pytest.approx(fresh.del_rad, abs=1e-6 * ARCMIN_RAD)
    assert shipped.pop_rad == pytest.approx(fresh.pop_rad, abs=1e-6 * ARCMIN_RAD)


def test_other_altitudes_are_simulated():
    assert calibrated_correction_table(650e3).source == "calibration rig, 650 km"


def test_lookup_interpolates_linearly_and_clamps_outside():
    table = CorrectionTable(np.array([1.0, 2.0, 4.0]), np.array([10.0, 20.0, 0.0]))
    assert table(np.array([0.5, 1.5, 3.0, 9.0])).tolist() == [10.0, 15.0, 10.0, 0.0]
    assert math.isnan(float(table(math.nan)))


def test_csv_round_trip(tmp_path):
    table = rig_correction_table(835e3)
    path = tmp_path / "curve.csv"
    table.to_csv(path, comments=["test table"])
    loaded = CorrectionTable.from_csv(path)
    assert path.read_text().startswith("# test table\ndel_arcmin,pop_arcmin\n")
    assert loaded.del_rad == pytest.approx(table.del_rad, abs=1e-6 * ARCMIN_RAD)
    assert loaded.pop_rad == pytest.approx(table.pop_rad, abs=1e-6 * ARCMIN_RAD)


def test_unsorted_rows_are_sorted():
    table = CorrectionTable.from_csv_text("del_arcmin,pop_arcmin\n60,5\n30,-20\n45,0\n")
    assert (table.del_rad / ARCMIN_RAD).tolist() == pytest.approx([30.0, 45.0, 60.0])


@pytest.mark.parametrize("text, fragment", [
    ("", "is empty"),
    ("del,pop\n1,2\n3,4\n", "line 1: the header must be 'del_arcmin,pop_arcmin'"),
    ("del_arcmin,pop_arcmin\n1,2\n", "at least 2 rows"),
    ("# note\ndel_arcmin,pop_arcmin\n1,2\nx,4\n", "line 4: expected two finite numbers"),
    ("del_arcmin,pop_arcmin\n1,2\n3,nan\n", "line 3: expected two finite numbers"),
    ("del_arcmin,pop_arcmin\n1,2\n3\n", "line 3"),
    ("del_arcmin,pop_arcmin\n1,2\n1,3\n", "repeated Del"),
])
def test_malformed_files_raise_naming_the_line(text, fragment):
    with pytest.raises(ValueError, match=fragment):
        CorrectionTable.from_csv_text(text, source="t.csv")


def test_missing_file_raises_value_error(tmp_path):
    with pytest.raises(ValueError, match="cannot read correction table"):
        CorrectionTable.from_csv(tmp_path / "absent.csv")


def test_load_correction_words_and_paths(tmp_path):
    assert load_correction("none", 500e3) is None
    assert load_correction("calibrated", 500e3).source.endswith("correction_rig_500km.csv")
    path = tmp_path / "flat.csv"
    path.write_text("del_arcmin,pop_arcmin\n30,0\n170,0\n")
    assert load_correction(str(path), 500e3).source == str(path)


def test_a_curve_that_does_not_correct_leaves_the_error_as_it_was(tmp_path):
    # physics.md §4: Meteor-M No.2-2 flew with a stored curve that did not correct the brightness error.
    path = tmp_path / "meteor_m2_2.csv"
    path.write_text("# a flat curve\ndel_arcmin,pop_arcmin\n20,3.0\n200,3.0\n")
    flat = load_correction(str(path), 835e3)
    result = run_pair(model_a(1.0, 3.0, 835e3), correction=flat)
    uncorrected = run_pair(model_a(1.0, 3.0, 835e3), correction=None)
    assert result.beta_corrected_rad == pytest.approx(result.beta_rad, abs=1e-12)
    assert result.beta_rad == pytest.approx(uncorrected.beta_rad, abs=1e-12)
    assert abs(result.beta_rad) > 20 * ARCMIN_RAD


def test_corrected_horizon_is_the_hard_earth_horizon_under_rig_conditions():
    # Any radiance between the rig's points, any sub-step phase of the scan start: θ₀ − Gam′ = φ₀
    # to the table's interpolation error (rig step 0.025 r.u.; measured ≤ 0.015′, 0.2′ allowed).
    phi0, slope = sphere_chord(500e3)
    start = scan_start_nadir_angle(phi0, slope) + np.linspace(0.0, 0.01, 7)
    radiances = np.array([1.01, 1.13, 1.7, 2.44, 3.06, 3.51, 3.99])
    readings = sense_horizon_chords(phi0, slope, radiances, scan_start_nadir_rad=start,
                                    correction=calibrated_correction_table(500e3))
    assert np.all(readings.status == DetectionStatus.OK)
    assert np.max(np.abs(readings.sensed_horizon_nadir_rad - phi0)) / ARCMIN_RAD < 0.2
    # Uncorrected, the same horizon is misplaced by up to ≈ 1° (the methodical error the table removes).
    assert np.max(np.abs(readings.sensed_horizon_nadir_uncorrected_rad - phi0)) / ARCMIN_RAD > 40.0


def test_the_no2_2_curve_is_refused_on_another_orbit():
    """The inferred Meteor-M No.2-2 curve belongs to the 835 km orbit: elsewhere it would be silently wrong."""
    from pmv_ros.physics.instrument.correction import load_correction

    assert load_correction("meteor_m2_2", 835e3) is not None
    with pytest.raises(ValueError, match="835 km"):
        load_correction("meteor_m2_2", 500e3)
