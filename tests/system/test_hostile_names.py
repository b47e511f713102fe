"""A node's command line that rcl refuses ends the node with one line and status 2, never a traceback or a hang.

A well-formed but too-long namespace, node name or remapped topic, or an unknown ROS argument after
``--ros-args``: rcl refuses each only when the context, the node or the topic is made. Each node executable is
started with each, at once (discovery off: nothing is heard); each must end within seconds, say
``<node>: cannot start: <rcl's reason>`` once on stderr and exit 2.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from children import child_env, domain_id

pytestmark = pytest.mark.multi_process

VENV_BIN = Path(sys.executable).parent
#: A cold start of a node on a busy 2-core machine takes a few seconds; a refusal comes before it spins.
TIMEOUT_S = 60.0
LONG = "a" * 300  # rcl's names stop at 255 characters

CASES = {
    "namespace": ["-r", f"__ns:=/{LONG}"],
    "node name": ["-r", f"__node:={LONG}"],
    "remap": ["-r", f"/diagnostics:=/{LONG}"],
    "unknown ROS argument": ["--bogus"],
}
REASONS = {"namespace": "invalid node namespace", "node name": "node name length should not exceed",
           "remap": "topic length should not exceed", "unknown ROS argument": "unknown ROS arguments"}


@pytest.mark.parametrize("node", ["sensor_node", "star_tracker_node", "error_monitor_node"])
def test_a_refused_command_line_is_one_line_and_status_2(node, tmp_path):
    env = child_env(tmp_path / "ros_log", domain_id(1), discovery="OFF")
    started = time.monotonic()
    children = {case: subprocess.Popen([str(VENV_BIN / node), "--ros-args", *arguments], env=env,
                                       stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                       text=True)
                for case, arguments in CASES.items()}
    try:
        said = {case: child.communicate(timeout=TIMEOUT_S) for case, child in children.items()}
    finally:
        for child in children.values():
            child.kill()
    elapsed_s = time.monotonic() - started
    for case, (stdout, stderr) in said.items():
        status = children[case].returncode
        lines = [line for line in stderr.splitlines() if "cannot start" in line]
        assert status == 2, (case, status, stderr)
        assert "Traceback" not in stderr + stdout, (case, stderr)
        assert len(lines) == 1 and lines[0].startswith(f"{node}: cannot start: "), (case, stderr)
        assert REASONS[case] in lines[0] and len(lines[0]) < 300, (case, lines[0])
        assert "RuntimeWarning" not in stderr, (case, stderr)
    print(f"{node}: {len(CASES)} refused command lines in {elapsed_s:.1f} s, all status 2")
