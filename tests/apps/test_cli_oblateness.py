"""``pmv oblateness``: table, JSON and one-line errors (issue 2)."""

from __future__ import annotations

import json

import pytest
from cli_runner import pmv


def test_json_rows_reproduce_the_kondor_table_row_at_45_deg():
    result = pmv("oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--step-deg", "15", "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    rows = {row["u_deg"]: row for row in payload["rows"]}
    assert len(rows) == 24
    # physics.md §2.1 Kondor table, u = 45°: 9.7, 9.1, −3.4 (tolerance 0.3′, see test_geometry.py).
    assert rows[45.0]["meridional_arcmin"] == pytest.approx(9.7, abs=0.3)
    assert rows[45.0]["pitch_arcmin"] == pytest.approx(9.1, abs=0.3)
    assert rows[45.0]["roll_arcmin"] == pytest.approx(-3.4, abs=0.3)


def test_table_for_people():
    result = pmv("oblateness", "--altitude-km", "835", "--inclination-deg", "98.8")
    assert result.returncode == 0
    assert "pitch" in result.stdout and "roll" in result.stdout
    assert len(result.stdout.splitlines()) == 3 + 24


@pytest.mark.parametrize("args, fragment", [
    (["--altitude-km", "-5", "--inclination-deg", "74.5"], "-5 km is outside the allowed range [150, 40000] km"),
    (["--altitude-km", "1e9", "--inclination-deg", "74.5"], "outside the allowed range"),
    (["--altitude-km", "500", "--inclination-deg", "190"], "190 deg is outside the allowed range [0, 180] deg"),
    (["--altitude-km", "five", "--inclination-deg", "74.5"], "'five' is not a number"),
    (["--altitude-km", "nan", "--inclination-deg", "74.5"], "outside the allowed range"),
    (["--altitude-km", "500", "--inclination-deg", "74.5", "--step-deg", "0"], "outside the allowed range"),
])
def test_bad_input_is_one_line_and_non_zero(args, fragment):
    result = pmv("oblateness", *args)
    assert result.returncode != 0
    assert fragment in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr
    assert result.stdout == ""


def test_convention_is_named_and_ros_is_the_paper_table_with_both_signs_reversed():
    # physics.md "Sign conventions": the published table (paper) is the default; --convention ros
    # gives the signs of /pmv/attitude (REP-103), the opposite for roll and pitch; meridional is
    # the paper's (Δβ)m in both.
    common = ("oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--json")
    paper, ros = (json.loads(pmv(*common, *extra).stdout) for extra in ((), ("--convention", "ros")))
    assert paper["convention"] == "paper" and ros["convention"] == "ros"
    for row_paper, row_ros in zip(paper["rows"], ros["rows"]):
        assert row_ros["roll_arcmin"] == pytest.approx(-row_paper["roll_arcmin"], abs=1e-12)
        assert row_ros["pitch_arcmin"] == pytest.approx(-row_paper["pitch_arcmin"], abs=1e-12)
        assert row_ros["meridional_arcmin"] == pytest.approx(row_paper["meridional_arcmin"], abs=1e-12)
    rows = {row["u_deg"]: row for row in ros["rows"]}
    assert rows[45.0]["pitch_arcmin"] == pytest.approx(-9.1, abs=0.3)  # Kondor table, u = 45°, sign reversed
    table = pmv("oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--convention", "ros")
    assert "REP-103" in table.stdout.splitlines()[0]
    bad = pmv("oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--convention", "nasa")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
