"""Run a command as a child process and measure it: exit status, stdout, stderr, wall and CPU time, peak memory.

The peak is the child's own maximum resident set (``resource.getrusage``
of the children of a small wrapper process that has no other child), so it
counts what the command took, not the test process. The CPU time is the
child's user + system time: the work the command did, whatever else loads
the machine. ``limit_mb`` caps the child's address space (``RLIMIT_AS``), so a
command that would take gigabytes — the code a fix replaced, run for
comparison — fails there instead of pressing on a shared machine.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass

_WRAPPER = """
import json, resource, subprocess, sys, time
timeout_s, limit_mb = float(sys.argv[1]), int(sys.argv[2])

def limit():
    if limit_mb:
        resource.setrlimit(resource.RLIMIT_AS, (limit_mb << 20, limit_mb << 20))

started = time.monotonic()
try:
    status = subprocess.run(sys.argv[3:], timeout=timeout_s, preexec_fn=limit).returncode
except subprocess.TimeoutExpired:
    status = "timeout"
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
sys.stderr.write("\\n@@" + json.dumps({"status": status, "peak_mb": usage.ru_maxrss / 1024.0,
                                       "cpu_s": usage.ru_utime + usage.ru_stime,
                                       "wall_s": time.monotonic() - started}) + "\\n")
"""


@dataclass(frozen=True)
class Run:
    status: int | str
    stdout: str
    stderr: str
    peak_mb: float
    wall_s: float
    cpu_s: float = 0.0

    def summary(self) -> str:
        """One line for a test's printed figures: status, times, peak and the last line on stderr."""
        last = self.stderr.strip().splitlines()[-1] if self.stderr.strip() else ""
        return (f"status {self.status}, {self.wall_s:.2f} s wall, {self.cpu_s:.2f} s CPU, peak {self.peak_mb:.0f} MB"
                + (f": {last}" if last else ""))


def run_measured(argv, *, timeout_s: float = 60.0, env=None, cwd=None, stdin=subprocess.DEVNULL,
                 limit_mb: int = 0) -> Run:
    """``argv`` run to its end (killed after ``timeout_s``): what it printed, its status, time and peak memory.

    ``limit_mb``: the child's address-space limit, MB (0: none).
    """
    result = subprocess.run([sys.executable, "-c", _WRAPPER, str(timeout_s), str(int(limit_mb)), *map(str, argv)],
                            capture_output=True, text=True, env=env, cwd=cwd, stdin=stdin, timeout=timeout_s + 30)
    stderr, _, tail = result.stderr.rpartition("\n@@")
    measured = json.loads(tail)
    return Run(measured["status"], result.stdout, stderr, measured["peak_mb"], measured["wall_s"], measured["cpu_s"])


def pmv(*arguments) -> list[str]:
    """The ``pmv`` command line of this environment."""
    return [sys.executable, "-m", "pmv_ros.cli", *map(str, arguments)]


def node(name: str) -> list[str]:
    """A node's console script of this environment."""
    return [os.path.join(os.path.dirname(sys.executable), name)]
