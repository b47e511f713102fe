"""orbit.source follow (issue 21): the sensor flies the user's orbit/odometry.

The user's stack is played by an eccentric orbit (e = 0.01, perigee 700 km:
the altitude swings by ≈ 143 km over an orbit) published as nav_msgs
odometry at 5 Hz on its own stamps, 0.07 s off the sensor's grid, and up to
0.5 s behind the sample it is needed for (the newest states are carried on
by two-body motion). The reference is the same orbit flown internally
(:class:`pmv_ros.physics.orbit.two_body.KeplerOrbit`) through the node's own
instrument model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from nav_msgs.msg import Odometry

import pmv_msgs_shim as shim
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import CircularOrbit, KeplerOrbit
from pmv_ros.physics.instrument.sensor import SensorModel
from pmv_ros.runtime.common import parameters
from pmv_ros.runtime.common.assembly import SENSOR_PARAMS, build_models

ECCENTRIC = KeplerOrbit(700e3, 0.01, math.radians(98.8), 0.4, math.radians(45.0), 0.0, 0.0)
FOLLOW = {"orbit.source": "follow", "orbit.altitude_km": 771.0, "sim.fast_time": True, "sensor.rate_hz": 1.0,
          "sensor.detector": "ideal", "attitude.roll_amplitude_arcmin": 20.0, "attitude.pitch_amplitude_arcmin": 15.0,
          "attitude.oscillation_period_s": 300.0, "diagnostics_period_s": 1.0}


def _odometry(t_s: float, orbit=ECCENTRIC, frame: str = "eci") -> Odometry:
    position, velocity = orbit.state_eci(t_s)
    return shim.write_orbit_state(Odometry(), t_s, frame, "orbital", tuple(position), tuple(velocity))


def _statuses(diagnostics, name="pmv_ros/sensor_node: horizon"):
    return [status for message in diagnostics for status in message.status if status.name == name]


def _fly(h, seconds: float, odometry_until=lambda t_s: t_s - 0.5, bad=()):
    """Step the sensor ``seconds`` at 1 Hz, the odometry published at 5 Hz up to ``odometry_until(t)`` first."""
    if not hasattr(h, "odometry"):  # one publisher: a second one would be a second source (refused)
        h.odometry, h.next_odometry_s = h.publisher(Odometry, "/orbit/odometry"), 0.07
    publisher, state = h.odometry, h.next_odometry_s
    for _ in range(int(seconds)):
        t_next = h.node.sim_time_s + 1.0
        while state <= odometry_until(t_next):
            publisher.publish(_odometry(state))
            for message in bad:
                publisher.publish(message(state))
            state += 0.2
        h.drain()
        h.node.step()
        h.drain()
    h.next_odometry_s = state


def test_the_sensor_measures_on_the_users_eccentric_orbit(harness):
    h = harness(SensorNode, FOLLOW, external_drive=True)
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    _fly(h, 1200)
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in attitude])
    sensed = np.array([[m.vector.x, m.vector.y] for m in attitude])
    assert stamps.size == 1200 and np.allclose(np.diff(stamps), 1.0)
    # The orbit/odometry topic is the user's: the sensor only reads it.
    assert [info.node_name for info in h.tester.get_publishers_info_by_topic("/orbit/odometry")] == ["tester"]
    # The same samples through the instrument the same parameters build, on the orbit itself.
    _, profile, model = build_models(parameters.preset_values({}, "sensor_node", SENSOR_PARAMS, FOLLOW))

    def sensed_on(orbit):
        reading = SensorModel(orbit, model.config, model.detector).sense(stamps, profile.quaternion(stamps))
        return np.stack([reading.sensed_roll_rad, reading.sensed_pitch_rad], axis=1)

    reference = sensed_on(ECCENTRIC)
    # Hermite between 5 Hz states and ≤ 0.5 s of two-body carry: ≪ 1 mm of position, ≪ 1e-6′ of angle.
    assert np.max(np.abs(sensed - reference)) / ARCMIN_RAD < 1e-4
    # The figure: statistics equal within 0.05′ (σ) — here equal to far better.
    for k in range(2):
        assert abs(np.std(sensed[:, k]) - np.std(reference[:, k])) / ARCMIN_RAD < 0.05
    # And the node did follow the orbit's altitude, not the nominal one: on the circular orbit of the nominal
    # 771 km (the same plane and phase at the start) the same samples read differently, by far more.
    nominal = CircularOrbit(771e3, ECCENTRIC.inclination_rad, ECCENTRIC.raan_rad, ECCENTRIC.arg_latitude_at_epoch_rad)
    apart = np.max(np.abs(sensed - sensed_on(nominal))) / ARCMIN_RAD
    print(f"followed vs internal: {np.max(np.abs(sensed - reference)) / ARCMIN_RAD:.2e}′; "
          f"vs the nominal circle: {apart:.2f}′")
    assert apart > 0.1


def test_stale_odometry_stops_the_output_with_an_error_and_bad_odometry_is_refused(harness):
    h = harness(SensorNode, FOLLOW, external_drive=True)
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    hyperbolic = KeplerOrbit(700e3, 0.0, 0.0)

    def escaping(t_s):  # 1.5 × the circular speed: no bound orbit
        position, velocity = hyperbolic.state_eci(t_s)
        return shim.write_orbit_state(Odometry(), t_s + 0.01, "eci", "orbital", tuple(position), tuple(1.5 * velocity))

    bad = (lambda t_s: _odometry(t_s + 0.01, frame="ecef"), escaping)
    _fly(h, 20, bad=bad)
    assert len(attitude) == 20
    levels = [s.level for s in _statuses(diagnostics)]
    assert levels and max(levels) == b"\x01"  # bad odometry is refused and said (WARN), as bad truth is
    assert any("rejected /orbit/odometry messages" in s.message for s in _statuses(diagnostics))
    counters = {kv.key: kv.value for kv in _statuses(diagnostics)[-1].values}
    assert int(counters["rejected_odometry_wrong_frame"]) == int(counters["rejected_odometry_implausible_orbit"]) > 90
    # The user's stack stops: 2 s of two-body carry, then nothing and an ERROR.
    stopped_at = h.next_odometry_s - 0.2
    _fly(h, 10, odometry_until=lambda t_s: -1.0)
    published = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in attitude]
    assert max(published) <= stopped_at + 2.0 + 1e-6 and len(published) < 20 + 10
    stale = _statuses(diagnostics)[-1]
    assert stale.level == b"\x02" and "stale" in stale.message, stale.message
    # It comes back: the samples it covers are measured, OK again.
    h.next_odometry_s = h.node.sim_time_s - 1.0
    _fly(h, 5)
    assert max(m.header.stamp.sec for m in attitude) == int(h.node.sim_time_s)
    assert _statuses(diagnostics)[-1].level == b"\x00"


def test_a_sensor_following_an_orbit_is_refused_by_nothing_else(harness):
    # orbit.source follow builds at start-up (no odometry yet): no output, a WARN, no ERROR, no exception.
    h = harness(SensorNode, FOLLOW, external_drive=True)
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    for _ in range(3):
        h.node.step()
        h.drain()
    assert not attitude
    status = _statuses(diagnostics)[-1]
    assert status.level == b"\x01" and "no orbit" in status.message, status.message


@pytest.mark.parametrize("name, value", [("orbit.extrapolation_s", 61.0), ("orbit.follow_timeout_s", 0.0)])
def test_follow_parameters_are_bounded(harness, name, value):
    from pmv_ros.nodes.params import ParameterError

    with pytest.raises(ParameterError, match=name):
        harness(SensorNode, {**FOLLOW, name: value}, external_drive=True)
