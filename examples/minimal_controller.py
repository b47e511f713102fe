"""A minimal attitude controller closing its loop on the PMV, in one file of plain rclpy: copy it to write yours.

It subscribes to ``pmv/attitude`` (roll, pitch of the sensor, REP-103), integrates a rigid body with pmv_ros's
physics (``pmv_ros.physics.rigid_body``: Euler's equations relative to the orbital frame, gravity gradient),
applies a PD torque on the measured roll and pitch and on the true yaw, and publishes the body's attitude on
``attitude/truth`` for a sensor in follow mode. Run it beside the sensor:

    ros2 run pmv_ros sensor_node --ros-args --params-file config/kondor.yaml --params-file config/follow.yaml
    .venv/bin/python examples/minimal_controller.py [--bandwidth-hz 0.02] [--altitude-km 500]

``attitude_controller_node`` is the full version (checked inputs, parameters, /diagnostics, /tf, the pointing
statistics); ``pmv simulate --closed-loop`` runs that one in fast time.
"""

from __future__ import annotations

import argparse
import math

import rclpy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from rclpy.node import Node

from pmv_ros.physics.attitude import true_yaw
from pmv_ros.physics.orbit.two_body import circular_mean_motion_rad_s
from pmv_ros.physics.rigid_body import PdGains, RigidBody, pd_torque

INERTIA_KG_M2 = (900.0, 1100.0, 600.0)
RATE_HZ = 10.0


class MinimalController(Node):
    def __init__(self, bandwidth_hz: float, altitude_km: float, **node_options):
        super().__init__("minimal_controller", **node_options)
        self.body = RigidBody(INERTIA_KG_M2, circular_mean_motion_rad_s(altitude_km * 1e3))
        self.gains = PdGains(bandwidth_hz, 0.7, INERTIA_KG_M2)
        self.q, self.rate = (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0)  # at rest, nadir-pointing
        self.measured = (0.0, 0.0)  # the newest roll and pitch; a NaN axis keeps its last value
        self.truth = self.create_publisher(QuaternionStamped, "attitude/truth", 10)
        self.create_subscription(Vector3Stamped, "pmv/attitude", self.on_measurement, 10)
        self.time_s = None
        self.create_timer(1.0 / RATE_HZ, self.on_timer)

    def on_measurement(self, message: Vector3Stamped) -> None:
        roll, pitch = message.vector.x, message.vector.y
        self.measured = (self.measured[0] if math.isnan(roll) else roll,
                         self.measured[1] if math.isnan(pitch) else pitch)

    def on_timer(self) -> None:
        now = self.get_clock().now()
        now_s = now.nanoseconds * 1e-9
        if self.time_s is not None:
            torque = pd_torque(self.gains, (*self.measured, true_yaw(self.q)), self.rate)
            self.q, self.rate = self.body.step(self.q, self.rate, torque, now_s - self.time_s)
        self.time_s = now_s
        message = QuaternionStamped()
        message.header.stamp = now.to_msg()
        message.header.frame_id = "orbital"
        message.quaternion.x, message.quaternion.y, message.quaternion.z, message.quaternion.w = self.q
        self.truth.publish(message)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bandwidth-hz", type=float, default=0.02)
    parser.add_argument("--altitude-km", type=float, default=500.0)
    args, ros_arguments = parser.parse_known_args(argv)
    rclpy.init(args=ros_arguments)
    try:
        rclpy.spin(MinimalController(args.bandwidth_hz, args.altitude_km))
    except KeyboardInterrupt:
        pass
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
