"""``pmv simulate --closed-loop [--compensation off|on]``: the true pointing error beside the residuals."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_runner import pmv

REPO = Path(__file__).resolve().parents[2]
KONDOR = str(REPO / "config" / "kondor.yaml")


@pytest.fixture(scope="module")
def closed_run(tmp_path_factory):
    report = tmp_path_factory.mktemp("report")
    result = pmv("simulate", "--config", KONDOR, "--orbits", "0.03", "--rate-hz", "2", "--closed-loop",
                 "--compensation", "off", "--report", report, "--json", "--quiet")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout), report


def test_the_json_carries_the_pointing_per_axis(closed_run):
    summary, _ = closed_run
    pointing = summary["pointing"]
    assert pointing["oblateness_compensation"] is False and pointing["bandwidth_hz"] == 0.02
    assert pointing["settling_time_s"] == pytest.approx(4.0 / (0.7 * 2 * 3.141592653589793 * 0.02))
    for axis in ("roll", "pitch"):
        figures = pointing[axis]
        # 0.03 orbit (170 s) at 10 Hz control: the steps after the 45 s settling time.
        assert figures["count"] == pytest.approx(10 * (0.03 * 5677 - pointing["settling_time_s"]), abs=30)
        assert 0.0 < figures["sigma_arcmin"] < 20.0 and figures["max_abs_arcmin"] < 30.0
        assert set(figures["harmonics_arcmin"]) >= {"1", "2", "20"}
    assert summary["channels"]["roll"]["count"] > 0  # the residual statistics as before, beside it


def test_the_report_adds_the_pointing_plot_and_section(closed_run):
    summary, report = closed_run
    assert str(report / "pointing.png") in summary["report_files"]
    data = (report / "pointing.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    written = json.loads((report / "statistics.json").read_text())
    assert written["pointing"]["roll"]["count"] == summary["pointing"]["roll"]["count"]


def test_the_table_shows_the_true_pointing():
    result = pmv("simulate", "--config", KONDOR, "--orbits", "0.01", "--rate-hz", "2", "--closed-loop",
                 "--compensation", "on", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "true pointing error" in result.stdout and "oblateness compensation on" in result.stdout
    assert "true roll" in result.stdout and "true pitch" in result.stdout


def test_compensation_without_the_closed_loop_is_one_line_and_exit_2():
    result = pmv("simulate", "--config", KONDOR, "--orbits", "0.01", "--compensation", "on", "--quiet")
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1 and "--closed-loop" in result.stderr
    result = pmv("simulate", "--config", KONDOR, "--closed-loop", "--compensation", "maybe")
    assert result.returncode == 2 and "maybe" in result.stderr


def test_the_open_loop_json_has_no_pointing():
    result = pmv("simulate", "--config", KONDOR, "--orbits", "0.005", "--rate-hz", "2", "--json", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "pointing" not in json.loads(result.stdout)
