"""``pmv campaign`` in a child process, with the scheduler's answer timeout shortened for the test.

The child is the real command (``pmv_ros.cli.main``) with one change:
``cluster.SCHEDULER_TIMEOUT_S`` (10 s) set to what the test gives, so that
a test of "one line within the timeout" waits seconds, not the whole 10 s.
A child, not this process: a client still waiting on a silent peer is a
thread that ends only with its process.
"""

from __future__ import annotations

import subprocess
import sys

_CHILD = ("import sys\n"
          "from pmv_ros.apps.campaign import cluster\n"
          "cluster.SCHEDULER_TIMEOUT_S = float(sys.argv[1])\n"
          "from pmv_ros.cli import main\n"
          "sys.exit(main(sys.argv[2:]))\n")


def campaign_child(arguments, scheduler_timeout_s: float, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    """``pmv campaign ARGUMENTS`` with the scheduler timeout ``scheduler_timeout_s``; its status and output."""
    return subprocess.run([sys.executable, "-c", _CHILD, str(scheduler_timeout_s), "campaign", *map(str, arguments)],
                          capture_output=True, text=True, timeout=timeout_s)
