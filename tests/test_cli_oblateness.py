"""``pmv oblateness``: table, JSON and one-line errors (issue 2)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


def pmv(*args):
    return subprocess.run([sys.executable, "-m", "pmv_ros.cli", *args], capture_output=True, text=True, timeout=120)


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
