"""The error monitor's runtime without ROS: inputs refused or fed, residuals, the statistics schedule, health."""

from __future__ import annotations

import math

import numpy as np
import yaml

from flights import REPO
from pmv_ros.analysis.statistics import CHANNELS
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import CircularOrbit
from pmv_ros.runtime.flight import flight_values
from pmv_ros.runtime.monitor.runtime import STATISTICS_VECTORS, MonitorRuntime, oblateness_override
from pmv_ros.runtime.common.records import Level


def values_of(overrides: dict | None = None):
    document = yaml.safe_load((REPO / "config" / "kondor.yaml").read_text())
    return flight_values(document, overrides)


def test_the_oblateness_override_is_zero_only_when_the_sensor_removes_it_on_board():
    assert oblateness_override({"sensor.oblateness_compensation": False}) == {}
    assert oblateness_override({"sensor.oblateness_compensation": True}) == {
        "oblateness_roll_rad": 0.0, "oblateness_pitch_rad": 0.0}


def test_residuals_statistics_schedule_and_health_of_the_monitor():
    values = values_of({"statistics_rate_hz": 0.5}).monitor
    problems = []
    runtime = MonitorRuntime(values, source_problems=lambda: list(problems), source_counters=dict)
    frames = runtime.frames
    orbit = CircularOrbit(values["orbit.altitude_km"] * 1e3, math.radians(values["orbit.inclination_deg"]))
    # Refused before the monitor: another frame, or unreadable.
    runtime.add_sensor("eci", 1.0, 0.0, 0.0, 1.0)
    runtime.add_truth(frames.orbital, None, None, 1.0)
    runtime.add_odometry(frames.eci, "body", None, 1.0)
    assert runtime.rejected_messages == {**{k: 0 for k in runtime.rejected_messages},
                                         "rejected_sensor_wrong_frame": 1, "rejected_truth_unreadable": 1,
                                         "rejected_odometry_wrong_frame": 1}
    first = runtime.health(1.0)
    assert first.level is Level.WARN and "rejected input messages" in first.message
    assert "rejected input messages" not in runtime.health(1.0).message  # said once per new rejection
    offset_rad = 1.5 * ARCMIN_RAD
    residuals, statistics = [], []
    for k in range(100):
        t_s = 10.0 + 0.1 * k
        position, velocity = orbit.state_eci(t_s)
        runtime.add_odometry(frames.eci, frames.orbital, (t_s, position, velocity), t_s)
        truth = runtime.add_truth(frames.orbital, t_s, quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.0), t_s)
        residuals += truth.residuals
        out = runtime.add_sensor(frames.sensor, t_s, offset_rad, -offset_rad, t_s)
        residuals += out.residuals
        if out.statistics is not None:
            statistics.append(out.statistics)
    assert len(residuals) >= 95
    np.testing.assert_allclose([r.residual_roll_rad for r in residuals], offset_rad, atol=1e-12)
    np.testing.assert_allclose([r.residual_pitch_rad for r in residuals], -offset_rad, atol=1e-12)
    stamps = [s.stamp_s for s in statistics]
    assert stamps[0] == 10.0 and np.allclose(np.diff(stamps), 2.0)  # 0.5 Hz of sample time
    last = statistics[-1]
    for name, statistic in STATISTICS_VECTORS.items():
        assert last.vectors[name] == tuple(getattr(last.summary.channel(c), statistic) for c in CHANNELS)
    problems.append("2 publishers of /pmv/attitude")
    health = runtime.health(20.0)
    assert health.level is Level.ERROR and health.values["used"] == runtime.monitor.counters["used"] > 0
    runtime.reconfigure(values)  # new statistics: the next sample publishes at once
    assert runtime.add_sensor(frames.sensor, 21.0, 0.0, 0.0, 21.0).statistics.stamp_s == 21.0
