"""What each remaining fast twin buys the main job: a float path kept beside an array path of the same computation.

A twin is an array path and a plain-float path of one computation, kept equal for speed; one stays only where
it pays (5 % of the main job's or the campaign's time). The monitor's one, the array scan, is measured by
``design/twin_scan_clean.py``. Deleted after this script measured them below 5 %: the closed-form oblateness of
one position in floats (the compiled closed form serves both) and the harmonic ring's bin filled in floats
(``OrbitRing.add`` is ``add_many`` of one sample). The orbit angles and the orbital axes of one state are no
twins any more (one state and an array of them run the same compiled kernel), nor are the star tracker's
one-frame paths (its frames run one compiled kernel, one message or a batch). Measured here:

* ``true_roll_pitch_floats`` — :func:`pmv_ros.physics.attitude.true_roll_pitch` of one quaternion in floats (the
  monitor's truth; also the closed loop's pointing statistics, one quaternion a control step).

How: the main job (``pmv simulate``'s pipeline on the Kondor preset) runs once for ``--orbits`` while the calls
its monitor and star-tracker runtimes receive, and the states the sensor writes as odometry, are recorded; the
recording is then replayed through those runtimes (and through ``orbital_axes_of_state``) with and without the
fast path — the fast path replaced by the array path it twins, everything else as it is — alternating,
``--pairs`` times, in CPU time. A twin's figure is the median difference over the main job's own CPU time for
the same ticks (measured in the same run): what deleting the fast path would cost it. ``null`` (nothing
replaced) shows the noise. The campaign: each fast path's calls are counted over one campaign task (the worker's
``run_task`` on Meteor-M No.2 at 10 Hz); a fast path the campaign never calls buys it nothing.

``--baseline PATH`` also replays the monitor's recording through another tree's monitor runtime (a checkout of
an older commit), alternating with this tree's: what the monitor's own changes cost the main job.

    .venv/bin/python design/twins_main_job.py [--orbits 0.2] [--pairs 12] [--baseline ../old-checkout]
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import importlib
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_design_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

import numpy as np  # noqa: E402
import yaml  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

KONDOR = REPO / "config" / "kondor.yaml"
METEOR = REPO / "config" / "meteor_m2.yaml"


@contextlib.contextmanager
def patched(*replacements):
    """Set ``(object, name, value)`` for the duration; put the originals back."""
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in replacements]
    try:
        for obj, name, value in replacements:
            setattr(obj, name, value)
        yield
    finally:
        for obj, name, value in saved:
            setattr(obj, name, value)


# --------------------------------------------------------------------------------- the array path in place of each

def _true_roll_pitch_floats():
    from pmv_ros.physics import attitude
    from pmv_ros.runtime.monitor import scan

    arrays = attitude.true_roll_pitch

    def roll_pitch(q):
        if isinstance(q, tuple):
            roll, pitch = arrays(np.array(q, float).reshape(4, 1))
            return float(roll[0]), float(pitch[0])
        return arrays(q)

    return patched((scan, "true_roll_pitch", roll_pitch))


#: Twin → (what replays it, the array path in its place).
TWINS = {
    "null (nothing replaced)": ("monitor", lambda: patched()),
    "true_roll_pitch_floats": ("monitor", _true_roll_pitch_floats),
}

#: The fast paths counted over a campaign task: (module, attribute).
FAST_PATHS = {
    "true_roll_pitch_floats": ("pmv_ros.runtime.monitor.scan", "true_roll_pitch"),
}


# ------------------------------------------------------------------------------------------ record and replay

def record(orbits: float) -> dict:
    """Run the main job for ``orbits``, recording how its monitor and tracker runtimes are made and every call they
    are given, and the states the sensor writes as odometry."""
    import pmv_msgs_shim.conversions as conversions
    from pmv_ros.nodes.pipeline import Pipeline
    from pmv_ros.runtime.monitor.runtime import MonitorRuntime
    from pmv_ros.runtime.tracker.runtime import TrackerRuntime

    made, calls = {}, {"monitor": [], "tracker": [], "odometry": []}

    def recorded(target: str, cls, name: str):
        original = getattr(cls, name)

        def call(self, argument):
            calls[target].append((name, copy.deepcopy(argument)))
            return original(self, argument)

        return cls, name, call

    def recorded_making(target: str, cls):
        original = cls.__init__

        def make(self, *args, **kwargs):
            made[target] = copy.deepcopy(args)  # the values (and the tracker's start); the node's callbacks not
            original(self, *args, **kwargs)

        return cls, "__init__", make

    axes = conversions.orbital_axes_of_state

    def recorded_axes(position, velocity):
        calls["odometry"].append((tuple(map(float, position)), tuple(map(float, velocity))))
        return axes(position, velocity)

    with patched(recorded_making("monitor", MonitorRuntime), recorded_making("tracker", TrackerRuntime),
                 recorded("monitor", MonitorRuntime, "add_inputs"), recorded("monitor", MonitorRuntime, "poll"),
                 recorded("monitor", MonitorRuntime, "health"), recorded("tracker", TrackerRuntime, "add_inputs"),
                 recorded("tracker", TrackerRuntime, "stale_health"),
                 (conversions, "orbital_axes_of_state", recorded_axes)), Pipeline(KONDOR, {}) as pipeline:
        rate = pipeline.sensor.get_parameter("sensor.rate_hz").value
        ticks = max(1, round(orbits * pipeline.sensor.orbit.period_s * rate))
        pipeline.step(ticks)
    return {"made": made, "calls": calls, "ticks": ticks}


def main_job_cpu_per_tick(chunks: int = 6, ticks: int = 1000) -> float:
    """The main job's CPU time per tick, s: the median over ``chunks`` stretches of ``ticks`` after a warm-up."""
    from pmv_ros.nodes.pipeline import Pipeline

    per_tick = []
    with Pipeline(KONDOR, {}) as pipeline:
        pipeline.step(300)
        for _ in range(chunks):
            cpu = time.process_time()
            pipeline.step(ticks)
            per_tick.append((time.process_time() - cpu) / ticks)
    return statistics.median(per_tick)


