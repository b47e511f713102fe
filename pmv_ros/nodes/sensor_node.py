"""``sensor_node``: the PMV horizon sensor in a ROS 2 graph.

Propagates the orbit on the ROS clock (or on its own simulation clock in
fast-time mode, publishing ``/clock``), takes the body attitude from its own
profile (published on ``/attitude/truth``) or follows the user's
``/attitude/truth``, runs the four chords through the instrument model and
publishes crossings, roll/pitch (REP-103, corrected and uncorrected), the
same as an orientation with covariance for estimators (``pmv/attitude_imu``,
:mod:`pmv_ros.runtime.estimator_output`), odometry and health. The work
in :mod:`pmv_ros.runtime` and :mod:`pmv_ros.physics`, message layout in
:mod:`pmv_msgs_shim`, health in :mod:`pmv_ros.runtime.sensor_health`.

A chord without a horizon, without a crossing, or with the Sun or the Moon
near its arc is invalid: its point is NaN and so is its pair's angle (roll
for ±Y, pitch for ±X); ``/diagnostics`` names the chord and the cause.

Follow mode (``attitude.source: follow``; README "Follow mode") never
publishes ``/attitude/truth``. It measures with the attitude at its own
sample time (:class:`pmv_ros.runtime.truth_buffer.TruthBuffer`: slerp between
truth samples, the last body rate for ``attitude.extrapolation_periods`` truth
periods past the newest, and up to ``attitude.extrapolation_s`` to bridge a
late truth sample, counted ``truth_bridged``), stamps
the output with that time, and publishes nothing from stale truth: the stale
state is an ERROR on ``/diagnostics`` at once and logged once. Bad truth
(non-finite, far-from-unit, zero, future, duplicate, backward, too-fast
stamps: :mod:`pmv_ros.runtime.validation`) is dropped and counted; a truth clock
that jumps back by more than ``attitude.follow_timeout_s`` starts a new
timeline once the next stamp confirms it. Truth stamped in another frame than
the orbital one (``frames.*``) is refused (``rejected_truth_wrong_frame``).
Only the first publisher of
``/attitude/truth`` heard is followed; a second one is an ERROR on
``/diagnostics`` (:class:`pmv_ros.runtime.validation.SourceLock`).

Topic names are relative (a namespace moves them), frames come from the
``frames.*`` parameters, the instrument scans in its own frame, turned on the
body by ``sensor.mounting_*`` (:mod:`pmv_ros.runtime.frames`), and the node
publishes its transforms on /tf and /tf_static when tf2_msgs is there
(:mod:`pmv_ros.nodes.tf`).

``sensor.correction`` is read once, at start-up, and is read-only: no
parameter change, and nothing from the network, makes the node read a file.
"""

from __future__ import annotations

import sys

import numpy as np

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import Imu

import pmv_msgs_shim as shim
from .base import PmvNode
from ..runtime.assembly import SENSOR_PARAMS as PARAMS, build_models, orbit_bounds, read_correction
from ..runtime.sample_stream import SampleGrid, SampleStream, SensorSample, fast_time_block
from ..runtime.estimator_output import estimator_orientation, variance_from_rms_arcmin
from ..runtime.sensor_health import SensorHealth, truth_source_warnings
from ..runtime.truth_buffer import PendingSamples, TruthAt, TruthBuffer
from ..runtime.frames import Frames, Mounting
from ..runtime.validation import (Jump, JumpDetector, Rejection, StampCheck, check_frame, check_orbit_state,
                                  check_quaternion_sample)
from ..physics.tle_orbit import OrbitPropagationError
from ..runtime.orbit_buffer import FollowedOrbit, OrbitAt
from .launch import run_node
from .managed import managed_factory, managed_requested
from .params import ParameterError, declare, install_validation
from .tf import NO_TF2_MSGS, SensorTransforms, tf_message_type




