"""The watch on a simulation clock that stops (interfaces.md "Time"), ROS-free."""

from __future__ import annotations

import pytest

from pmv_ros.runtime.common.clock_watch import CLOCK_STALL_S, ClockWatch
from pmv_ros.runtime.common.records import Level


def test_a_clock_standing_longer_than_the_stall_time_warns_at_each_reading_and_is_ok_once_when_it_moves():
    watch = ClockWatch(CLOCK_STALL_S)
    assert watch.observe(0.0, 100.0) is None and watch.observe(0.0, 110.0) is None  # no /clock yet: not a stall
    assert watch.observe(5.0, 110.5) is None
    assert watch.observe(5.0, 110.5 + CLOCK_STALL_S - 0.01) is None
    for wall in (110.5 + CLOCK_STALL_S, 115.0):
        report = watch.observe(5.0, wall)
        assert report.level is Level.WARN and "5.000 s" in report.message
    assert watch.stalled and watch.stalls == 1
    report = watch.observe(5.5, 115.2)
    assert report.level is Level.OK and "moves again" in report.message and not watch.stalled
    assert report.values == {"clock_stalls": 1}
    assert watch.observe(6.0, 115.4) is None  # moving: nothing to say
    assert watch.observe(6.0, 116.0 + CLOCK_STALL_S).level is Level.WARN and watch.stalls == 2
    with pytest.raises(ValueError, match="stall time"):
        ClockWatch(0.0)
