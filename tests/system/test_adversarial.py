"""A hostile neighbour on the DDS domain (issue 15): the attacks, from a second process, against the three nodes.

The three nodes run as their console scripts, each its own process, in fast
time at real speed (the sensor publishes /clock, the others follow it), on a
ROS domain of their own, discovery on this host only. This test process is
the neighbour: it publishes on every input topic (1e308 angles, a plausible
second sensor reading 20′ off, absurd odometry, a flood of quaternions far
from the truth), forges /clock an hour ahead, and asks the parameter
services for a file read (/etc/passwd, a FIFO, /dev/zero) and a 200,000-
element outage list. Then it checks what the nodes did:

* the monitor's residuals stay those of the real sensor against the real
  tracker (|residual| < 1′; any hostile sample accepted would be ≥ 20′);
  every statistic on /pmv/error_statistics is finite;
* /diagnostics of the monitor is an ERROR naming the publishers' count of
  each attacked input; no clock jump or alignment reset, the forged /clock
  dropped as a second source of the clock;
  no real truth refused as backwards;
* every parameter request is refused at once with a reason that quotes no
  file; the star tracker's memory does not grow;
* the real pair is still aligned during the flood, and at half its rate
  before at least once the attacks are over;
* all three processes are still running.

About 30 s (marked ``adversarial``; ``-m "not adversarial"`` leaves it out).
"""

from __future__ import annotations

import math
import os
import time

import pytest
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from neighbour import Neighbour, monitor_status, rss_mb, running_stack
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD

pytestmark = [pytest.mark.adversarial, pytest.mark.serial, pytest.mark.multi_process]

@pytest.fixture
def stack(tmp_path):
    with running_stack(tmp_path) as processes:
        yield processes


