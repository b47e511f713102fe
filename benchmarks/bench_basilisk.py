"""What the PMV module costs a Basilisk simulation: steps a second with and without it, in one run.

Two scenarios, each flown for ``--seconds`` of simulation time in one 10 Hz task, with and without the PMV:

* Kondor (pmv_ros.hosts.basilisk.kondor_scenario: spacecraft, two-body gravity, simpleNav, hillPoint →
  attTrackingError → mrpFeedback → external torque on truth): ``bare``; ``python module`` (a Python SysModel
  that only reads SCStatesMsg: the floor of any Python module); ``pmv`` (the preset's instrument and
  environment, a sample a step); ``pmv, geometric`` (ideal detector, uniform radiance, no Sun/Moon check);
* Meteor-M No.2 (examples/basilisk_meteor.py: J2, reaction wheels, the attitude loop closed through the PMV and
  its navigation bridge): ``meteor bare`` (the same FSW on simpleNav) and ``meteor, PMV in the loop``.

Rounds alternate the cases; each figure is the best of its rounds, in CPU time of this process (Basilisk and
the module run on one thread; on a shared machine wall time measures the neighbours). The module's cost per
step is 1/rate − 1/rate(bare), measured in the same run. The headline: the Kondor scenario with the PMV at
each step, against the same scenario without it.

    .venv/bin/python benchmarks/bench_basilisk.py [--rounds 3] [--seconds 60]
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import sys
import time
from pathlib import Path

try:
    from Basilisk.architecture import messaging, sysModel
except ImportError:
    print("bench_basilisk: not run here: bsk (Basilisk) is not installed (pip install pmv_ros[basilisk])")
    sys.exit(3)

from pmv_ros.hosts.basilisk import kondor_scenario

REPO = Path(__file__).resolve().parents[1]
PRESET = str(REPO / "config" / "kondor.yaml")
GEOMETRIC = {"sensor.detector": "ideal", "radiance.source": "uniform", "sensor.bright_body_exclusion_deg": 0.0}
STEP_S = 0.1


def _meteor():
    spec = importlib.util.spec_from_file_location("basilisk_meteor", REPO / "examples" / "basilisk_meteor.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


METEOR = _meteor()


class StateProbe(sysModel.SysModel):
    """Reads the spacecraft's state at each step, and nothing else."""

    def __init__(self):
        super().__init__()
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.last = None

    def UpdateState(self, CurrentSimNanos):
        self.last = self.scStateInMsg().r_BN_N


CASES = {
    "bare": lambda: kondor_scenario(PRESET, pmv=False),
    "python module": lambda: kondor_scenario(PRESET, pmv=False, extra=(StateProbe(),)),
    "pmv": lambda: kondor_scenario(PRESET),
    "pmv, geometric": lambda: kondor_scenario(PRESET, GEOMETRIC),
    "meteor bare": lambda: METEOR.MeteorScenario(pmv=False),
    "meteor, PMV in the loop": lambda: METEOR.MeteorScenario(),
}
#: The baseline of each case: the same scenario without the module.
BASELINE = {"python module": "bare", "pmv": "bare", "pmv, geometric": "bare",
            "meteor, PMV in the loop": "meteor bare"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=60.0, help="simulation time per case and round, s")
    args = parser.parse_args()
    best = dict.fromkeys(CASES, math.inf)
    steps = round(args.seconds / STEP_S)
    for _ in range(args.rounds):
        for name, build in CASES.items():
            scenario = build()
            started = time.process_time()
            scenario.run(args.seconds)
            best[name] = min(best[name], time.process_time() - started)
    print(f"{steps} steps of {STEP_S} s per case, best of {args.rounds} rounds, CPU time; "
          f"load {os.getloadavg()[0]:.2f}")
    for name, seconds in best.items():
        per_step = seconds / steps
        base = BASELINE.get(name)
        added = "" if base is None else f"   +{(per_step - best[base] / steps) * 1e6:8.1f} µs a step"
        print(f"  {name:24s} {1.0 / per_step:9.0f} steps/s{added}")
    from headline import headline
    headline("basilisk", "Basilisk's Kondor scenario with the PMV module at each step", steps / best["pmv"],
             "steps/s", "higher", steps / best["bare"], "steps/s", "the same scenario without the module",
             ratio=best["bare"] / best["pmv"])


if __name__ == "__main__":
    main()
