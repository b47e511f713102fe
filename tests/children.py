"""The environment of child processes (nodes, launch, CLI runs) and of this process joining their domain.

One home for what five test modules once wrote each: a ROS domain of the
test's own, derived from the pid so that concurrent runs do not hear each
other; discovery on localhost (or OFF for children that never talk); no
inherited variable that would steer discovery elsewhere.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import rclpy

#: Variables that would steer discovery elsewhere than our domain on localhost.
DISCOVERY_ENV = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY",
                 "ROS_DISCOVERY_SERVER", "ROS_SUPER_CLIENT", "FASTRTPS_DEFAULT_PROFILES_FILE",
                 "FASTDDS_DEFAULT_PROFILES_FILE")
#: The venv bootstrapper's state: a child without it sets up the ROS library
#: path itself, as when started from a fresh shell.
BOOTSTRAP_ENV = ("_ROS_WHEELS_BOOTSTRAP_COMPLETE", "LD_LIBRARY_PATH")
PYTHON_LIB = f"lib/python{sys.version_info.major}.{sys.version_info.minor}/site-packages"

#: ../shared/vendor beside the repository (as CI lays it out), or where PMV_ROS_VENDOR points: snapshots of the
#: real ROS 2 tools (ros2cli, launch) and tf2_msgs with the script that installs them into a venv copy.
VENDOR = Path(os.environ.get("PMV_ROS_VENDOR") or Path(__file__).resolve().parents[2] / "shared" / "vendor")
VENDOR_INSTALLER = VENDOR / "install-ros-tools.sh"


def domain_id(block: int) -> int:
    """A ROS domain of this run's own in ``block`` (0: 1…99, 1: 101…199): apart from other runs by the pid,
    and from the other workers of a parallel run (``pytest -n 2`` or ``-n 3``) by the worker's number.

    Test modules whose children may overlap in time take different blocks.
    """
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw")
    return 1 + 100 * block + 3 * (os.getpid() % 33) + (int(worker) if worker.isdigit() else 0) % 3


def child_env(log_dir: Path, domain: int, *, discovery: str = "LOCALHOST", fresh_shell: bool = False,
              **extra: str) -> dict:
    """The environment of a child on ``domain`` with discovery ``LOCALHOST`` (or ``OFF``).

    ``fresh_shell`` also drops the venv bootstrapper's state, as for a node
    started from a new terminal.
    """
    dropped = DISCOVERY_ENV + (BOOTSTRAP_ENV if fresh_shell else ())
    env = {name: value for name, value in os.environ.items() if name not in dropped}
    env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE=discovery, ROS_LOG_DIR=str(log_dir))
    env.update(extra)
    return env


def install_env(install: Path, log_dir: Path, domain: int) -> dict:
    """What ``source install/setup.bash`` adds for this package (its hooks: pythonpath, ament_prefix_path)."""
    prefix = install / "pmv_ros"
    return child_env(
        log_dir, domain, fresh_shell=True,
        PYTHONPATH=os.pathsep.join(p for p in (str(prefix / PYTHON_LIB), os.environ.get("PYTHONPATH")) if p),
        AMENT_PREFIX_PATH=os.pathsep.join(p for p in (str(prefix), os.environ.get("AMENT_PREFIX_PATH")) if p),
    )


def join_domain(monkeypatch, domain: int) -> rclpy.Context:
    """An initialised rclpy context of this process on the children's domain, discovery on localhost.

    conftest.py turned discovery OFF for the in-process tests; the caller shuts the context down.
    """
    for name in DISCOVERY_ENV:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    return context
