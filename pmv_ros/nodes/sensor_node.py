"""``sensor_node``: the PMV horizon sensor in a ROS 2 graph.

Flies the orbit on the ROS clock (or its own simulation clock in fast time, publishing ``/clock``) with its own
attitude profile (published on ``/attitude/truth``) or the user's, and publishes crossings, roll/pitch (REP-103,
corrected and uncorrected), the same for estimators (``pmv/attitude_imu``), odometry, /tf and health. The node
only wires (:data:`TOPICS`): its runtime (:mod:`pmv_ros.runtime.sensor.runtime`: what each input and tick does)
returns what to publish, :mod:`pmv_msgs_shim` lays it out; transforms: :mod:`pmv_ros.nodes.tf`.
``sensor.correction`` is read once, at start-up, and is read-only: nothing from the network makes it read a file.
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
from .base import PmvNode, Pub, Sub
from ..runtime.common.assembly import READ_CORRECTION, SENSOR_PARAMS as PARAMS
from ..runtime.common.frames import Mounting
from ..runtime.sensor.runtime import HealthAt, SamplePublication, SensorRuntime
from .launch import node_main
from .managed import ManagedNode
from .params import ParameterError, declare, install_validation
from .tf import NO_TF2_MSGS, tf_message_type, transform_topics


def _sample(write):
    """A writer of one sample's message: ``write(message, sample, frames)``."""
    return lambda message, item, node: write(message, item.sample, node.frames)


#: What the sensor publishes and takes (relative names: in a namespace, every topic of the spacecraft moves
#: under it, interfaces.md "Topics"), in publication order per sample; /tf and /tf_static: :mod:`.tf`.
TOPICS = (
    Pub("attitude/truth", QuaternionStamped, SamplePublication, _sample(
        lambda m, s, f: shim.write_attitude_quaternion(m, s.t_s, f.orbital, s.q_xyzw)),
        when=lambda n: not n.follows_attitude),
    Pub("orbit/odometry", Odometry, SamplePublication, _sample(lambda m, s, f: shim.write_orbit_state(
        m, s.t_s, f.eci, f.orbital, s.position_eci_m, s.velocity_eci_m_s)),
        when=lambda n: not n.follows_orbit),  # orbit.source follow: the user's (its TF is still ours)
    Pub("pmv/horizon_crossings", PolygonStamped, SamplePublication, _sample(
        lambda m, s, f: shim.write_horizon_crossings(m, s.t_s, f.sensor, shim.checked_lines_of_sight(
            s.line_of_sight, s.chord_valid)))),  # checked as a message's: only when someone subscribes
    Pub("pmv/attitude", Vector3Stamped, SamplePublication, _sample(
        lambda m, s, f: shim.write_attitude_angles(m, s.t_s, f.sensor, s.roll_rad, s.pitch_rad))),
    Pub("pmv/attitude_uncorrected", Vector3Stamped, SamplePublication, _sample(lambda m, s, f: (
        shim.write_attitude_angles(m, s.t_s, f.sensor, s.roll_uncorrected_rad, s.pitch_uncorrected_rad)))),
    Pub("pmv/attitude_imu", Imu, SamplePublication, lambda m, p, n: shim.write_attitude_imu(
        m, p.sample.t_s, n.frames.sensor, p.imu.q_xyzw, p.imu.variances_rad2)),
    Pub("/diagnostics", DiagnosticArray, HealthAt, lambda m, h, n: shim.write_health(m, n.health_report(
        h.stamp_s, h.health, "horizon", others=(n.orbit_status,) if n.orbit_status else ()))),
    Pub("/clock", ClockMsg, "clock", lambda m, t_s, n: shim.write_clock(m, t_s),
        when=lambda n: n.fast_time),
    Sub("attitude/truth", QuaternionStamped, shim.quaternion_input, "add_truth", when=lambda n: n.follows_attitude),
    Sub("orbit/odometry", Odometry, shim.odometry_input, "add_odometry", when=lambda n: n.follows_orbit),
)


