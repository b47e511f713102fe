"""``sensor_node``: the PMV horizon sensor in a ROS 2 graph.

Propagates the orbit on the ROS clock (or on its own simulation clock in
fast-time mode, publishing ``/clock``), takes the body attitude from its own
profile (published on ``/attitude/truth``) or follows the user's
``/attitude/truth``, runs the four chords through the instrument model and
publishes crossings, roll/pitch (corrected and uncorrected), odometry and
health. All physics is in :mod:`pmv_ros.core`; all message layout in
:mod:`pmv_msgs_shim`.

Chord faults (issue 6): a chord whose half-plane has no horizon (a large
attitude excursion), whose scan found no crossing, or that has the Sun or the
Moon within ``sensor.bright_body_exclusion_deg`` of its swept arc is invalid:
its point on ``/pmv/horizon_crossings`` is NaN, and the angle of its pair
(roll for ±Y, pitch for ±X) is NaN on ``/pmv/attitude`` — the other pair's
angle is still published. ``/diagnostics`` names the chord and the cause
(and the body) as soon as the condition starts and again when it ends; the
chord is used again by itself as soon as it is valid.

Follow mode validates ``/attitude/truth``: non-finite or far-from-unit
quaternions, zero, future, duplicate and backward stamps are dropped and
counted per reason on ``/diagnostics`` (a stamp older than the latest by more
than ``attitude.follow_timeout_s`` is a restarted source and accepted).

QoS: outputs are reliable, keep-last 100 — deep enough for a fast-time
pipeline that is drained every tick, bounded in memory.
"""

from __future__ import annotations

import math
import sys
from collections import deque

import numpy as np
from geometry_msgs.msg import PolygonStamped, QuaternionStamped, Vector3Stamped
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg

import pmv_msgs_shim as shim
from .base import PmvNode
from ..core.assembly import SENSOR_PARAMS as PARAMS, build_models
from ..core.geometry import CHORD_NAMES
from ..core.monitor import Status, validate_quaternion
from ..core.sensor import BRIGHT_BODIES, ChordStatus
from .launch import run_node
from .params import ParameterError, declare, install_validation


#: | |q| − 1 | up to which a followed truth quaternion is normalised; beyond it is rejected.
QUATERNION_NORM_TOLERANCE = 0.01

#: Samples computed per call of the instrument model in fast time with the
#: own attitude profile (amortises numpy overhead; the output is identical).
#: 512 samples cost ≈ 35 µs each against ≈ 70 µs in blocks of 64; a parameter
#: change discards the block.
FAST_TIME_BLOCK = 512

#: Paced fast time (sim.time_scale > 0): a block should take no longer than one
#: tick period, or /clock stops while it is computed (512 samples: ≈ 20–45 ms).
#: Blocks are sized with this cost per sample, the slow end of what these
#: machines do, and kept between 16 samples and FAST_TIME_BLOCK.
PACED_SAMPLE_COST_S = 100e-6


