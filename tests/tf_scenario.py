"""One spacecraft's sensor in namespace ``sat1`` stepped in fast time, with everything it publishes read back.

Run in-process by the TF tests (without tf2_msgs) and as a script by the
system test in a venv that has the vendored tf2_msgs (``python
tests/tf_scenario.py`` prints one JSON object). What comes back: the sensor's
/pmv/attitude, the transforms of /tf and /tf_static, and how far ``eci →
pmv_sensor`` composed from them is from the rotation built from
/orbit/odometry, /attitude/truth and the mounting parameters.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import rclpy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from scipy.spatial.transform import Rotation

import pmv_msgs_shim as shim
from pmv_ros.nodes.pipeline import drain
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.tf import TF_QOS, TF_STATIC_QOS, tf_message_type
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import orbital_frame_from_state

TICKS = 60
MOUNTING_ARCMIN = {"roll": 10.0, "pitch": -5.0, "yaw": 3.0}
PARAMETERS = {
    "sim.fast_time": True, "frames.prefix": "sat1/", "sensor.detector": "ideal", "radiance.source": "uniform",
    "sensor.bright_body_exclusion_deg": 0.0, "attitude.roll_offset_arcmin": 20.0, "attitude.yaw_offset_arcmin": 7.0,
    "attitude.pitch_amplitude_arcmin": 30.0, "attitude.oscillation_period_s": 4.0, "orbit.u0_deg": 33.0,
    **{f"sensor.mounting_{axis}_arcmin": value for axis, value in MOUNTING_ARCMIN.items()},
}


def _matrix(q_xyzw) -> np.ndarray:
    return Rotation.from_quat(np.asarray(q_xyzw, float)).as_matrix()


def run(publish_tf: bool = True) -> dict:
    """Step the sensor TICKS times; what it published (see the module docstring), JSON-ready."""
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    sensor = tester = None
    got = {"attitude": [], "odometry": [], "truth": [], "tf": [], "tf_static": []}
    try:
        sensor = SensorNode(context=context, namespace="sat1", external_drive=True, publish_tf=publish_tf,
                            parameter_overrides=[Parameter(k, value=v) for k, v in PARAMETERS.items()])
        tester = Node("tf_listener", context=context)
        tester.create_subscription(Vector3Stamped, "/sat1/pmv/attitude", got["attitude"].append, 1000)
        tester.create_subscription(Odometry, "/sat1/orbit/odometry", got["odometry"].append, 1000)
        tester.create_subscription(QuaternionStamped, "/sat1/attitude/truth", got["truth"].append, 1000)
        tf_message = tf_message_type()
        if tf_message is not None:
            tester.create_subscription(tf_message, "/tf", got["tf"].append, TF_QOS)
        for node in (sensor, tester):
            executor.add_node(node)
        drain(executor)
        for _ in range(TICKS):
            sensor.step()
            drain(executor)
        if tf_message is not None:  # a listener that comes late still gets the static transform (transient local)
            tester.create_subscription(tf_message, "/tf_static", got["tf_static"].append, TF_STATIC_QOS)
            for _ in range(50):
                if got["tf_static"]:
                    break
                executor.spin_once(timeout_sec=0.02)
        topics = sorted(name for name, _ in tester.get_topic_names_and_types())
    finally:
        executor.shutdown()
        for node in (sensor, tester):
            if node is not None:
                node.destroy_node()
        rclpy.shutdown(context=context)
    result = {
        "topics": topics,
        "attitude": [[shim.time_from_msg(m.header.stamp), m.header.frame_id, m.vector.x, m.vector.y]
                     for m in got["attitude"]],
        "tf_messages": len(got["tf"]), "tf_static_messages": len(got["tf_static"]),
        "transforms": sorted({(t.header.frame_id, t.child_frame_id) for m in got["tf"] + got["tf_static"]
                              for t in m.transforms}),
    }
    if got["tf"]:
        result.update(_compare(got))
    return result


def _compare(got: dict) -> dict:
    """Largest angle between eci → pmv_sensor composed from /tf + /tf_static and the rotation built from the inputs."""
    static = {t.child_frame_id: shim.read_transform(t) for m in got["tf_static"] for t in m.transforms}
    by_stamp = {}
    for message in got["tf"]:
        for transform in message.transforms:
            stamp_s, parent, child, translation, q = shim.read_transform(transform)
            by_stamp.setdefault(stamp_s, {})[child] = (stamp_s, parent, child, translation, q)
    truth = {shim.time_from_msg(m.header.stamp): shim.attitude_quaternion_from_msg(m) for m in got["truth"]}
    mounting = _matrix(quaternion_from_roll_pitch_yaw(*(MOUNTING_ARCMIN[a] * ARCMIN_RAD
                                                        for a in ("roll", "pitch", "yaw"))))
    angles, offsets, compared = [], [], 0
    for odometry in got["odometry"]:
        stamp_s, position, velocity = shim.read_orbit_state(odometry)
        chain = {**static, **by_stamp[stamp_s]}
        composed, frame, translation = np.eye(3), "sat1/pmv_sensor", None
        # Walk up the tree: R(eci ← sensor) = R(eci ← orbital) R(orbital ← base_link) R(base_link ← sensor).
        while frame != "eci":
            _, parent, _, offset, q = chain[frame]
            composed = _matrix(q) @ composed
            translation = offset if parent == "eci" else translation
            frame = parent
        built = orbital_frame_from_state(np.array(position), np.array(velocity)) \
            @ _matrix(truth[stamp_s].q_xyzw) @ mounting
        angles.append(Rotation.from_matrix(composed.T @ built).magnitude())
        offsets.append(float(np.max(np.abs(np.subtract(translation, position)))))
        compared += 1
    return {"compared": compared, "max_angle_rad": float(max(angles)), "max_translation_error_m": max(offsets)}


if __name__ == "__main__":
    json.dump(run(), sys.stdout)
