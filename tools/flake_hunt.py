"""Run the suite's multi-process and serial tests N times in a row and count each test's passes.

A test that waits on the wrong thing passes alone on a quiet machine and fails on a busy one. This tool
repeats the tests where such races live — those marked ``serial`` (rates of wall time) and ``multi_process``
(they start child processes: nodes on a DDS domain, ros2 launch, a Dask cluster, pmv in a child), selected by
their marks (``-m``) — optionally beside a CPU hog, one busy process per core, and prints one line per test:
how many runs it passed, failed (with the first line of the first failure) and was skipped.

    python tools/flake_hunt.py --runs 10 --hog                 # every such test, 10 runs, cores busy
    python tools/flake_hunt.py --runs 3 tests/system/test_adversarial.py
    python tools/flake_hunt.py --runs 5 --marks serial          # another mark expression

Each run is one ``pytest`` process over the chosen tests, in order, without xdist: the hog is the load.
The session fixtures' early work (the colcon build, the vendored ROS tools, the Kondor orbit: see
``tests/conftest.py``) is done in the first run and reused by the later ones, so the runs repeat the tests,
not the builds. Exit status 1 if any test failed in any run.
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: The marks of the tests repeated by default.
MARKS = "serial or multi_process"


def _early_env() -> str:
    """The variable through which tests/conftest.py keeps the early work's folder across runs (its home)."""
    sys.path.insert(0, str(ROOT / "tests"))
    spec = importlib.util.spec_from_file_location("pmv_ros_tests_conftest", ROOT / "tests" / "conftest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.EARLY_ENV


def _hog() -> None:
    """Keep one core busy until killed."""
    while True:
        pass


def _outcomes(report: Path) -> dict:
    """test id → ("passed" | "failed" | "skipped", first line of the failure) from a JUnit XML report."""
    outcomes = {}
    if not report.is_file():
        return outcomes
    for case in ElementTree.parse(report).getroot().iter("testcase"):
        name = f"{case.get('classname', '')}::{case.get('name')}"
        failure = case.find("failure")
        if failure is None:
            failure = case.find("error")
        if failure is not None:
            text = (failure.get("message") or failure.text or "").strip().splitlines()
            outcomes[name] = ("failed", text[0][:160] if text else "")
        elif case.find("skipped") is not None:
            outcomes[name] = ("skipped", "")
        else:
            outcomes[name] = ("passed", "")
    return outcomes


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("modules", nargs="*", help="test modules or ids (default: the whole suite, by --marks)")
    parser.add_argument("--marks", default=MARKS, help=f"mark expression of the tests repeated (default {MARKS!r})")
    parser.add_argument("--runs", type=int, default=10, help="runs in a row (default 10)")
    parser.add_argument("--hog", action="store_true", help="a busy process on every core for the whole hunt")
    parser.add_argument("--hogs", type=int, default=None, help="how many busy processes (default: one per core)")
    parser.add_argument("--pytest-args", default="", help="more pytest arguments, one string (e.g. '-k clock')")
    parser.add_argument("--keep", default=None, help="folder for the reports and logs (default: a temporary one)")
    args = parser.parse_args(argv)

    modules = args.modules or ["tests"]
    work = Path(args.keep or tempfile.mkdtemp(prefix="flake_hunt_"))
    work.mkdir(parents=True, exist_ok=True)
    early = work / "early"
    early.mkdir(exist_ok=True)
    env = dict(os.environ, **{_early_env(): str(early)})
    env.setdefault("ROS_LOG_DIR", str(work / "ros_log"))

    hogs = []
    if args.hog:
        for _ in range(args.hogs or os.cpu_count() or 1):
            process = multiprocessing.Process(target=_hog, daemon=True)
            process.start()
            hogs.append(process)
    print(f"flake hunt: {' '.join(modules)} -m {args.marks!r}, {args.runs} runs, {len(hogs)} CPU hogs; "
          f"reports in {work}", flush=True)
    results = collections.defaultdict(list)  # test id → [(outcome, detail)] in run order
    started = time.monotonic()
    try:
        for run in range(1, args.runs + 1):
            report = work / f"run_{run:02d}.xml"
            command = [sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                       f"--junitxml={report}", "-m", args.marks, *args.pytest_args.split(), *modules]
            run_started = time.monotonic()
            with open(work / f"run_{run:02d}.log", "w") as log:
                status = subprocess.run(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL).returncode
            outcomes = _outcomes(report)
            for name, outcome in outcomes.items():
                results[name].append(outcome)
            counts = collections.Counter(outcome for outcome, _ in outcomes.values())
            print(f"run {run}/{args.runs}: exit {status}, {counts['passed']} passed, {counts['failed']} failed, "
                  f"{counts['skipped']} skipped in {time.monotonic() - run_started:.0f} s", flush=True)
            if not outcomes:
                print(f"  no report: see {work / f'run_{run:02d}.log'}", flush=True)
                results["<run without a report>"].append(("failed", f"exit {status}"))
    finally:
        for process in hogs:
            process.kill()
            process.join()

    width = max((len(name) for name in results), default=10)
    failed_any = False
    print(f"\n{'test':<{width}}  passed  failed  skipped")
    for name in sorted(results):
        counts = collections.Counter(outcome for outcome, _ in results[name])
        failures = [detail for outcome, detail in results[name] if outcome == "failed"]
        failed_any = failed_any or bool(failures)
        print(f"{name:<{width}}  {counts['passed']:>6}  {counts['failed']:>6}  {counts['skipped']:>7}"
              + (f"  first failure: {failures[0]}" if failures else ""))
    totals = collections.Counter(outcome for outcomes in results.values() for outcome, _ in outcomes)
    print(f"\ntotal over {args.runs} runs ({len(hogs)} CPU hogs, {time.monotonic() - started:.0f} s): "
          f"{totals['passed']} passed, {totals['failed']} failed, {totals['skipped']} skipped")
    return 1 if failed_any else 0


if __name__ == "__main__":
    sys.exit(main())
