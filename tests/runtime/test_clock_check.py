"""The /clock rule (issue 23): what may set a node's time, and that every refusal is counted by reason.

The nodes' wiring of the rule (a hostile /clock against running processes)
is tested in ``tests/system/test_hostile_clock.py``.
"""

from __future__ import annotations

import pytest

from pmv_ros.runtime.common.validation import CLOCK_REJECTIONS, ClockCheck

BACK_S, AHEAD_S = 1.0, 10.0


def _check() -> ClockCheck:
    return ClockCheck(BACK_S, AHEAD_S, source_timeout_s=1.0)


@pytest.mark.parametrize("sec, nanosec, reason", [
    (-1, 0, "negative"),
    (-(2**31), 0, "negative"),
    (5, 1_000_000_000, "malformed"),   # nanosec must be below one second
    (5, -1, "malformed"),
    (2**31, 0, "malformed"),           # beyond int32 seconds
    (5.0, 0, "malformed"),             # not integers (a hand-made message object)
    (True, 0, "malformed"),
])
def test_a_time_rclpy_would_choke_on_is_refused_and_counted(sec, nanosec, reason):
    check = _check()
    assert check.admit(100, 0, wall_s=0.0, sequence=1) is None
    assert check.admit(sec, nanosec, wall_s=0.01, sequence=2) == reason
    assert check.counts[reason] == 1
    assert sum(check.counts.values()) == 1
    assert check.admit(100, 100_000_000, wall_s=0.02, sequence=3) is None  # and the clock goes on


def test_a_single_forged_jump_costs_one_message_and_a_real_restart_one():
    check = _check()
    assert check.admit(100, 0, wall_s=0.0, sequence=1) is None
    assert check.admit(3700, 0, wall_s=0.1, sequence=2) == "unconfirmed_jump"  # an hour ahead, alone
    assert check.admit(100, 200_000_000, wall_s=0.2, sequence=3) is None         # contradicted: back on the timeline
    assert check.admit(50, 0, wall_s=0.3, sequence=4) == "unconfirmed_jump"      # far back, alone
    assert check.admit(100, 400_000_000, wall_s=0.4, sequence=5) is None
    # A restarted simulation: back, and the next message confirms the new timeline.
    assert check.admit(0, 100_000_000, wall_s=0.5, sequence=6) == "unconfirmed_jump"
    assert check.admit(0, 200_000_000, wall_s=0.6, sequence=7) is None
    assert check.admit(0, 300_000_000, wall_s=0.7, sequence=8) is None
    assert check.counts["unconfirmed_jump"] == 3


def test_a_second_clock_publisher_is_another_source_whatever_it_says():
    check = _check()
    for k in range(1, 50):  # the real clock, sequence 1 … 49 at 10 Hz
        assert check.admit(100 + k // 10, (k % 10) * 100_000_000, wall_s=k * 0.1, sequence=k) is None
    # A neighbour's stream an hour ahead, numbering from 1, interleaved with the real clock.
    for k in range(1, 30):
        assert check.admit(3700 + k, 0, wall_s=5.0 + k * 0.1, sequence=k) == "other_source"
        assert check.admit(105 + k // 10, (k % 10) * 100_000_000, wall_s=5.0 + k * 0.1 + 0.05,
                           sequence=49 + k) is None
    assert check.counts["other_source"] == 29 and check.sources.sources_heard(7.9) == 2
    assert set(check.counts) == set(CLOCK_REJECTIONS)


def test_the_first_clock_is_given_up_after_a_second_of_silence():
    """A restarted clock publisher (kill -9, start again) is followed again once the old one is silent."""
    check = _check()
    for k in range(1, 20):
        assert check.admit(100, k * 1000, wall_s=k * 0.1, sequence=1000 + k) is None
    assert check.admit(0, 100, wall_s=2.0, sequence=5) == "other_source"  # within the timeout: still the old
    assert check.admit(0, 200, wall_s=3.5, sequence=6) == "unconfirmed_jump"  # old one silent: new source, back
    assert check.admit(0, 300, wall_s=3.6, sequence=7) is None