def replay(target: str, recording: dict, runtime_class=None) -> float:
    """CPU s of the recorded calls of ``target`` (``monitor``, ``tracker``, ``odometry``) replayed on a new runtime."""
    if target == "odometry":
        import pmv_msgs_shim.conversions as conversions

        axes, states = conversions.orbital_axes_of_state, recording["calls"]["odometry"]
        cpu = time.process_time()
        for position, velocity in states:
            axes(position, velocity)
        return time.process_time() - cpu
    if runtime_class is None:
        from pmv_ros.runtime.monitor.runtime import MonitorRuntime
        from pmv_ros.runtime.tracker.runtime import TrackerRuntime

        runtime_class = MonitorRuntime if target == "monitor" else TrackerRuntime
    runtime = runtime_class(*copy.deepcopy(recording["made"][target]))
    calls = recording["calls"][target]
    cpu = time.process_time()
    for name, argument in calls:
        getattr(runtime, name)(argument)
    return time.process_time() - cpu


def alternate(measure_a, measure_b, pairs: int) -> tuple[float, float, float, float]:
    """(median b − a, its first and third quartiles, median a), s: ``pairs`` pairs, the order flipped every pair."""
    measure_a(), measure_b()  # warm-up
    deltas, firsts = [], []
    for k in range(pairs):
        if k % 2 == 0:
            a, b = measure_a(), measure_b()
        else:
            b, a = measure_b(), measure_a()
        deltas.append(b - a)
        firsts.append(a)
    return (statistics.median(deltas), float(np.percentile(deltas, 25)), float(np.percentile(deltas, 75)),
            statistics.median(firsts))


