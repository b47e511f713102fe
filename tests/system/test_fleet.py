"""Load: eight spacecraft in one domain (issue 29) — 24 node processes at the Kondor preset's rates, 60 s.

Eight spacecraft ``sat1`` … ``sat8``, each the three nodes as console scripts in its namespace (frames with
its prefix), on the wall clock, on one ROS domain of the test's own: 10 Hz sensors with the signal chain and
the radiance environment, 2 Hz star trackers, monitors. This test process listens to every spacecraft's
``pmv/attitude`` and ``pmv/residual``. After a warm-up (every monitor has aligned samples, then 5 s more)
it measures for 60 s:

* every monitor aligned ≥ 99 % of its own sensor's samples of the window (a sample's residual carries its
  stamp), every sample and residual in its own spacecraft's sensor frame (none took another's samples);
* no process's resident memory grew by 10 MB or more over the window (RSS flat after the warm-up).

Marked ``long``: the default run flies two spacecraft for 5 s; ``--run-long`` the eight for 60 s.
"""

from __future__ import annotations

import copy
import time

import pytest
import yaml
from geometry_msgs.msg import Vector3Stamped
from neighbour import Neighbour, output_of, proc_status, running_nodes
from rclpy.qos import QoSProfile

import pmv_msgs_shim as shim

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

NODES = ("sensor_node", "star_tracker_node", "error_monitor_node")
SHORT, FULL = (2, 5.0), (8, 60.0)
RSS_GROWTH_MB, TAKEN = 10.0, 0.99


def _params(fleet: list[str]) -> str:
    """kondor.yaml with its node sections given to each spacecraft's nodes (rcl matches full names), and the
    spacecraft's frame prefix."""
    from pathlib import Path

    preset = yaml.safe_load((Path(__file__).resolve().parents[2] / "config" / "kondor.yaml").read_text())
    document = {"/**": preset["/**"]}
    for name in fleet:
        for node in NODES:
            section = {"ros__parameters": {**copy.deepcopy(preset.get(node, {}).get("ros__parameters", {})),
                                           "frames": {"prefix": f"{name}/"}}}  # copies: no YAML aliases
            document[f"/{name}/{node}"] = section
    return yaml.safe_dump(document)


@pytest.mark.long
def test_eight_spacecraft_in_one_domain_keep_every_sample_and_flat_memory(tmp_path, run_long):
    count, window_s = FULL if run_long else SHORT
    fleet = [f"sat{k}" for k in range(1, count + 1)]
    names = [f"{node}:{sat}" for sat in fleet for node in NODES]
    arguments = {name: [] for name in names}
    with running_nodes(tmp_path, _params(fleet), nodes=names, arguments=arguments,
                       ros_arguments={name: ["-r", f"__ns:=/{name.split(':')[1]}"] for name in names}) as processes:
        neighbour = Neighbour()
        try:
            got = {sat: {"attitude": [], "residual": []} for sat in fleet}
            for sat in fleet:
                for topic in ("attitude", "residual"):
                    neighbour.node.create_subscription(Vector3Stamped, f"/{sat}/pmv/{topic}", got[sat][topic].append,
                                                       QoSProfile(depth=1000))

            def died() -> list:
                return [name for name, process in processes.items() if process.poll() is not None]

            started = time.monotonic()
            neighbour.wait_until(lambda: died() or all(len(got[sat]["residual"]) > 5 for sat in fleet), 240.0,
                                 "residuals from every spacecraft")
            assert not died(), {name: output_of(tmp_path, name)[-1500:] for name in died()}
            up_s = time.monotonic() - started
            neighbour.spin(5.0)  # warm-up
            rss_before = {name: proc_status(process.pid)["rss_mb"] for name, process in processes.items()}
            window_from = time.time()
            neighbour.spin(window_s)
            window_to = time.time()
            rss_after = {name: proc_status(process.pid)["rss_mb"] for name, process in processes.items()}

            def window(sat) -> list:
                return [t for t in (shim.time_from_msg(m.header.stamp) for m in got[sat]["attitude"])
                        if window_from <= t <= window_to]

            deadline = time.monotonic() + 30.0  # each window's last residual comes with its truth (latency)
            while not all(got[sat]["residual"] and shim.time_from_msg(got[sat]["residual"][-1].header.stamp)
                          >= max(window(sat)) for sat in fleet):
                assert time.monotonic() < deadline, "the monitors did not catch up within 30 s of the window"
                neighbour.spin(0.2)
            assert not died(), {name: output_of(tmp_path, name)[-1500:] for name in died()}
            taken, worst = {}, {}
            for sat in fleet:
                stamps = window(sat)
                aligned = {round(shim.time_from_msg(m.header.stamp), 3) for m in got[sat]["residual"]}
                taken[sat] = (sum(round(t, 3) in aligned for t in stamps), len(stamps))
                worst[sat] = {m.header.frame_id for m in got[sat]["residual"] + got[sat]["attitude"]}
            growth = {name: rss_after[name] - rss_before[name] for name in processes}
            print(f"fleet of {count} ({len(processes)} processes) up in {up_s:.0f} s; over {window_s:g} s: monitors "
                  f"took {taken}; frames {sorted(set().union(*worst.values()))}; RSS {min(rss_before.values()):.0f}–"
                  f"{max(rss_before.values()):.0f} MB, largest growth {max(growth.values()):+.2f} MB "
                  f"({max(growth, key=growth.get)})")
            for sat, (aligned, samples) in taken.items():
                assert samples >= 0.9 * 10 * window_s, (sat, samples)  # the sensor kept its 10 Hz
                assert aligned >= TAKEN * samples, (sat, aligned, samples)
                assert worst[sat] == {f"{sat}/pmv_sensor"}, (sat, worst[sat])  # each its own, none another's
            assert max(growth.values()) < RSS_GROWTH_MB, growth
        finally:
            neighbour.close()
