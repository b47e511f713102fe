"""The live statistics as numbers a plotter draws: /pmv/residual_mean, _sigma, _limit (interfaces.md "Topics").

Each is a Vector3Stamped (x roll, y pitch, z meridional, rad) published with every /pmv/error_statistics,
carrying the very numbers that message prints in arcmin; a statistic not defined yet reads "pending" there
(NaN on the numeric topic, a gap in a plot), never "nan".
"""

from __future__ import annotations

import math

import pytest

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node

import pmv_msgs_shim as shim
from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import CircularOrbit

KEYS = {"/pmv/residual_mean": "mean_arcmin", "/pmv/residual_sigma": "sigma_arcmin",
        "/pmv/residual_limit": "three_sigma_arcmin"}


@pytest.mark.long
def test_numeric_statistics_equal_the_diagnostic_array_to_the_digits_printed_and_nothing_reads_nan(run_long):
    # 1.2 orbits with --run-long (the harmonics turn from "pending" to numbers after the first); by
    # default the first quarter orbit, all of it pending harmonics.
    rate_hz = 0.2  # an orbit of 500 km (5677 s) in ≈ 1140 samples
    period_s = CircularOrbit(altitude_m=500e3, inclination_rad=math.radians(74.5)).period_s
    steps = int((1.2 if run_long else 0.25) * period_s * rate_hz)
    overrides = {"sensor.rate_hz": rate_hz, "sensor.detector": "ideal", "statistics_rate_hz": 0.02}
    with Pipeline(None, overrides, collect=False) as pipeline:
        probe = Node("probe", context=pipeline.context)
        got = {topic: [] for topic in ("/pmv/error_statistics", *KEYS)}
        for topic, received in got.items():
            kind = DiagnosticArray if topic == "/pmv/error_statistics" else Vector3Stamped
            probe.create_subscription(kind, topic, received.append, 1000)
        pipeline.executor.add_node(probe)
        pipeline.nodes.append(probe)
        pipeline.step(steps)
    statistics = got["/pmv/error_statistics"]
    assert len(statistics) >= 5 and all(len(got[topic]) == len(statistics) for topic in KEYS)
    pending_seen = numbers_seen = 0
    for index, message in enumerate(statistics):
        stamp_s = shim.time_from_msg(message.header.stamp)
        channels = {status.name.removeprefix(shim.STATISTICS_STATUS_PREFIX): {kv.key: kv.value for kv in status.values}
                    for status in message.status}
        for status_values in channels.values():
            assert "nan" not in [v.lower() for v in status_values.values()], status_values
        first_orbit = stamp_s < period_s
        harmonics = [v for k, v in channels["pitch"].items() if k.startswith("harmonic_k")]
        assert harmonics and all(v == shim.PENDING for v in harmonics) == first_orbit, (stamp_s, harmonics)
        for topic, key in KEYS.items():
            vector = got[topic][index]
            assert vector.header.stamp == message.header.stamp
            for channel, value in zip(("roll", "pitch", "meridional"), (vector.vector.x, vector.vector.y,
                                                                         vector.vector.z)):
                printed = channels[channel][key]
                if printed == shim.PENDING:
                    pending_seen += 1
                    assert math.isnan(value)
                else:  # the digits printed are repr(value in arcmin): the same float, to the last digit
                    numbers_seen += 1
                    assert repr(value / ARCMIN_RAD) == printed, (topic, channel, value, printed)
    assert numbers_seen > 40
    print(f"{len(statistics)} statistics messages over {steps / rate_hz:.0f} s: {numbers_seen} numbers equal to "
          f"the digits printed, {pending_seen} pending (NaN on the numeric topics)")