def campaign_calls() -> dict:
    """Each fast path's float-path calls over one campaign task (the worker's ``run_task``, Meteor-M No.2, 10 Hz,
    0.25 orbit)."""
    from pmv_ros.apps import campaign
    from pmv_ros.apps.campaign.results import run_task

    counts, replacements = {}, []
    for twin, (module_name, attribute) in FAST_PATHS.items():
        owner = importlib.import_module(module_name)
        *path, name = attribute.split(".")
        for part in path:
            owner = getattr(owner, part)
        original = getattr(owner, name)
        counts[twin] = 0

        def counted(*args, _original=original, _twin=twin, **kwargs):
            # the float path only: a call with an array of samples is the array path of the same function
            counts[_twin] += not any(isinstance(a, np.ndarray) and a.ndim >= 1 and a.size > 4 for a in args)
            return _original(*args, **kwargs)

        replacements.append((owner, name, counted))
    settings = campaign.Settings(yaml.safe_load(METEOR.read_text()), "2024-01-15T00:00:00Z", 10.0, 0.25)
    with patched(*replacements):
        table, _ = run_task(settings, campaign.Task(day=1, seed=0))
    counts["(samples)"] = table.num_rows
    return counts


def monitor_of(tree: Path):
    """Another tree's MonitorRuntime class (its own modules, imported beside this tree's)."""
    ours = {name: module for name, module in sys.modules.items() if name.split(".")[0] in ("pmv_ros", "pmv_msgs_shim")}
    for name in ours:
        del sys.modules[name]
    sys.path.insert(0, str(tree))
    try:
        module = importlib.import_module("pmv_ros.runtime.monitor.runtime")
        if not Path(module.__file__).resolve().is_relative_to(tree.resolve()):
            raise ValueError(f"{tree} has no pmv_ros package of its own")
        return module.MonitorRuntime
    finally:
        sys.path.remove(str(tree))
        for name in [name for name in sys.modules if name.split(".")[0] in ("pmv_ros", "pmv_msgs_shim")]:
            del sys.modules[name]
        sys.modules.update(ours)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbits", type=float, default=0.2, help="main job recorded, orbits (default 0.2)")
    parser.add_argument("--pairs", type=int, default=12, help="alternating pairs per twin (default 12)")
    parser.add_argument("--baseline", type=Path, default=None, help="another tree: its monitor against this one's")
    args = parser.parse_args(argv)

    loads = [os.getloadavg()[0]]
    recording = record(args.orbits)
    ticks = recording["ticks"]
    main_job_s = main_job_cpu_per_tick() * ticks
    print(f"main job: {ticks} ticks ({args.orbits:g} orbit, Kondor), {main_job_s:.2f} s CPU; "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    calls = campaign_calls()
    samples = calls.pop("(samples)")
    print(f"{'twin':26s} {'main job: without it':>22s} {'(quartiles)':>18s}   "
          f"campaign: calls in a task of {samples} samples")
    for twin, (target, replaced) in TWINS.items():
        try:
            replaced()  # made, not entered: a fast path no longer there says so here
        except (AttributeError, LookupError) as error:
            print(f"{twin:26s} not measured: {error}")
            continue

        def without(_replaced=replaced, _target=target):
            with _replaced():
                return replay(_target, recording)

        delta, low, high, _ = alternate(lambda: replay(target, recording), without, args.pairs)
        print(f"{twin:26s} {100 * delta / main_job_s:+21.2f} % {100 * low / main_job_s:+8.2f} … "
              f"{100 * high / main_job_s:+.2f}   {calls.get(twin, '—')}", flush=True)
        loads.append(os.getloadavg()[0])
    if args.baseline is not None:
        theirs = monitor_of(args.baseline)
        delta, low, high, base = alternate(lambda: replay("monitor", recording, theirs),
                                           lambda: replay("monitor", recording), args.pairs)
        print(f"this tree's monitor against {args.baseline}'s on the same calls: {1e3 * delta:+.0f} ms "
              f"({1e3 * low:+.0f} … {1e3 * high:+.0f}) on {base:.3f} s: {100 * delta / main_job_s:+.2f} % of the "
              "main job")
    loads.append(os.getloadavg()[0])
    print(f"{args.pairs} pairs per twin, CPU time; load average {', '.join(f'{load:.1f}' for load in loads)} on "
          f"{os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