class SensorNode(PmvNode):
    """The PMV sensor: orbit + attitude → 4-chord crossings and roll/pitch.

    Args:
        external_drive: fast time stepped by the caller through :meth:`step`
            (``pmv simulate``) instead of by the node's own wall-clock timer.
    """

    def __init__(self, *, external_drive: bool = False, **kwargs):
        super().__init__("sensor_node", **kwargs)
        self._values = declare(self, PARAMS)
        self._external_drive = external_drive
        self._values["_epoch_s"] = self.get_clock().now().nanoseconds * 1e-9
        try:
            self._rebuild(self._values)
        except ValueError as error:  # a combination, a date or a file the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild_live)

        self._pub_crossings = self.publisher(PolygonStamped, "/pmv/horizon_crossings")
        self._pub_attitude = self.publisher(Vector3Stamped, "/pmv/attitude")
        self._pub_attitude_raw = self.publisher(Vector3Stamped, "/pmv/attitude_uncorrected")
        self._pub_odometry = self.publisher(Odometry, "/orbit/odometry")
        self._pub_diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self._pub_truth = None
        self._pub_clock = None
        self._latest_truth = None  # (stamp_s, unit q) in follow mode
        self._chord_problem_counts = [[0] * 4 for _ in ChordStatus]  # [status][chord]
        self._rejected = {}  # reason → count (fixed set of reasons: bounded)
        self._rejected_reported = 0
        self._samples_published = 0
        self._last_diagnostics_s = -math.inf
        self._last_condition = ()  # what the last /diagnostics said, to report changes at once
        self._pending = deque()  # precomputed fast-time samples
        # One message per topic, filled in place for every sample (rclpy serialises at publish).
        self._out = dict(truth=QuaternionStamped(), odometry=Odometry(), crossings=PolygonStamped(),
                         attitude=Vector3Stamped(), attitude_raw=Vector3Stamped(), clock=ClockMsg(),
                         diagnostics=DiagnosticArray())
        if self._values["attitude.source"] == "profile":
            self._pub_truth = self.publisher(QuaternionStamped, "/attitude/truth")
        else:
            self.subscription(QuaternionStamped, "/attitude/truth", self._on_truth)

        self._sim_time_s = self._values["sim.start_time_s"]
        self._timer = None
        if self._values["sim.fast_time"]:
            self._pub_clock = self.publisher(ClockMsg, "/clock")
            if not external_drive:
                self._start_fast_timer(self._values)
        else:
            self._timer = self.create_timer(1.0 / self._values["sensor.rate_hz"], self._on_real_time_tick)
        self.get_logger().info(
            f"sensor_node: H = {self._values['orbit.altitude_km']:g} km, i = {self._values['orbit.inclination_deg']:g}°, "
            f"{self._values['sensor.rate_hz']:g} Hz, attitude from {self._values['attitude.source']}, "
            f"{'fast time' if self._values['sim.fast_time'] else 'real time'}")

    # -- parameters ---------------------------------------------------------------------------

    def _rebuild(self, values: dict) -> None:
        self._orbit, self._profile, self._model = build_models(values)

    def _rebuild_live(self, values: dict) -> None:
        for fixed in ("attitude.source", "sim.fast_time"):
            if values[fixed] != self._values[fixed]:
                raise ValueError(f"{fixed} cannot change while the node runs (restart the node to change it)")
        if values["sim.fast_time"]:
            values = dict(values, **{"sim.start_time_s": self._values["sim.start_time_s"]})
        self._rebuild(values)
        self._pending.clear()
        timing = ("sensor.rate_hz", "sim.time_scale")
        if self._timer is not None and any(values[name] != self._values[name] for name in timing):
            self._timer.cancel()
            self.destroy_timer(self._timer)
            if values["sim.fast_time"]:
                self._start_fast_timer(values)
            else:
                self._timer = self.create_timer(1.0 / values["sensor.rate_hz"], self._on_real_time_tick)

    def _start_fast_timer(self, values: dict) -> None:
        scale = values["sim.time_scale"]
        period = 0.0 if scale == 0.0 else 1.0 / (values["sensor.rate_hz"] * scale)
        self._timer = self.create_timer(period, self.step, clock=Clock(clock_type=ClockType.STEADY_TIME))

    # -- inputs ---------------------------------------------------------------------------------

    def _now_s(self) -> float:
        """Now on the sensor's own clock: simulation time in fast time, the node clock otherwise."""
        if self._values["sim.fast_time"]:
            return self._sim_time_s
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_truth(self, message: QuaternionStamped) -> None:
        """Follow mode: keep the latest valid truth; drop and count bad messages."""
        try:
            record = shim.attitude_quaternion_from_msg(message)
        except ValueError:  # negative or non-finite stamp
            self._count_rejected(f"rejected_truth_{Status.ZERO_STAMP.value}")
            return
        q, status, _ = validate_quaternion(record.q_xyzw, QUATERNION_NORM_TOLERANCE)
        t_s, timeout = record.stamp_s, self._values["attitude.follow_timeout_s"]
        latest = self._latest_truth
        if status is Status.OK:
            if t_s <= 0.0:
                status = Status.ZERO_STAMP
            elif t_s > self._now_s() + timeout:
                status = Status.FUTURE_STAMP
            elif latest is not None and t_s == latest[0]:
                status = Status.DUPLICATE
            elif latest is not None and latest[0] - timeout <= t_s < latest[0]:
                # Older by more than the timeout: the source restarted on a new clock; take it.
                status = Status.BACKWARDS
        if status is not Status.OK:
            self._count_rejected(f"rejected_truth_{status.value}")
            return
        self._latest_truth = (t_s, q)

    def _count_rejected(self, reason: str) -> None:
        self._rejected[reason] = self._rejected.get(reason, 0) + 1

    # -- ticks ----------------------------------------------------------------------------------

    @property
    def sim_time_s(self) -> float:
        """Current simulation time of the fast-time clock, s."""
        return self._sim_time_s

    def step(self) -> None:
        """Fast time: advance the simulation clock by one sensor period and publish that sample."""
        period = 1.0 / self._values["sensor.rate_hz"]
        self._sim_time_s += period
        self._pub_clock.publish(shim.write_clock(self._out["clock"], self._sim_time_s))
        if self._values["attitude.source"] == "profile":
            if not self._pending:
                times = self._sim_time_s + period * np.arange(self.fast_time_block)
                self._pending = deque(self._sense_block(times, self._profile.quaternion(times)))
            self._publish_sample(*self._pending.popleft())
        else:
            self._sense_following(self._sim_time_s)

    @property
    def fast_time_block(self) -> int:
        """Samples the instrument model computes per call in fast time (see PACED_SAMPLE_COST_S).

        Stepped by a caller (the in-process pipeline) or as fast as possible:
        FAST_TIME_BLOCK; paced by the node's own timer: no longer than a tick.
        """
        scale = self._values["sim.time_scale"]
        if scale == 0.0 or self._external_drive:
            return FAST_TIME_BLOCK
        tick_s = 1.0 / (self._values["sensor.rate_hz"] * scale)
        return max(16, min(FAST_TIME_BLOCK, int(tick_s / PACED_SAMPLE_COST_S)))

    def _on_real_time_tick(self) -> None:
        now_s = self.get_clock().now().nanoseconds * 1e-9
        if self._values["attitude.source"] == "profile":
            times = np.array([now_s])
            self._publish_sample(*self._sense_block(times, self._profile.quaternion(times))[0])
        else:
            self._sense_following(now_s)

    def _sense_following(self, t_s: float) -> None:
        truth = self._latest_truth
        if truth is None or abs(t_s - truth[0]) > self._values["attitude.follow_timeout_s"]:
            self._count_rejected("skipped_no_fresh_truth")
            self._maybe_publish_diagnostics(t_s)
            return
        self._publish_sample(*self._sense_block(np.array([t_s]), truth[1][:, None])[0])

    def _sense_block(self, times: np.ndarray, q: np.ndarray) -> list:
        """Run the instrument for a block of samples; a list of per-sample tuples of plain values to publish.

        The arrays become Python floats and tuples here, once per block: the
        per-sample publishing path then does no numpy indexing.
        """
        reading = self._model.sense(times, q)
        position, velocity = self._orbit.state_eci(times)
        status = reading.chord_status
        blinding = reading.blinding_body
        valid = (status == ChordStatus.VALID).T
        # What a HorizonCrossings record would hold (NaN rows for invalid chords), checked for the whole block.
        line_of_sight = shim.checked_lines_of_sight(reading.line_of_sight_sensor.transpose(2, 1, 0), valid)
        columns = (
            times.tolist(),
            q.T.tolist(),
            line_of_sight.tolist(),
            reading.sensed_roll_rad.tolist(),
            reading.sensed_pitch_rad.tolist(),
            reading.sensed_roll_uncorrected_rad.tolist(),
            reading.sensed_pitch_uncorrected_rad.tolist(),
            status.T.tolist(),
            (np.full_like(status, -1) if blinding is None else blinding).T.tolist(),
            position.T.tolist(),
            velocity.T.tolist(),
        )
        return list(zip(*columns))

    def _publish_sample(self, t_s, q, line_of_sight, roll, pitch, roll_raw, pitch_raw, status, blinding,
                        position, velocity) -> None:
        out = self._out
        if self._pub_truth is not None:
            self._pub_truth.publish(shim.write_attitude_quaternion(out["truth"], t_s, shim.ORBITAL_FRAME, q))
        self._pub_odometry.publish(shim.write_orbit_state(out["odometry"], t_s, shim.ECI_FRAME, shim.BODY_FRAME,
                                                          position, velocity))
        self._pub_crossings.publish(shim.write_horizon_crossings(out["crossings"], t_s, shim.SENSOR_FRAME,
                                                                 line_of_sight))
        self._pub_attitude.publish(shim.write_attitude_angles(out["attitude"], t_s, shim.SENSOR_FRAME, roll, pitch))
        self._pub_attitude_raw.publish(shim.write_attitude_angles(out["attitude_raw"], t_s, shim.SENSOR_FRAME,
                                                                  roll_raw, pitch_raw))
        for chord, code in enumerate(status):
            self._chord_problem_counts[code][chord] += 1
        self._samples_published += 1
        self._maybe_publish_diagnostics(t_s, status, blinding)

    def _chord_problems(self, status, blinding) -> list[str]:
        """One phrase per invalid chord: which chord, and why."""
        problems = []
        for chord, code, body in zip(CHORD_NAMES, status, blinding):
            if code == ChordStatus.SUN_OR_MOON:
                problems.append(f"chord {chord}: {BRIGHT_BODIES[body]} in the field of view (within "
                                f"{self._values['sensor.bright_body_exclusion_deg']:g} deg)")
            elif code == ChordStatus.NO_HORIZON:
                problems.append(f"chord {chord}: no horizon in the scan")
            elif code == ChordStatus.NOT_DETECTED:
                problems.append(f"chord {chord}: no crossing detected")
        return problems

    def _maybe_publish_diagnostics(self, t_s: float, status=None, blinding=None) -> None:
        """Publish /diagnostics every diagnostics_period_s, and at once when the chords' condition changes."""
        condition = () if status is None else (tuple(status), tuple(blinding))
        due = (t_s - self._last_diagnostics_s >= self._values["diagnostics_period_s"]
               or t_s < self._last_diagnostics_s)  # the clock went back: a new run
        if not due and condition == self._last_condition:
            return
        self._last_diagnostics_s = t_s
        self._last_condition = condition
        problems = [] if status is None else self._chord_problems(status, blinding)
        values = {"samples_published": self._samples_published}
        if status is not None:
            values.update({f"chord_{chord}": ChordStatus(int(code)).name.lower()
                           for chord, code in zip(CHORD_NAMES, status)})
        for code in ChordStatus:
            if code != ChordStatus.VALID:
                for chord, count in zip(CHORD_NAMES, self._chord_problem_counts[code]):
                    if count:
                        values[f"{code.name.lower()}_{chord}"] = int(count)
        values.update(self._rejected)
        rejected_total = sum(n for reason, n in self._rejected.items() if reason.startswith("rejected_"))
        fresh_rejections = rejected_total > self._rejected_reported
        self._rejected_reported = rejected_total
        if status is None:
            problems.append("no sample: no fresh /attitude/truth to follow")
        elif fresh_rejections:
            problems.append("rejected /attitude/truth messages")
        level = shim.Level.WARN if problems else shim.Level.OK
        message = "; ".join(problems) if problems else "all chords valid"
        report = shim.HealthReport(stamp_s=t_s, statuses=(shim.HealthStatus(
            name="pmv_ros/sensor_node: horizon", level=level, message=message, hardware_id="pmv", values=values),))
        self._pub_diagnostics.publish(shim.write_health(self._out["diagnostics"], report))


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros sensor_node``."""
    return run_node(SensorNode, "sensor_node", args)


if __name__ == "__main__":
    sys.exit(main())
