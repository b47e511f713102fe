"""``pmv scenario {A,B,C,D}``: tables, JSON, the model behaviours from the command line, one-line errors."""

from __future__ import annotations

import json

import pytest
from cli_runner import pmv

from pmv_ros.cli import main


def scenario_json(capsys, *args) -> dict:
    """Run ``pmv scenario ... --json`` in-process and parse its one JSON object."""
    status = main(["scenario", *args, "--json"])
    out = capsys.readouterr().out
    assert status == 0
    assert len(out.strip().splitlines()) == 1
    return json.loads(out)


def test_model_a_json_reproduces_the_first_table_row(capsys):
    payload = scenario_json(capsys, "A", "--b1", "1", "--b2", "2", "--altitude-km", "500")
    for key in ("beta_arcmin", "beta_corrected_arcmin", "gam_arcmin", "del_arcmin", "chords"):
        assert key in payload
    assert len(payload["gam_arcmin"]) == len(payload["del_arcmin"]) == 2
    # physics.md §4 table (Model A at 500 km), row 1: β = 22.7′ (10 %), β′ = 0.1′ (under 1′).
    assert payload["beta_arcmin"] == pytest.approx(22.7, rel=0.10)
    assert abs(payload["beta_corrected_arcmin"]) < 1.0
    assert [c["status"] for c in payload["chords"]] == ["OK", "OK"]


def test_model_b_from_the_cli_correction_reduces_the_error_several_fold(capsys):
    payload = scenario_json(capsys, "B")  # defaults: 1.6 → 3.5 r.u. (physics.md §3.1)
    assert abs(payload["beta_arcmin"]) > 3.0 * abs(payload["beta_corrected_arcmin"])


def test_model_c_from_the_cli_error_largest_for_a_dark_horizon(capsys):
    errors = {b: abs(scenario_json(capsys, "C", "--b", b, "--jump", "0.4")["beta_corrected_arcmin"])
              for b in ("1", "2.4", "4")}
    assert errors["1"] > errors["2.4"] > errors["4"]


def test_model_c_jump_distance_option(capsys):
    near = scenario_json(capsys, "C", "--b", "1", "--jump-distance-km", "300")
    far = scenario_json(capsys, "C", "--b", "1", "--jump-distance-km", "3000")
    assert abs(far["beta_arcmin"]) < 0.01 < abs(near["beta_arcmin"])


def test_model_d_from_the_cli_correction_changes_the_error_by_less_than_one_arcmin(capsys):
    payload = scenario_json(capsys, "D", "--b", "2.4", "--height-km", "50")
    assert abs(payload["beta_arcmin"]) > 1.0
    assert abs(payload["beta_corrected_arcmin"] - payload["beta_arcmin"]) < 1.0


def test_table_for_people_and_no_correction():
    result = pmv("scenario", "A", "--b1", "1", "--b2", "4", "--correction", "none")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("Model A") and "correction: none" in lines[0]
    assert any(line.startswith("β  =") for line in lines) and any(line.startswith("β′ =") for line in lines)
    beta = float(next(l for l in lines if l.startswith("β  =")).split()[2].rstrip("′"))
    corrected = float(next(l for l in lines if l.startswith("β′ =")).split()[2].rstrip("′"))
    assert beta == corrected  # no table: Gam′ = Gam


def test_correction_table_from_a_file(tmp_path, capsys):
    path = tmp_path / "flat.csv"
    path.write_text("del_arcmin,pop_arcmin\n20,1.5\n200,1.5\n")
    payload = scenario_json(capsys, "A", "--b1", "1", "--b2", "3", "--correction", str(path))
    assert payload["correction"] == str(path)
    assert payload["beta_corrected_arcmin"] == pytest.approx(payload["beta_arcmin"], abs=1e-9)


@pytest.mark.parametrize("args, fragment", [
    (["A", "--b1", "0"], "argument --b1: 0 r.u. is outside the allowed range (0, 20] r.u."),
    (["A", "--b2", "-2"], "argument --b2: -2 r.u. is outside the allowed range"),
    (["B", "--b1", "nan"], "argument --b1: nan r.u. is outside the allowed range"),
    (["C", "--b", "inf"], "outside the allowed range"),
    (["C", "--b", "two"], "'two' is not a number"),
    (["D", "--height-km", "120"], "argument --height-km: 120 km is outside the allowed range [0, 100] km"),
    (["D", "--height-km", "-5"], "outside the allowed range [0, 100] km"),
    (["E"], "invalid choice: 'E'"),
    (["C", "--b", "1", "--jump", "-1.5"], "must be positive"),
    (["A", "--correction", "/no/such/table.csv"], "cannot read correction table /no/such/table.csv"),
])
def test_bad_input_is_one_line_and_non_zero(args, fragment):
    result = pmv("scenario", *args)
    assert result.returncode != 0
    assert fragment in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr
    assert result.stdout == ""


def test_a_horizon_too_dark_to_sense_is_reported_per_chord():
    result = pmv("scenario", "A", "--b1", "0.5", "--b2", "2", "--json")
    assert result.returncode == 1
    assert result.stderr.strip() == ("pmv scenario: error: chord 1: never crossed the second threshold (0.67 J): "
                                     "horizon too dark")
    payload = json.loads(result.stdout)
    assert payload["beta_arcmin"] is None
    assert [c["status"] for c in payload["chords"]] == ["SECOND_THRESHOLD_NOT_REACHED", "OK"]