class SensorNode(PmvNode):
    """The PMV sensor: orbit + attitude → 4-chord crossings and roll/pitch.

    Args:
        external_drive: fast time stepped by the caller through :meth:`step`
            (``pmv simulate``) instead of by the node's own wall-clock timer.
        publish_tf: publish /tf and /tf_static (when tf2_msgs is there). The
            in-process pipeline turns it off unless it records: nothing else
            in its private graph listens, and every message per tick costs
            the main job time.
    """

    def __init__(self, *, external_drive: bool = False, publish_tf: bool = True, **kwargs):
        super().__init__("sensor_node", **kwargs)
        self._values = declare(self, PARAMS)
        self._external_drive = external_drive
        self._clock_epoch_s = self.get_clock().now().nanoseconds * 1e-9
        try:
            self._frames = Frames.from_values(self._values)
            self._correction = read_correction(self._values)  # the one file read: here, at start-up
            self._rebuild(self._values)
        except ValueError as error:  # a combination, a date or a file the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild_live)
        self._following = self._values["attitude.source"] == "follow"
        # Relative names: in a namespace, every topic of this spacecraft moves under it (interfaces.md "Topics").
        self._pub_crossings = self.publisher(PolygonStamped, "pmv/horizon_crossings")
        self._pub_attitude = self.publisher(Vector3Stamped, "pmv/attitude")
        self._pub_attitude_raw = self.publisher(Vector3Stamped, "pmv/attitude_uncorrected")
        self._pub_imu = self.publisher(Imu, "pmv/attitude_imu")
        # orbit.source follow: the user's stack owns orbit/odometry and the sensor flies it (runtime/orbit_buffer.py).
        self._orbit_following = self._values["orbit.source"] == "follow"
        self._orbit_problem = None  # orbit.source follow: (OrbitAt, message) while sample times have no orbit
        self._pub_odometry = None if self._orbit_following else self.publisher(Odometry, "orbit/odometry")
        self._pub_diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self.watch_clock(self._pub_diagnostics)
        self._pub_truth = self._pub_clock = None
        self._health = SensorHealth(self.resolve_topic_name("attitude/truth"),
                                    self.resolve_topic_name("orbit/odometry"))
        self._truth_state = None  # follow mode: where the last tick's attitude came from
        self._stale_logged = False  # follow mode: the stale truth was logged and has not come back since
        self._orbit_error = None  # an element set's orbit that SGP4 could not propagate: no output from then on
        self._graph_warnings, self._source_errors, self._graph_checked_s = (), (), None
        # Real time on a /clock someone else publishes: a tick on a single forged time is skipped, not measured.
        self._tick_clock = JumpDetector(1.0, forward_threshold_s=10.0)
        # One message per topic, filled in place for every sample (rclpy serialises at publish).
        self._out = dict(truth=QuaternionStamped(), odometry=Odometry(), crossings=PolygonStamped(),
                         attitude=Vector3Stamped(), attitude_raw=Vector3Stamped(), imu=Imu(), clock=ClockMsg(),
                         diagnostics=DiagnosticArray())
        if self._following:
            self.input_subscription(QuaternionStamped, "attitude/truth", self._on_truth,
                                    self._values["input.source_timeout_s"])
        else:
            self._pub_truth = self.publisher(QuaternionStamped, "attitude/truth")
        if self._orbit_following:
            timeout = self._values["orbit.follow_timeout_s"]
            self._odometry_stamps = StampCheck(timeout, timeout, 1.0 / self._values["input.max_rate_hz"])
            self.input_subscription(Odometry, "orbit/odometry", self._on_odometry,
                                    self._values["input.source_timeout_s"])
        self._sim_time_s = self._values["sim.start_time_s"]
        self._transforms = None
        tf_message = tf_message_type() if publish_tf else None
        if publish_tf and tf_message is None:
            self.get_logger().warning(NO_TF2_MSGS)
        elif tf_message is not None:
            self._transforms = SensorTransforms(self, tf_message, self._frames,
                                                Mounting.from_values(self._values).q_body_to_sensor,
                                                own_attitude=not self._following, stamp_s=self._now_s())
        self._waiting = PendingSamples()  # follow mode, real time: due sample times waiting for truth
        self._timer = None
        if self._values["sim.fast_time"]:
            self._pub_clock = self.publisher(ClockMsg, "/clock")
            if not external_drive:
                self._start_timer(self._values)
        else:
            self._start_timer(self._values)
        v, frames = self._values, self._frames
        pacing = ("fast time, publishing its own /clock" if v["sim.fast_time"]
                  else "paced by its clock, " + self.clock_name())
        self.get_logger().info(
            f"sensor_node: H = {v['orbit.altitude_km']:g} km, i = {v['orbit.inclination_deg']:g}°, "
            f"{v['sensor.rate_hz']:g} Hz, attitude from {v['attitude.source']}, {pacing}; "
            f"frames {frames.eci} → {frames.orbital} → {frames.base_link} → {frames.sensor}")

    # -- parameters ---------------------------------------------------------------------------

    def _rebuild(self, values: dict) -> None:
        orbit, profile, model = build_models(values, clock_epoch_s=self._clock_epoch_s, correction=self._correction)
        previous_orbit = self._stream.orbit if hasattr(self, "_stream") else None
        if isinstance(orbit, FollowedOrbit) and isinstance(previous_orbit, FollowedOrbit):  # it keeps its states
            orbit.buffer.take_states(previous_orbit.buffer)
        self._orbit_bounds = orbit_bounds(values)
        self._stream = SampleStream(model, orbit, profile, shim.checked_lines_of_sight)
        self._imu_variances = (variance_from_rms_arcmin(values["imu.roll_error_rms_arcmin"]),
                               variance_from_rms_arcmin(values["imu.pitch_error_rms_arcmin"]))
        # Real time: the sample times, on the grid of the orbit's epoch (the node clock at the start).
        period_s = 1.0 / values["sensor.rate_hz"]
        grid = getattr(self, "_grid", None)
        self._grid = SampleGrid(self._clock_epoch_s, period_s) if grid is None else grid.with_period(period_s)
        timeout = values["attitude.follow_timeout_s"]
        # Older by more than the timeout: the source restarted on a new clock (once the next stamp confirms it).
        stamps = getattr(self, "_truth_stamps", None) or StampCheck(timeout, timeout)
        self._truth_stamps = stamps.reconfigured(timeout, timeout, 1.0 / values["input.max_rate_hz"])
        for lock in self.source_locks.values():
            lock.timeout_s = values["input.source_timeout_s"]
        previous = getattr(self, "_truth", None)
        self._truth = TruthBuffer(values["attitude.extrapolation_periods"], values["attitude.follow_timeout_s"],
                                  bridge_s=values["attitude.extrapolation_s"])
        if previous is not None:  # a parameter change keeps the truth received so far
            self._truth.take_samples(previous)
        # Epoch and elements on every /diagnostics, so that recordings can be analysed (issue 13); a followed
        # orbit has none (the user's odometry is the record of it).
        self._orbit_status = None if values["orbit.source"] == "follow" else shim.orbit_elements_status(
            shim.OrbitElements.from_orbit(orbit, values["sim.epoch_utc"]), self.status_name("orbit"),
            self.hardware_id("pmv"))

    def _rebuild_live(self, values: dict) -> None:
        if values["sim.fast_time"]:
            values = dict(values, **{"sim.start_time_s": self._values["sim.start_time_s"]})
        self._rebuild(values)
        if self._timer is not None and any(values[k] != self._values[k] for k in ("sensor.rate_hz", "sim.time_scale")):
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._start_timer(values)

    def _start_timer(self, values: dict) -> None:
        if not values["sim.fast_time"]:
            self._timer = self.create_timer(1.0 / values["sensor.rate_hz"], self._on_real_time_tick)
            return
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
        """Follow mode: keep valid truth in the buffer; drop and count bad messages."""
        rejection = check_frame(message.header.frame_id, self._frames.orbital)  # an inertial quaternion, say
        if rejection is not None:
            self._health.count(f"rejected_truth_{rejection.value}")
            return
        try:
            record = shim.attitude_quaternion_from_msg(message)
        except ValueError:  # negative or non-finite stamp
            self._health.count(f"rejected_truth_{Rejection.ZERO_STAMP.value}")
            return
        sample = check_quaternion_sample(self._truth_stamps, record.stamp_s, record.q_xyzw, self._now_s())
        if sample.outliers:
            self._health.count("clock_outliers")
        if sample.jumped:
            self._health.count("clock_jumps")
            self._truth.clear()
        if sample.rejection is not None:
            self._health.count(f"rejected_truth_{sample.rejection.value}")
            return
        self._truth.add(record.stamp_s, sample.q_xyzw)
        if self._waiting and not self._values["sim.fast_time"]:  # sample times that waited for this truth
            self._sense_following(self._waiting.ready(self._truth, self._now_s()))

    def _on_odometry(self, message: Odometry) -> None:
        """orbit.source follow: keep the user's valid orbit states; drop and count bad messages."""
        frames = self._frames
        rejection = (check_frame(message.header.frame_id, frames.eci)
                     or check_frame(message.child_frame_id, frames.orbital))
        if rejection is None:
            try:
                stamp_s, position, velocity = shim.read_orbit_state(message)
            except ValueError:  # an orientation that is no rotation, or a bad stamp
                rejection = Rejection.NON_FINITE
            else:
                rejection = check_orbit_state(position, velocity, self._orbit_bounds)
        if rejection is None:
            rejection, jumped = self._odometry_stamps.check(stamp_s, self._now_s())
            if jumped:
                self._health.count("clock_jumps")
                self._stream.orbit.buffer.clear()
        if rejection is not None:
            self._health.count(f"rejected_odometry_{rejection.value}")
            return
        self._stream.orbit.buffer.add(stamp_s, position, velocity)

    def _orbit_covered(self, times) -> list:
        """orbit.source follow: the times of ``times`` the followed orbit gives a state at. Each other one is
        counted (``skipped_<reason>``) and publishes health only; a stale orbit is an ERROR, said once each
        way on the log, as for stale truth."""
        buffer, covered = self._stream.orbit.buffer, []
        for t_s in times:
            where = buffer.where(t_s)
            if where.usable:
                if self._orbit_problem is not None:
                    self.get_logger().info(f"orbit/odometry covers the samples again at t = {t_s:.3f} s")
                    self._orbit_problem = None
                covered.append(t_s)
                continue
            self._health.count(f"skipped_{where.value}")
            if self._orbit_problem is None or self._orbit_problem[0] is not where:
                newest = buffer.newest_stamp_s
                self._orbit_problem = (where, f"orbit/odometry: {where.value.replace('_', ' ')} at t = {t_s:.3f} s "
                                              f"(newest state {'none' if newest is None else f'{newest:.3f} s'}): "
                                              "no output until the odometry covers the sample times")
                if where is OrbitAt.STALE:
                    self.get_logger().error(self._orbit_problem[1])
            self._publish_health(t_s)
        return covered

    def _sense_profile_on_followed_orbit(self, times) -> None:
        """orbit.source follow with the own attitude model: each covered time alone (no orbit exists ahead of
        the user's odometry to compute a block from)."""
        for t_s in self._orbit_covered(times):
            for sample in self._orbit_samples(t_s, lambda: self._stream.samples(
                    [t_s], self._stream.profile.quaternion(np.array([t_s])).T)):
                self._publish_sample(sample)

    # -- ticks ----------------------------------------------------------------------------------

    @property
    def sim_time_s(self) -> float:
        """Current simulation time of the fast-time clock, s."""
        return self._sim_time_s

    @property
    def orbit(self):
        """The orbit the sensor flies (:class:`pmv_ros.physics.orbit.CircularOrbit`)."""
        return self._stream.orbit

    @property
    def samples_computed_ahead(self) -> int:
        """Fast-time samples computed ahead and not yet published (at most one block)."""
        return self._stream.pending

    @property
    def samples_published(self) -> int:
        """Samples published on /pmv/attitude since the start."""
        return self._health.samples_published

    def step(self) -> None:
        """Fast time: advance the simulation clock by one sensor period and publish that sample."""
        period = 1.0 / self._values["sensor.rate_hz"]
        self._sim_time_s += period
        self._pub_clock.publish(shim.write_clock(self._out["clock"], self._sim_time_s))
        if self._following:
            self._sense_following([(self._sim_time_s, *self._truth.attitude_at(self._sim_time_s))])
            return
        if self._orbit_following:
            self._sense_profile_on_followed_orbit([self._sim_time_s])
            return
        samples = self._orbit_samples(self._sim_time_s, lambda: [self._stream.next_profile_sample(
            self._sim_time_s, period, self.fast_time_block)])
        for sample in samples:
            self._publish_sample(sample)

    @property
    def fast_time_block(self) -> int:
        """Samples computed per call in fast time (:func:`pmv_ros.runtime.sample_stream.fast_time_block`)."""
        v = self._values
        return fast_time_block(v["sensor.rate_hz"], v["sim.time_scale"], self._external_drive)

    def _on_real_time_tick(self) -> None:
        """Publish every sample of the sensor's grid due since the last one, in order, each at its own stamp.

        The timer runs on the node clock; a ``/clock`` that steps by more than
        a period fires it once per step, so the samples are taken from the
        grid (:class:`pmv_ros.runtime.sample_stream.SampleGrid`), not from the
        tick: with the own attitude profile computed in the grid's blocks
        (those of a fast-time run), in follow mode the due ones as one block.
        A confirmed clock jump restarts the grid at the new time.
        """
        now_s = self.get_clock().now().nanoseconds * 1e-9
        jump = self._tick_clock.observe(now_s)
        if jump is Jump.OUTLIER:
            self._health.count("clock_outliers")
        if jump is Jump.SUSPECTED:
            self._health.count("skipped_unconfirmed_clock_jump")
            return
        if jump in (Jump.CONFIRMED_BACK, Jump.CONFIRMED_FORWARD):
            self._grid.restart()
            self._waiting.clear()
        indices = self._grid.due(now_s)
        if self._following:  # due times wait for the truth that covers them (it may come after the tick)
            self._waiting.add(self._grid.time_of(indices).tolist(), now_s)
            self._sense_following(self._waiting.ready(self._truth, now_s))
            return
        if not indices:
            return
        if self._orbit_following:
            self._sense_profile_on_followed_orbit(self._grid.time_of(indices).tolist())
            return
        last_s = float(self._grid.time_of(indices[-1]))
        for sample in self._orbit_samples(last_s, lambda: self._stream.grid_profile_samples(self._grid, indices)):
            self._publish_sample(sample)

    def _sense_following(self, found: list) -> None:
        """Measure at each ``(t_s, q, source)`` of ``found`` (in order; the attitude the truth buffer gives at
        t_s and where it came from), the samples that have one computed as one block; a time without one
        publishes nothing but health."""
        if not found:
            return
        usable = [(t_s, q) for t_s, q, source in found if source.usable]
        covered = set(self._orbit_covered([t for t, _ in usable])) if self._orbit_following else None
        if covered is not None:
            usable = [(t_s, q) for t_s, q in usable if t_s in covered]
        samples = iter(self._orbit_samples(found[-1][0], lambda: self._stream.samples(
            [t for t, _ in usable], [q for _, q in usable])) if usable else ())
        for t_s, _, source in found:
            self._truth_state = source
            # Said once each way: samples between the stale ones and the truth's return may read truth_gap.
            if source is TruthAt.STALE and not self._stale_logged:
                self._stale_logged = True
                self.get_logger().error(f"/attitude/truth is stale at t = {t_s:.3f} s (newest "
                                        f"{self._truth.newest_stamp_s:.3f} s): no angles until it returns")
            elif source.usable and self._stale_logged:
                self._stale_logged = False
                self.get_logger().info(f"/attitude/truth is back at t = {t_s:.3f} s")
            if not source.usable:
                self._health.count(f"skipped_{source.value}")
                self._publish_health(t_s)
                continue
            if covered is not None and t_s not in covered:  # no orbit at t_s: counted and said already
                continue
            if source is TruthAt.BRIDGED:  # a late truth sample, bridged by the last rate: counted, no alarm
                self._health.count("truth_bridged")
            sample = next(samples, None)
            if sample is not None:
                self._publish_sample(sample)

    def _orbit_samples(self, t_s: float, compute) -> list:
        """``compute()`` (a list of :class:`SensorSample`) unless the orbit has failed: [] then. An SGP4 error
        code stops the output for good: logged once as an ERROR, counted, and an ERROR on /diagnostics."""
        if self._orbit_error is None:
            try:
                return compute()
            except OrbitPropagationError as error:
                self._orbit_error = f"orbit: {error}: no output from here on"
                self.get_logger().error(self._orbit_error)
        self._health.count("skipped_orbit_error")
        self._publish_health(t_s)
        return []

    def _publish_sample(self, sample: SensorSample) -> None:
        out, t_s, frames = self._out, sample.t_s, self._frames
        if self._pub_truth is not None:
            self._pub_truth.publish(shim.write_attitude_quaternion(out["truth"], t_s, frames.orbital, sample.q_xyzw))
        odometry = shim.write_orbit_state(out["odometry"], t_s, frames.eci, frames.orbital,
                                          sample.position_eci_m, sample.velocity_eci_m_s)
        if self._pub_odometry is not None:  # a followed orbit's odometry is the user's (its TF is still ours)
            self._pub_odometry.publish(odometry)
        if self._transforms is not None:
            self._transforms.publish(odometry, t_s, sample.q_xyzw)
        self._pub_crossings.publish(shim.write_horizon_crossings(out["crossings"], t_s, frames.sensor,
                                                                 sample.line_of_sight))
        self._pub_attitude.publish(shim.write_attitude_angles(out["attitude"], t_s, frames.sensor,
                                                              sample.roll_rad, sample.pitch_rad))
        self._pub_attitude_raw.publish(shim.write_attitude_angles(out["attitude_raw"], t_s, frames.sensor,
                                                                  sample.roll_uncorrected_rad,
                                                                  sample.pitch_uncorrected_rad))
        imu = estimator_orientation(sample.roll_rad, sample.pitch_rad, *self._imu_variances)
        self._pub_imu.publish(shim.write_attitude_imu(out["imu"], t_s, frames.sensor, imu.q_xyzw,
                                                      imu.variances_rad2))
        self._health.record_sample(sample.chord_status)
        self._publish_health(t_s, sample.chord_status, sample.blinding_body)

    def _publish_health(self, t_s: float, status=None, blinding=None) -> None:
        """Publish /diagnostics when due (every diagnostics_period_s, and at once on a change)."""
        period = self._values["diagnostics_period_s"]
        if self._graph_checked_s is None or not (0.0 <= t_s - self._graph_checked_s < period):
            self._graph_checked_s, self._graph_warnings = t_s, self._truth_publisher_warnings()
            self._source_errors = tuple(self.input_source_problems(max_age_s=0.0))  # a second truth source
        source_errors = self._source_errors + ((self._orbit_error,) if self._orbit_error else ())
        warnings = self._graph_warnings
        if self._orbit_problem is not None:  # a stale followed orbit is an ERROR, one not there yet a WARN
            where, problem = self._orbit_problem
            source_errors, warnings = ((source_errors + (problem,), warnings) if where is OrbitAt.STALE
                                       else (source_errors, warnings + (problem,)))
        newest = self._truth.newest_stamp_s if self._following else None
        summary = self._health.report(
            t_s, period, status=status, blinding=blinding, truth=self._truth_state,
            exclusion_deg=self._values["sensor.bright_body_exclusion_deg"],
            truth_age_s=float("nan") if newest is None else t_s - newest,
            warnings=warnings + source_errors,
            no_sample=f"no {self._health.odometry_topic} state at the sample time" if self._orbit_problem else None)
        if summary is not None:
            level = max(summary.level, shim.Level.ERROR if source_errors else shim.Level.OK)  # a second source
            report = shim.HealthReport(stamp_s=t_s, statuses=(shim.HealthStatus(
                name=self.status_name("horizon"), level=shim.Level(level), message=summary.message,
                hardware_id=self.hardware_id("pmv"), values={**summary.values, **self.input_source_counters()}),
                *((self._orbit_status,) if self._orbit_status is not None else ())))
            self._pub_diagnostics.publish(shim.write_health(self._out["diagnostics"], report))

    def _truth_publisher_warnings(self) -> tuple:
        """A warning when /attitude/truth has a publisher besides this sensor's own model (following, a second
        source is an ERROR from :meth:`input_source_problems`: only the first one heard is followed)."""
        if self._following:
            return ()
        others = self.count_publishers(self._pub_truth.topic_name) - 1
        return truth_source_warnings(others)


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros sensor_node [--managed]``."""
    if managed_requested(args):  # --managed: a lifecycle node (pmv_ros/nodes/managed.py)
        return run_node(managed_factory(SensorNode, "sensor_node"), "sensor_node", args)
    return run_node(SensorNode, "sensor_node", args)


if __name__ == "__main__":
    sys.exit(main())
