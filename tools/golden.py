"""Golden outputs of the ``pmv`` command line: capture them once, compare every later tree against them.

A code move must not change a figure. This tool runs a fixed set of ``pmv``
commands (``simulate`` for the three presets at a fixed seed, one of them
recorded and then analysed, ``campaign`` on a few tasks, ``scenario`` A–D and
``oblateness``), each through the console script's ``main(argv)`` in this
process, and keeps their ``--json`` output.

    python tools/golden.py capture            # writes tests/data/golden.json
    python tools/golden.py compare            # exit 1 and one line per difference

Numbers must agree to ``TOLERANCE_ARCMIN`` (1e-9′): the outputs are in
arcminutes, metres and counts, and a move that only reorders floating-point
sums may change the last bits but not the ninth decimal. Fields that measure
the machine (wall time, rates) or name a temporary folder are left out.

The machine itself must not move a figure either: numpy and OpenBLAS choose
their kernels by CPU, and on an AVX-512 machine the transcendental functions
and matrix products differ from the AVX2 ones in their last bits, which the
sensitive parts of a run (the random fields, the weather) carry to ≈ 1e-7′ in
the outputs. So on x86-64 both commands run in a child process with the
kernels pinned at the AVX2 level (:data:`PINNED_NUMERICS`), the level the
capture was made at; production runs with whatever the CPU offers.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN_PATH = ROOT / "tests" / "data" / "golden.json"

#: Agreement required of every number (arcminutes; the same figure for metres and counts is far stricter than needed).
TOLERANCE_ARCMIN = 1e-9

#: Keys whose values describe the machine or the temporary folder, not the physics.
VOLATILE_KEYS = frozenset({"wall_s", "task_compute_s", "samples_per_s_per_worker", "file", "out", "scheduler"})

#: numpy's and OpenBLAS's kernels for the golden runs on an x86-64 CPU with AVX2: the AVX2 level (x86-64-v3).
#: The feature names are numpy 2.4's (requirements.txt pins it; older numpy names them otherwise).
PINNED_NUMERICS = {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR"}

SEED = 7
SIMULATE_ORBITS = "0.02"
PRESETS = ("kondor", "meteor_m2", "meteor_m2_2")


def commands(workdir: Path) -> dict[str, list[str]]:
    """Name → ``pmv`` arguments, in the order they must run (the analysis reads the recording)."""
    recording = workdir / "kondor.mcap"
    runs: dict[str, list[str]] = {}
    for preset in PRESETS:
        argv = ["simulate", "--config", f"config/{preset}.yaml", "--orbits", SIMULATE_ORBITS,
                "--seed", str(SEED), "--quiet", "--json"]
        if preset == "kondor":
            argv += ["--record", str(recording)]
        runs[f"simulate_{preset}"] = argv
    runs["analyze_kondor_recording"] = ["analyze", str(recording), "--altitude-km", "500",
                                        "--inclination-deg", "74.5", "--json"]
    runs["campaign_meteor_m2"] = ["campaign", "--config", "config/meteor_m2.yaml", "--days", "1,183",
                                  "--seeds", "2", "--orbits-per-task", "0.05", "--workers", "1",
                                  "--out", str(workdir / "campaign"), "--quiet", "--json"]
    for model in "ABCD":
        runs[f"scenario_{model}"] = ["scenario", model, "--json"]
    runs["oblateness_kondor"] = ["oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--json"]
    runs["oblateness_meteor_closed_form"] = ["oblateness", "--altitude-km", "835", "--inclination-deg", "98.7",
                                             "--closed-form", "--convention", "ros", "--json"]
    return runs


def run_all(workdir: Path) -> dict[str, object]:
    """Every command's JSON output with the volatile keys removed, each run in this process (``main(argv)``)."""
    os.environ.setdefault("ROS_LOG_DIR", str(workdir / "ros_log"))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")
    from pmv_ros.cli import main as pmv

    outputs: dict[str, object] = {}
    here = os.getcwd()
    os.chdir(ROOT)  # the presets are named relative to the repository
    try:
        for name, argv in commands(workdir).items():
            out, err = io.StringIO(), io.StringIO()
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                status = pmv(argv)
            if status != 0:
                raise RuntimeError(f"pmv {' '.join(argv)} exited {status}: {err.getvalue().strip()[-400:]}")
            outputs[name] = _strip(json.loads(out.getvalue()))
    finally:
        os.chdir(here)
    return outputs


def _strip(value):
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if k not in VOLATILE_KEYS}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def differences(expected, actual, path: str = "") -> list[str]:
    """One line per place where ``actual`` differs from ``expected`` beyond the tolerance."""
    if isinstance(expected, dict) and isinstance(actual, dict):
        lines = [f"{path}/{k}: missing" for k in expected if k not in actual]
        lines += [f"{path}/{k}: new" for k in actual if k not in expected]
        for key in expected.keys() & actual.keys():
            lines += differences(expected[key], actual[key], f"{path}/{key}")
        return lines
    if isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            return [f"{path}: {len(expected)} items, now {len(actual)}"]
        return [line for i, (e, a) in enumerate(zip(expected, actual)) for line in differences(e, a, f"{path}[{i}]")]
    numbers = (int, float)
    if isinstance(expected, numbers) and isinstance(actual, numbers) and not isinstance(expected, bool):
        if math.isclose(expected, actual, rel_tol=0.0, abs_tol=TOLERANCE_ARCMIN):
            return []
        return [f"{path}: {expected!r}, now {actual!r}"]
    return [] if expected == actual else [f"{path}: {expected!r}, now {actual!r}"]


def avx2_machine() -> bool:
    """An x86-64 CPU with AVX2, the level the kernels are pinned at (a CPU without it cannot run them)."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        with open("/proc/cpuinfo", "rb") as stream:
            return b" avx2" in stream.read(1 << 20)
    except OSError:
        return False


def numerics_pinned() -> bool:
    """True where this process computes with :data:`PINNED_NUMERICS`, or where they cannot apply (not an
    x86-64 CPU with AVX2: its figures may then differ from the capture in the last bits)."""
    if not avx2_machine():
        return True
    return all(os.environ.get(name) == value for name, value in PINNED_NUMERICS.items())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("capture", "compare"))
    parser.add_argument("--golden", type=Path, default=GOLDEN_PATH)
    args = parser.parse_args(argv)
    if not numerics_pinned():  # numpy has chosen its kernels at import: run again in a child that pins them
        child = [sys.executable, str(Path(__file__).resolve()), *(sys.argv[1:] if argv is None else argv)]
        return subprocess.run(child, env={**os.environ, **PINNED_NUMERICS}).returncode
    with tempfile.TemporaryDirectory(prefix="pmv_golden_") as tmp:
        outputs = run_all(Path(tmp))
    if args.action == "capture":
        args.golden.parent.mkdir(parents=True, exist_ok=True)
        args.golden.write_text(json.dumps(outputs, indent=1, sort_keys=True) + "\n")
        print(f"wrote {args.golden} ({len(outputs)} outputs)")
        return 0
    lines = differences(json.loads(args.golden.read_text()), outputs)
    for line in lines:
        print(line)
    print(f"{len(outputs)} outputs, {len(lines)} differences beyond {TOLERANCE_ARCMIN}′")
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
