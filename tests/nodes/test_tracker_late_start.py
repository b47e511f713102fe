"""Two star_tracker_nodes, one started 20 s of truth later: the same frames for the same frame times, bit for bit
(physics.md §6 item 9: every draw keyed by the frame's time, not by the frames since the node started)."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import QuaternionStamped

import pmv_msgs_shim as shim
from pmv_ros.nodes.star_tracker_node import StarTrackerNode
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw

#: On the simulation's clock (sim.fast_time: the orbit's epoch is sim.start_time_s, as the sensor's), and with
#: recognition failures made frequent so that the frames without attitude must agree too.
OPTIONS = {"sim.fast_time": True, "frame_period_s": 0.5, "exposure_s": 0.5, "processing_s": 0.25,
           "recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 8.0}


def _fly(harness, first_k: int) -> dict:
    h = harness(StarTrackerNode, OPTIONS)
    h.record(QuaternionStamped, "/star_tracker/attitude")
    truth = h.publisher(QuaternionStamped, "/attitude/truth")
    for k in range(first_k, 1201):  # truth at 10 Hz up to 120 s
        t = 0.1 * k
        q = quaternion_from_roll_pitch_yaw(2e-4 * np.sin(t / 30.0), -1e-4, 3e-4 * np.cos(t / 20.0))
        truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), t, shim.ORBITAL_FRAME, q))
        h.drain()
    counters = h.node.counters
    return {(m := shim.attitude_quaternion_from_msg(message)).stamp_s: m.q_xyzw
            for message in h.received["/star_tracker/attitude"]}, counters


def test_two_trackers_started_20_s_apart_publish_the_same_frames(harness):
    early, early_counts = _fly(harness, 1)
    late, late_counts = _fly(harness, 201)  # 20 s of truth later
    common = sorted(set(early) & set(late))
    assert len(late) > 40 and common == sorted(late)  # every frame of the late one, the early one had too
    for stamp in common:
        np.testing.assert_array_equal(late[stamp], early[stamp])
    # The frames without attitude fall on the same frame times: the early one's after 20.5 s are the late one's.
    assert early_counts["frames_recognition_failure"] > late_counts["frames_recognition_failure"] > 10
    missing_early = {round(0.5 * k, 6) for k in range(42, 241)} - set(early)
    missing_late = {round(0.5 * k, 6) for k in range(42, 241)} - set(late)
    assert missing_early == missing_late
