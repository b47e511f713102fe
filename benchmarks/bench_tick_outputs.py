"""What the estimator output adds to each sensor tick: /pmv/attitude_imu against /pmv/attitude, in one run.

Per tick the sensor now also builds the Imu orientation
(:func:`pmv_ros.runtime.sensor.estimator_output.estimator_orientation`), fills one
reused ``sensor_msgs/Imu`` (:func:`pmv_msgs_shim.write_attitude_imu`) and
publishes it. Measured here on a lean node of the pipeline's kind with no
subscriber (as in ``pmv simulate``, where nothing in the process takes it):
µs per tick for the Imu path and, as the baseline in the same rounds, for the
``/pmv/attitude`` Vector3Stamped the sensor already published. Rounds
alternate (baseline, Imu) and each figure is the best of its rounds — the
machine may be shared. ``make demo`` flies 56,681 ticks: the added time there
is ticks × the Imu figure.

    .venv/bin/python benchmarks/bench_tick_outputs.py [--rounds R] [--ticks N]
"""

from __future__ import annotations

import argparse
import math
import os
import time

import rclpy
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Imu

import pmv_msgs_shim as shim
from pmv_ros.nodes.base import PmvNode
from pmv_ros.runtime.common.assembly import IMU_DEFAULT_RMS_ARCMIN
from pmv_ros.runtime.sensor.estimator_output import estimator_orientation, variance_from_rms_arcmin

DEMO_TICKS = 56_681  # one Kondor orbit at 10 Hz


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--ticks", type=int, default=20_000)
    args = parser.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"
    context = rclpy.Context()
    rclpy.init(context=context)
    node = PmvNode("bench_tick_outputs", lean=True, context=context)
    attitude_pub, imu_pub = node.publisher(Vector3Stamped, "pmv/attitude"), node.publisher(Imu, "pmv/attitude_imu")
    attitude_msg, imu_msg = Vector3Stamped(), Imu()
    variances = tuple(variance_from_rms_arcmin(rms) for rms in IMU_DEFAULT_RMS_ARCMIN)

    def baseline(k: int) -> None:
        attitude_pub.publish(shim.write_attitude_angles(attitude_msg, 0.1 * k, shim.SENSOR_FRAME, 1e-3, -2e-3))

    def with_imu(k: int) -> None:
        imu = estimator_orientation(1e-3, math.nan if k % 50 == 0 else -2e-3, *variances)
        imu_pub.publish(shim.write_attitude_imu(imu_msg, 0.1 * k, shim.SENSOR_FRAME, imu.q_xyzw, imu.variances_rad2))

    best = {"attitude (baseline)": math.inf, "attitude_imu": math.inf}
    try:
        for round_number in range(1, args.rounds + 1):
            for name, work in (("attitude (baseline)", baseline), ("attitude_imu", with_imu)):
                started = time.perf_counter()
                for k in range(1, args.ticks + 1):
                    work(k)
                per_tick_us = (time.perf_counter() - started) / args.ticks * 1e6
                best[name] = min(best[name], per_tick_us)
                print(f"round {round_number} {name}: {per_tick_us:.1f} µs/tick (load {os.getloadavg()[0]:.1f})")
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
    imu_us, base_us = best["attitude_imu"], best["attitude (baseline)"]
    print(f"best: attitude {base_us:.1f} µs/tick, attitude_imu {imu_us:.1f} µs/tick ({imu_us / base_us:.2f}× the "
          f"Vector3Stamped); make demo ({DEMO_TICKS} ticks): + {imu_us * DEMO_TICKS * 1e-6:.1f} s")
    from headline import headline
    headline("attitude_imu", "writing and publishing /pmv/attitude_imu, per tick", imu_us, "µs/tick", "lower", base_us,
             "µs/tick", "/pmv/attitude's Vector3Stamped, the same way", ratio=imu_us / base_us)


if __name__ == "__main__":
    main()