class SensorNode(PmvNode):
    """The PMV sensor: orbit + attitude → 4-chord crossings and roll/pitch.

    Args (of :meth:`build`, given to the constructor):
        external_drive: fast time stepped by the caller through :meth:`step` (``pmv simulate``), not by a timer.
        publish_tf: publish /tf and /tf_static (when tf2_msgs is there). The in-process pipeline turns it off
            unless it records: nothing else in its private graph listens.
    """

    NODE_NAME = "sensor_node"

    def build(self, *, external_drive: bool = False, publish_tf: bool = True) -> None:
        """Parameters, runtime (the one file read: ``sensor.correction``), topics, the start-up transform and the
        timer (see :class:`~pmv_ros.nodes.base.PmvNode`)."""
        self._values = v = declare(self, PARAMS)
        self._orbit_status = self._timer = None
        try:
            self._runtime = SensorRuntime(
                v, clock_epoch_s=self.now_s(), stepped=external_drive,
                correction=READ_CORRECTION,  # the one file read: at start-up, once the orbit is checked
                truth_topic=self.resolve_topic_name("attitude/truth"),
                odometry_topic=self.resolve_topic_name("orbit/odometry"), graph_problems=self._graph_problems,
                source_counters=self.input_source_counters)
            self._orbit_status = self._orbit_status_of(v)
        except ValueError as error:  # a combination, a date or a file the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, v, self._rebuild_live)
        self.q_body_to_sensor = Mounting.from_values(v).q_body_to_sensor
        tf_message = tf_message_type() if publish_tf else None
        if publish_tf and tf_message is None:
            self.get_logger().warning(NO_TF2_MSGS)
        self.wire(TOPICS + (transform_topics(tf_message) if tf_message else ()), v["input.source_timeout_s"])
        self.emit("mounting", self._runtime.now_s(self.now_s()))
        if not (v["sim.fast_time"] and external_drive):
            self._start_timer(v)
        f = self._runtime.frames
        pacing = ("fast time, publishing its own /clock" if v["sim.fast_time"]
                  else "paced by its clock, " + self.clock_name())
        self.get_logger().info(f"{self.get_fully_qualified_name()}: H = {v['orbit.altitude_km']:g} km, "
                               f"i = {v['orbit.inclination_deg']:g}°, {v['sensor.rate_hz']:g} Hz, "
                               f"attitude from {v['attitude.source']}, {pacing}; "
                               f"frames {f.eci} → {f.orbital} → {f.base_link} → {f.sensor}")

    def _orbit_status_of(self, values: dict):
        """Epoch and elements on every /diagnostics (for analysis); none for a followed orbit (the user's odometry)."""
        return None if values["orbit.source"] == "follow" else shim.orbit_elements_status(
            shim.OrbitElements.from_orbit(self._runtime.orbit, values["sim.epoch_utc"]), self.status_name("orbit"),
            self.hardware_id("pmv"))

    def _rebuild_live(self, values: dict) -> None:
        self._runtime.reconfigure(values)
        self.sources.set_timeout(values["input.source_timeout_s"])
        self._orbit_status = self._orbit_status_of(values)
        if self._timer is not None and any(values[k] != self._values[k] for k in ("sensor.rate_hz", "sim.time_scale")):
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._start_timer(values)

    def _start_timer(self, values: dict) -> None:
        rate, scale = values["sensor.rate_hz"], values["sim.time_scale"]
        if not values["sim.fast_time"]:
            self._timer = self.make_timer(1.0 / rate, self.tick)
        else:  # fast time paced on the wall clock (time_scale 0: as fast as it goes)
            self._timer = self.make_timer(0.0 if scale == 0.0 else 1.0 / (rate * scale), self.step,
                                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def input_clock(self, now_s: float) -> float:
        """The node clock as the runtime takes it with an input (it makes it its own: ``SensorRuntime.now_s``)."""
        return now_s

    def step(self) -> None:
        """Fast time: advance the simulation clock by one sensor period and publish that sample."""
        output = self._runtime.step()
        self.emit("clock", self._runtime.sim_time_s)
        self.take_output(output)

    def tick(self) -> None:
        """Real time: publish every sample of the sensor's grid due since the last tick (the timer's work,
        :meth:`SensorRuntime.tick`)."""
        self.take_output(self._runtime.tick(self.now_s()))

    def _graph_problems(self) -> tuple[int, tuple]:
        """Publishers of /attitude/truth besides our own model (0 when following), second sources of our inputs."""
        truth = self.topic_publishers.get("attitude/truth")
        others = 0 if truth is None else self.count_publishers(truth.topic_name) - 1
        return others, tuple(self.input_source_problems(max_age_s=0.0))

    follows_attitude = property(lambda self: self._runtime.following,
                                doc="The attitude comes from the user's /attitude/truth (attitude.source follow).")
    follows_orbit = property(lambda self: self._runtime.orbit_following,
                             doc="The orbit comes from the user's /orbit/odometry (orbit.source follow).")
    fast_time = property(lambda self: self._values["sim.fast_time"],
                         doc="The sensor runs its own simulation clock and publishes /clock (sim.fast_time).")
    orbit_status = property(lambda self: self._orbit_status,
                            doc="The epoch-and-elements status on every /diagnostics (None for a followed orbit).")
    sim_time_s = property(lambda self: self._runtime.sim_time_s, doc="Simulation time of the fast-time clock, s.")
    timer = property(lambda self: self._timer, doc="The timer that paces the samples (real or fast time).")
    orbit = property(lambda self: self._runtime.orbit, doc="The orbit the sensor flies.")
    samples_computed_ahead = property(lambda self: self._runtime.stream.pending,
                                      doc="Fast-time samples computed ahead and not yet published (≤ one block).")
    samples_published = property(lambda self: self._runtime.health.samples_published,
                                 doc="Samples published on /pmv/attitude since the start.")
    fast_time_block = property(lambda self: self._runtime.fast_time_block, doc="Samples computed per fast-time call.")


class ManagedSensorNode(ManagedNode, SensorNode):
    """:class:`SensorNode` as a managed (lifecycle) node (:mod:`pmv_ros.nodes.managed`)."""


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros sensor_node [--managed]``."""
    return node_main(SensorNode, ManagedSensorNode, args)


if __name__ == "__main__":
    sys.exit(main())
