"""Run a command as a child process and measure it: exit status, stdout, stderr, wall time, peak memory.

The peak is the child's own maximum resident set (``resource.getrusage``
of the children of a small wrapper process that has no other child), so it
counts what the command took, not the test process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass

_WRAPPER = """
import json, resource, subprocess, sys, time
started = time.monotonic()
try:
    status = subprocess.run(sys.argv[2:], timeout=float(sys.argv[1])).returncode
except subprocess.TimeoutExpired:
    status = "timeout"
peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
sys.stderr.write("\\n@@" + json.dumps({"status": status, "peak_mb": peak_kb / 1024.0,
                                       "wall_s": time.monotonic() - started}) + "\\n")
"""


@dataclass(frozen=True)
class Run:
    status: int | str
    stdout: str
    stderr: str
    peak_mb: float
    wall_s: float


def run_measured(argv, *, timeout_s: float = 60.0, env=None, cwd=None, stdin=subprocess.DEVNULL) -> Run:
    """``argv`` run to its end (killed after ``timeout_s``): what it printed, its status, time and peak memory."""
    result = subprocess.run([sys.executable, "-c", _WRAPPER, str(timeout_s), *map(str, argv)], capture_output=True,
                            text=True, env=env, cwd=cwd, stdin=stdin, timeout=timeout_s + 30)
    stderr, _, tail = result.stderr.rpartition("\n@@")
    measured = json.loads(tail)
    return Run(measured["status"], result.stdout, stderr, measured["peak_mb"], measured["wall_s"])


def pmv(*arguments) -> list[str]:
    """The ``pmv`` command line of this environment."""
    return [sys.executable, "-m", "pmv_ros.cli", *map(str, arguments)]


def node(name: str) -> list[str]:
    """A node's console script of this environment."""
    return [os.path.join(os.path.dirname(sys.executable), name)]
