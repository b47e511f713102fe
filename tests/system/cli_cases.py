"""Child process of the hostile-file tests: run ``pmv`` command lines one after another, in this process.

Usage: ``python cli_cases.py CASES.json`` with ``{name: [pmv arguments]}``;
prints one JSON line per case: its exit status, what it printed on stdout and
stderr, its wall and CPU time, and this process's peak resident memory after it
(``VmHWM``: the peak so far, so the largest of these bounds every case; not
``ru_maxrss``, which a child inherits from the process that forked it — a
test runner of several hundred MB).
A case that runs past its time is stopped by SIGALRM and reported as
``"timeout"``.
"""

from __future__ import annotations

import contextlib
import io
import json
import signal
import sys
import time

#: Longest a case may take before it is stopped, s (generous: the bound the tests check is 10 s).
CASE_LIMIT_S = 60


class _Timeout(Exception):
    pass


def _alarm(number, frame):
    raise _Timeout()


def _peak_rss_mb() -> float:
    """This process's own peak resident memory since it was exec'd, MB (Linux /proc)."""
    for line in open("/proc/self/status", encoding="ascii"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmHWM in /proc/self/status")


def main() -> None:
    from pmv_ros.cli import main as pmv

    cases = json.loads(open(sys.argv[1], encoding="utf-8").read())
    signal.signal(signal.SIGALRM, _alarm)
    for name, argv in cases.items():
        out, err = io.StringIO(), io.StringIO()
        started, started_cpu = time.monotonic(), time.process_time()
        signal.alarm(CASE_LIMIT_S)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    status = pmv(argv)
                except SystemExit as stop:  # argparse
                    status = stop.code
        except _Timeout:
            status = "timeout"
        except BaseException:  # a traceback: reported, the test fails on it
            import traceback

            status = "exception"
            err.write(traceback.format_exc())
        finally:
            signal.alarm(0)
        wall_s, cpu_s = time.monotonic() - started, time.process_time() - started_cpu
        peak_mb = _peak_rss_mb()
        print(json.dumps({"name": name, "status": status, "stdout": out.getvalue(), "stderr": err.getvalue(),
                          "wall_s": wall_s, "cpu_s": cpu_s, "peak_mb": peak_mb}), flush=True)


if __name__ == "__main__":
    main()