def test_a_hostile_neighbour_changes_nothing_it_should_not(stack, tmp_path):
    neighbour = Neighbour()
    try:
        neighbour.wait_for_stack()
        # The residual rate without an attack, for comparison (a rate of wall time: on a busy machine it is lower).
        start = len(neighbour.got["residual"])
        neighbour.spin(3.0)
        rate_before = (len(neighbour.got["residual"]) - start) / 3.0
        before = len(neighbour.got["residual"])
        tracker_rss = rss_mb(stack["star_tracker_node"].pid)

        # 1. Hostile inputs on every input of the monitor for 3 s (20 Hz each, the truth flooded).
        far = quaternion_from_roll_pitch_yaw(0.3, -0.2)
        flood_sent = 0
        end = time.monotonic() + 3.0
        while time.monotonic() < end:
            t = neighbour.now_s
            neighbour.pub["attitude"].publish(shim.write_attitude_angles(
                Vector3Stamped(), t, shim.SENSOR_FRAME, 1e308, 1e308))
            neighbour.pub["attitude"].publish(shim.write_attitude_angles(
                Vector3Stamped(), t + 0.01, shim.SENSOR_FRAME, 20 * ARCMIN_RAD, 20 * ARCMIN_RAD))
            neighbour.pub["odometry"].publish(shim.write_orbit_state(Odometry(), t, shim.ECI_FRAME,
                                                                      shim.ORBITAL_FRAME, (1e3, 0.0, 0.0),
                                                                      (0.0, 7.6e3, 0.0)))
            for k in range(50):
                neighbour.pub["tracker"].publish(shim.write_attitude_quaternion(
                    QuaternionStamped(), t + 1e-4 * k, shim.ORBITAL_FRAME, far))
            flood_sent += 50
            neighbour.spin(0.05)

        rate_during = (len(neighbour.got["residual"]) - before) / (time.monotonic() - end + 3.0)
        # 2. A forged /clock an hour ahead, three times 0.2 s apart: rclpy's /clock subscription keeps one message,
        # and on a busy machine the next real /clock can replace a single forged one before the node takes it.
        for _ in range(3):
            neighbour.pub["clock"].publish(shim.write_clock(Clock(), neighbour.now_s + 3600.0))
            neighbour.spin(0.2)
        neighbour.spin(0.3)

        # 3. Parameter requests that would read a file, or fill memory.
        fifo = tmp_path / "fifo"
        os.mkfifo(fifo)
        for path in ("/etc/passwd", str(fifo), "/dev/zero"):
            result, took_s = neighbour.set_parameter("sensor_node", "sensor.correction", path)
            assert not result.successful and "read-only" in result.reason and "root:" not in result.reason
            assert took_s < 5.0
        result, _ = neighbour.set_parameter("star_tracker_node", "outage_start_s", [1.0] * 200_000)
        assert not result.successful and "more than the" in result.reason, result.reason

        neighbour.wait_for_reports("error_monitor_node")  # one made after the attacks had all been taken
        after = len(neighbour.got["residual"])
        neighbour.spin(3.0)
        rate_after = (len(neighbour.got["residual"]) - after) / 3.0

        # What the nodes did.
        for name, process in stack.items():
            assert process.poll() is None, f"{name} died: {(tmp_path / (name + '.out')).read_text()[-2000:]}"
        residuals = neighbour.got["residual"]
        # The real pair kept being aligned through the attack, and at half its rate before at least once it was
        # over. How much of the rate the flood leaves depends on the CPU the monitor gets: its executor takes
        # ≈ 1,000 flood messages a second, and when it falls behind, the keep-last input queue holds fewer of the
        # real tracker's frames (beside a busy process on each core, 10 runs: 15–37 % of the rate before in three,
        # ≥ 50 % in the others; at a load of 10 on 2 cores it fell to 0, and this test fails there).
        assert rate_during >= 0.1 * rate_before > 0, (rate_before, rate_during)
        assert rate_after >= 0.5 * rate_before, (rate_before, rate_after)
        worst = max(max(abs(m.vector.x), abs(m.vector.y)) for m in residuals) / ARCMIN_RAD
        report = monitor_status(neighbour.got["diagnostics"])
        assert worst < 1.0, (f"a hostile sample was used: residual {worst:.1f}′ at "
                             f"{[shim.time_from_msg(m.header.stamp) for m in residuals if abs(m.vector.x) > 1e-3][:5]}"
                             f"; monitor: {report.message if report else None} {dict(report.values) if report else {}}")
        statistics = shim.error_statistics_from_msg(neighbour.wait_for_statistics())
        for channel in statistics.channels:
            for value in (channel.mean_rad, channel.sigma_rad, channel.max_abs_rad):
                assert math.isfinite(value), channel
        status = monitor_status(neighbour.got["diagnostics"])
        values = dict(status.values)
        assert status.level == shim.Level.ERROR, status.message
        for topic in ("/pmv/attitude", "/star_tracker/attitude", "/orbit/odometry"):
            assert f"2 publishers of {topic}" in status.message, status.message
        assert int(values["other_source_star_tracker_attitude"]) > 0.5 * flood_sent
        assert "rejected_truth_backwards" not in values
        assert not [key for key in values if key.startswith("source_changes_")], values  # no input changed hands
        assert "clock_jumps" not in values and "alignment_resets" not in values
        # The forged /clock is a second publisher of /clock: dropped before it reaches the time source.
        assert int(values.get("rejected_clock_other_source", 0)) >= 1
        growth_mb = rss_mb(stack["star_tracker_node"].pid) - tracker_rss
        print(f"adversarial: {flood_sent} flood messages, {values['other_source_star_tracker_attitude']} dropped as "
              f"another source; worst residual {worst:.3f}′; "
              f"{len(residuals) - before} residuals since the attack began "
              f"({rate_during:.1f}/s during the flood, {rate_before:.1f}/s before, {rate_after:.1f}/s after); "
              f"tracker RSS {growth_mb:+.1f} MB after a 200,000-element list")
        assert growth_mb < 20.0
    finally:
        neighbour.close()
