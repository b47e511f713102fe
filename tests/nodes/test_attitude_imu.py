"""/pmv/attitude_imu: the sensor's roll and pitch for estimators, with covariance (interfaces.md "Topics").

The orientation must say exactly what /pmv/attitude says (its roll and pitch recovered to 1e-12 rad), the
variances must be the preset's documented ones, a lost chord pair must give a finite message whose axis a
filter ignores (a huge variance, angle 0), and nothing else may claim to be measured (yaw's variance huge;
angular velocity and linear acceleration marked not provided, sensor_msgs/Imu's covariance[0] = −1).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Imu

import pmv_msgs_shim as shim
from node_harness import probe
from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.sensor.estimator_output import UNOBSERVED_VARIANCE_RAD2, estimator_orientation

KONDOR = Path(__file__).resolve().parents[2] / "config" / "kondor.yaml"


def roll_pitch_yaw(q):
    """tf2's getRPY for R = R_z(yaw)·R_y(pitch)·R_x(roll), written out here (independent of the package)."""
    x, y, z, w = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def fuse(prior_mean, prior_covariance, measurement, measurement_covariance):
    """A static Kalman update of (roll, pitch, yaw) with the message's full 3 × 3 covariance: posterior mean."""
    gain = prior_covariance @ np.linalg.inv(prior_covariance + measurement_covariance)
    return prior_mean + gain @ (measurement - prior_mean)


def test_the_imu_output_is_the_measured_attitude_with_the_presets_variances_and_a_lost_axis_is_ignored():
    # Kondor's preset with a ±5° roll swing (period 200 s, 1 Hz): past ≈ 2.9° a ±Y chord finds no
    # horizon and roll is lost (tests/nodes/test_faults.py shows the chain side); pitch stays.
    documented = yaml.safe_load(KONDOR.read_text())["sensor_node"]["ros__parameters"]["imu"]
    overrides = {"attitude.roll_amplitude_arcmin": 300.0, "attitude.oscillation_period_s": 200.0,
                 "sensor.rate_hz": 1.0}
    with Pipeline(KONDOR, overrides, collect=False) as pipeline:
        got = probe(pipeline, {"/pmv/attitude": Vector3Stamped, "/pmv/attitude_imu": Imu})
        pipeline.step(100)
    attitude, imu = got["/pmv/attitude"], got["/pmv/attitude_imu"]
    assert len(attitude) == len(imu) == 100
    roll_variance = (documented["roll_error_rms_arcmin"] * ARCMIN_RAD) ** 2
    pitch_variance = (documented["pitch_error_rms_arcmin"] * ARCMIN_RAD) ** 2
    lost = worst = 0
    prior_mean = np.array([0.01, -0.02, 0.3])  # rad: an estimator's belief before this sample
    prior_covariance = np.diag([(1.0 * math.pi / 180) ** 2] * 3)
    for angles, message in zip(attitude, imu):
        assert message.header.stamp == angles.header.stamp and message.header.frame_id == shim.SENSOR_FRAME
        q = (message.orientation.x, message.orientation.y, message.orientation.z, message.orientation.w)
        covariance = np.array(message.orientation_covariance).reshape(3, 3)
        assert np.all(np.isfinite(q)) and np.all(np.isfinite(covariance)) and abs(np.linalg.norm(q) - 1.0) < 1e-12
        assert message.angular_velocity_covariance[0] == -1.0 and message.linear_acceleration_covariance[0] == -1.0
        assert np.count_nonzero(covariance - np.diag(np.diag(covariance))) == 0
        roll, pitch, yaw = roll_pitch_yaw(q)
        assert abs(yaw) < 1e-15 and covariance[2, 2] == UNOBSERVED_VARIANCE_RAD2
        assert math.isfinite(angles.vector.y) and covariance[1, 1] == pitch_variance
        worst = max(worst, abs(pitch - angles.vector.y))
        posterior = fuse(prior_mean, prior_covariance, np.array([roll, pitch, yaw]), covariance)
        if math.isfinite(angles.vector.x):
            worst = max(worst, abs(roll - angles.vector.x))
            assert covariance[0, 0] == roll_variance
        else:  # lost: angle 0, a huge variance — the filter keeps its prior roll and still takes the pitch
            lost += 1
            assert roll == 0.0 and covariance[0, 0] == UNOBSERVED_VARIANCE_RAD2
            assert abs(posterior[0] - prior_mean[0]) < 1e-9
        # Pitch is taken with the weight its variance gives (a gain of 0.98 against a 1° prior).
        gain = prior_covariance[1, 1] / (prior_covariance[1, 1] + pitch_variance)
        assert gain > 0.9 and abs(posterior[1] - (prior_mean[1] + gain * (pitch - prior_mean[1]))) < 1e-12
        assert abs(posterior[2] - prior_mean[2]) < 1e-9  # yaw: never measured
    print(f"{len(imu)} samples, {lost} with roll lost; roll/pitch from the quaternion vs /pmv/attitude: "
          f"{worst:.1e} rad")
    assert worst <= 1e-12
    assert 20 <= lost <= 80  # the swing past ≈ 2.9° (and the environment near it) loses roll; the rest is valid


def test_estimator_orientation_is_finite_for_every_lost_combination():
    for roll, pitch in ((math.nan, 0.01), (0.02, math.nan), (math.nan, math.nan), (math.inf, -0.03)):
        out = estimator_orientation(roll, pitch, 1e-6, 2e-6)
        assert all(map(math.isfinite, out.q_xyzw)) and all(map(math.isfinite, out.variances_rad2))
        recovered = roll_pitch_yaw(out.q_xyzw)
        for angle, back, variance, given in zip((roll, pitch), recovered, out.variances_rad2, (1e-6, 2e-6)):
            if math.isfinite(angle):
                assert abs(back - angle) < 1e-15 and variance == given
            else:
                assert back == 0.0 and variance == UNOBSERVED_VARIANCE_RAD2


def test_the_main_job_builds_no_imu_message_nobody_reads_and_a_probe_gets_every_one(monkeypatch):
    """The in-process pipeline's graph is private: with no subscriber of /pmv/attitude_imu the sensor builds and
    publishes none (PmvNode.emit); once one subscribes, every sample's message comes."""
    built = []
    write = shim.write_attitude_imu
    monkeypatch.setattr(shim, "write_attitude_imu", lambda *args: built.append(args[1]) or write(*args))
    with Pipeline(KONDOR, {"sensor.rate_hz": 1.0}, collect=False) as pipeline:
        attitude = probe(pipeline, {"/pmv/attitude": Vector3Stamped})["/pmv/attitude"]
        pipeline.step(20)
        assert len(attitude) == 20 and built == []
        imu = probe(pipeline, {"/pmv/attitude_imu": Imu})["/pmv/attitude_imu"]
        pipeline.step(20)
    assert len(imu) == len(built) == 20
