"""Refused requests counted whole and said sparingly (pmv_ros.runtime.common.refusals.RefusalTally)."""

from __future__ import annotations

from pmv_ros.runtime.common.refusals import REFUSAL_LOG_PERIOD_S, RefusalTally


def test_a_storm_of_refusals_is_counted_whole_and_said_once_a_period():
    tally = RefusalTally("a parameter update", period_s=60.0)
    said = [tally.refuse(f"reason {k}", now_s=0.001 * k) for k in range(5000)]  # 5 s of 1,000 a second
    assert tally.count == 5000
    assert [line for line in said if line] == ["refused a parameter update: reason 0"]
    line = tally.refuse("reason late", now_s=61.0)  # the next period: one line with the count since
    assert line.startswith("refused a parameter update: reason late (5000 refused since the last line, 5001 in all")
    assert tally.refuse("again", now_s=62.0) is None and tally.count == 5002


def test_the_default_period_says_a_storm_once_a_minute():
    tally = RefusalTally("a parameter update")
    assert tally.refuse("first", now_s=0.0) == "refused a parameter update: first"
    assert tally.refuse("inside", now_s=REFUSAL_LOG_PERIOD_S - 1e-3) is None
    assert tally.refuse("after", now_s=REFUSAL_LOG_PERIOD_S).startswith("refused a parameter update: after (2 refused")
