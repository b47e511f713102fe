"""``sensor_node``: the PMV horizon sensor in a ROS 2 graph.

Propagates the orbit on the ROS clock (or on its own simulation clock in
fast-time mode, publishing ``/clock``), takes the body attitude from its own
profile (published on ``/attitude/truth``) or follows the user's
``/attitude/truth``, and publishes crossings, roll/pitch (REP-103, corrected
and uncorrected), the same as an orientation with covariance for estimators
(``pmv/attitude_imu``), odometry, /tf and health. The node only wires: its
runtime (:mod:`pmv_ros.runtime.sensor.runtime`, which says what each input
and tick does) returns what to publish, :mod:`pmv_msgs_shim` lays it out.

Topic names are relative (a namespace moves them), frames come from the
``frames.*`` parameters, transforms go out when tf2_msgs is there
(:mod:`pmv_ros.nodes.tf`). ``sensor.correction`` is read once, at start-up,
and is read-only: nothing from the network makes the node read a file.
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import Imu

import pmv_msgs_shim as shim
from .base import PmvNode
from ..runtime.common.assembly import SENSOR_PARAMS as PARAMS, read_correction
from ..runtime.common.frames import Mounting
from ..runtime.sensor.runtime import SamplePublication, SensorOutput, SensorRuntime
from .launch import node_main
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
        self._values = v = declare(self, PARAMS)
        self._orbit_status = self._pub_truth = self._pub_clock = self._transforms = self._timer = None
        try:
            self._runtime = SensorRuntime(
                v, clock_epoch_s=self.get_clock().now().nanoseconds * 1e-9, stepped=external_drive,
                correction=read_correction(v),  # the one file read: here, at start-up
                check_lines_of_sight=shim.checked_lines_of_sight, truth_topic=self.resolve_topic_name("attitude/truth"),
                odometry_topic=self.resolve_topic_name("orbit/odometry"), graph_problems=self._graph_problems,
                source_counters=self.input_source_counters)
            self._orbit_status = self._orbit_status_of(v)
        except ValueError as error:  # a combination, a date or a file the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, v, self._rebuild_live)
        runtime, frames = self._runtime, self._runtime.frames
        # Relative names: in a namespace, every topic of this spacecraft moves under it (interfaces.md "Topics").
        self._pub_crossings = self.publisher(PolygonStamped, "pmv/horizon_crossings")
        self._pub_attitude = self.publisher(Vector3Stamped, "pmv/attitude")
        self._pub_attitude_raw = self.publisher(Vector3Stamped, "pmv/attitude_uncorrected")
        self._pub_imu = self.publisher(Imu, "pmv/attitude_imu")
        # orbit.source follow: the user's stack owns orbit/odometry and the sensor flies it (runtime/common/orbit_buffer.py).
        self._pub_odometry = None if runtime.orbit_following else self.publisher(Odometry, "orbit/odometry")
        self._pub_diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self.watch_clock(self._pub_diagnostics)
        # One message per topic, filled in place for every sample (rclpy serialises at publish).
        self._out = dict(truth=QuaternionStamped(), odometry=Odometry(), crossings=PolygonStamped(),
                         attitude=Vector3Stamped(), attitude_raw=Vector3Stamped(), imu=Imu(), clock=ClockMsg(),
                         diagnostics=DiagnosticArray())
        if runtime.following:
            self.input_subscription(QuaternionStamped, "attitude/truth", self._on_truth, v["input.source_timeout_s"])
        else:
            self._pub_truth = self.publisher(QuaternionStamped, "attitude/truth")
        if runtime.orbit_following:
            self.input_subscription(Odometry, "orbit/odometry", self._on_odometry, v["input.source_timeout_s"])
        tf_message = tf_message_type() if publish_tf else None
        if publish_tf and tf_message is None:
            self.get_logger().warning(NO_TF2_MSGS)
        elif tf_message is not None:
            self._transforms = SensorTransforms(self, tf_message, frames, Mounting.from_values(v).q_body_to_sensor,
                                                own_attitude=not runtime.following, stamp_s=self._now_s())
        if v["sim.fast_time"]:
            self._pub_clock = self.publisher(ClockMsg, "/clock")
        if not (v["sim.fast_time"] and external_drive):
            self._start_timer(v)
        pacing = ("fast time, publishing its own /clock" if v["sim.fast_time"]
                  else "paced by its clock, " + self.clock_name())
        self.get_logger().info(
            f"sensor_node: H = {v['orbit.altitude_km']:g} km, i = {v['orbit.inclination_deg']:g}°, "
            f"{v['sensor.rate_hz']:g} Hz, attitude from {v['attitude.source']}, {pacing}; "
            f"frames {frames.eci} → {frames.orbital} → {frames.base_link} → {frames.sensor}")

    # -- parameters ---------------------------------------------------------------------------

    def _orbit_status_of(self, values: dict):
        """Epoch and elements on every /diagnostics, so that recordings can be analysed; a followed orbit has
        none (the user's odometry is the record of it)."""
        return None if values["orbit.source"] == "follow" else shim.orbit_elements_status(
            shim.OrbitElements.from_orbit(self._runtime.orbit, values["sim.epoch_utc"]), self.status_name("orbit"),
            self.hardware_id("pmv"))

    def _rebuild_live(self, values: dict) -> None:
        self._runtime.reconfigure(values)
        self.set_source_timeout(values["input.source_timeout_s"])
        self._orbit_status = self._orbit_status_of(values)
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

    # -- inputs and ticks -------------------------------------------------------------------------

    def _now_s(self) -> float:
        """Now on the sensor's own clock: simulation time in fast time, the node clock otherwise."""
        return self._runtime.now_s(self.get_clock().now().nanoseconds * 1e-9)

    def _on_truth(self, message: QuaternionStamped) -> None:
        try:
            record = shim.attitude_quaternion_from_msg(message)
            stamp_s, q_xyzw = record.stamp_s, record.q_xyzw
        except ValueError:  # negative or non-finite stamp
            stamp_s = q_xyzw = None
        self._publish(self._runtime.add_truth(message.header.frame_id, stamp_s, q_xyzw, self._now_s()))

    def _on_odometry(self, message: Odometry) -> None:
        try:
            state = shim.read_orbit_state(message)
        except ValueError:  # an orientation that is no rotation, or a bad stamp
            state = None
        self._runtime.add_odometry(message.header.frame_id, message.child_frame_id, state, self._now_s())

    def step(self) -> None:
        """Fast time: advance the simulation clock by one sensor period and publish that sample."""
        out = self._runtime.step()
        if self.listened(self._pub_clock):
            self._pub_clock.publish(shim.write_clock(self._out["clock"], self._runtime.sim_time_s))
        self._publish(out)

    def _on_real_time_tick(self) -> None:
        """Publish every sample of the sensor's grid due since the last tick (:meth:`SensorRuntime.tick`)."""
        self._publish(self._runtime.tick(self.get_clock().now().nanoseconds * 1e-9))

    @property
    def sim_time_s(self) -> float:
        """Current simulation time of the fast-time clock, s."""
        return self._runtime.sim_time_s

    @property
    def orbit(self):
        """The orbit the sensor flies (:class:`pmv_ros.physics.orbit.two_body.CircularOrbit`)."""
        return self._runtime.orbit

    @property
    def samples_computed_ahead(self) -> int:
        """Fast-time samples computed ahead and not yet published (at most one block)."""
        return self._runtime.stream.pending

    @property
    def samples_published(self) -> int:
        """Samples published on /pmv/attitude since the start."""
        return self._runtime.health.samples_published

    @property
    def fast_time_block(self) -> int:
        """Samples computed per call in fast time (:func:`pmv_ros.runtime.sensor.sample_stream.fast_time_block`)."""
        return self._runtime.fast_time_block

    # -- outputs --------------------------------------------------------------------------------

    def _graph_problems(self) -> tuple[int, tuple]:
        """The graph as :class:`SensorRuntime` asks for it: publishers of /attitude/truth besides our own model
        (0 when following) and the second sources of our inputs."""
        others = 0 if self._pub_truth is None else self.count_publishers(self._pub_truth.topic_name) - 1
        return others, tuple(self.input_source_problems(max_age_s=0.0))

    def _publish(self, output: SensorOutput) -> None:
        for line in output.log:  # two call sites: rclpy's logger refuses two severities from one
            if line.level == "error":
                self.get_logger().error(line.text)
            else:
                self.get_logger().info(line.text)
        out, frames = self._out, self._runtime.frames
        listened = self.listened
        crossings, raw, imu_output = listened(self._pub_crossings), listened(self._pub_attitude_raw), \
            listened(self._pub_imu)
        for item in output.published:
            if type(item) is not SamplePublication:  # a /diagnostics report, HealthAt
                self._pub_diagnostics.publish(shim.write_health(out["diagnostics"], self.health_report(
                    item.stamp_s, item.health, "horizon", others=(self._orbit_status,) if self._orbit_status else ())))
                continue
            sample, imu, t_s = item.sample, item.imu, item.sample.t_s
            if self._pub_truth is not None:
                self._pub_truth.publish(shim.write_attitude_quaternion(out["truth"], t_s, frames.orbital,
                                                                       sample.q_xyzw))
            odometry = shim.write_orbit_state(out["odometry"], t_s, frames.eci, frames.orbital,
                                              sample.position_eci_m, sample.velocity_eci_m_s)
            if self._pub_odometry is not None:  # a followed orbit's odometry is the user's (its TF is still ours)
                self._pub_odometry.publish(odometry)
            if self._transforms is not None:
                self._transforms.publish(odometry, t_s, sample.q_xyzw)
            if crossings:
                self._pub_crossings.publish(shim.write_horizon_crossings(out["crossings"], t_s, frames.sensor,
                                                                         sample.line_of_sight))
            self._pub_attitude.publish(shim.write_attitude_angles(out["attitude"], t_s, frames.sensor,
                                                                  sample.roll_rad, sample.pitch_rad))
            if raw:
                self._pub_attitude_raw.publish(shim.write_attitude_angles(
                    out["attitude_raw"], t_s, frames.sensor, sample.roll_uncorrected_rad,
                    sample.pitch_uncorrected_rad))
            if imu_output:
                self._pub_imu.publish(shim.write_attitude_imu(out["imu"], t_s, frames.sensor, imu.q_xyzw,
                                                              imu.variances_rad2))


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros sensor_node [--managed]``."""
    return node_main(SensorNode, "sensor_node", args)


if __name__ == "__main__":
    sys.exit(main())
