"""A statistic not defined yet reads "pending" in ``pmv simulate``'s table, as on /pmv/error_statistics.

One rule, one home (:func:`pmv_ros.analysis.statistics.statistic_text`): a harmonic before a whole orbit, σ
before two samples — NaN inside — is the word "pending" wherever people read it, never "nan".
"""

from __future__ import annotations

import math

import pytest
from cli_runner import pmv

import pmv_msgs_shim as shim
from pmv_ros.analysis.statistics import PENDING, ChannelStatistics, statistic_text


def test_statistic_text_writes_pending_for_what_is_not_defined():
    assert [statistic_text(value) for value in (math.nan, math.inf, -math.inf, None)] == [PENDING] * 4
    assert statistic_text(0.1) == "0.1" and statistic_text(-2.0) == "-2.0"  # repr: the topic's exact numbers
    assert statistic_text(1.23456, "+.2f") == "+1.23"


def test_the_topic_and_the_table_share_the_rule():
    from diagnostic_msgs.msg import DiagnosticArray

    record = shim.ErrorStatistics(1.0, tuple(ChannelStatistics(channel, count=1, mean_rad=1e-3, max_abs_rad=1e-3,
                                                               harmonics_rad={1: math.nan})
                                             for channel in ("roll", "pitch", "meridional")))
    message = shim.write_error_statistics(DiagnosticArray(), record)
    roll = {pair.key: pair.value for pair in message.status[0].values}
    assert roll["sigma_arcmin"] == roll["harmonic_k01_arcmin"] == PENDING == "pending"


def _table(stdout: str) -> dict:
    """``pmv simulate``'s printed table: {channel: {heading: cell}}."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.split()[:1] == ["channel"])
    headings = [text.strip() for text in lines[start].split("  ") if text.strip()]
    rows = {}
    for line in lines[start + 2:start + 5]:
        cells = [text.strip() for text in line.split("  ") if text.strip()]
        rows[cells[0]] = dict(zip(headings, cells))
    return rows


@pytest.mark.parametrize("orbits, pending", [
    # 0.0004 orbit: samples before the first star-tracker frame have no truth, one after it has: no σ, no harmonic
    (0.0004, ("σ, ′", "mean ± 3σ, ′", "k=1, ′", "k=2, ′", "k=15…25 peak, ′")),
    (0.01, ("k=1, ′", "k=2, ′", "k=15…25 peak, ′")),  # under one orbit: no harmonic
])
def test_pmv_simulate_prints_pending_where_a_figure_is_not_defined_yet(orbits, pending):
    result = pmv("simulate", "--config", "config/kondor.yaml", "--orbits", orbits, "--quiet")
    assert result.returncode == 0, result.stderr
    assert "nan" not in result.stdout.lower()
    table = _table(result.stdout)
    assert set(table) == {"roll", "pitch", "meridional"}
    for row in table.values():
        for heading, cell in row.items():
            if heading in pending:
                assert cell == PENDING, (heading, cell)
            elif heading not in ("channel",):
                float(cell.replace("…", " ").split()[0])  # a number
