"""What each remaining fast twin buys the main job: a float path kept beside an array path of the same computation.

A twin is an array path and a plain-float path of one computation, kept equal for speed; one stays only where
it pays (5 % of the main job's or the campaign's time). This script measures the twins the tree still has
outside the monitor (whose one, the array scan, ``design/twin_scan_clean.py`` measures):

* ``closed_form_scalar`` — :func:`pmv_ros.physics.instrument.oblateness.closed_form_oblateness` of one orbit
  position in floats;
* ``orbit_angles_floats`` — :func:`pmv_ros.physics.orbit.two_body.orbit_angles_from_state` of one state in
  floats (the monitor's odometry);
* ``orbital_axes_floats`` — :func:`pmv_ros.physics.orbit.two_body.orbital_axes_of_state` (the shim's odometry
  message, one per sample);
* ``true_roll_pitch_floats`` — :func:`pmv_ros.physics.attitude.true_roll_pitch` of one quaternion in floats (the
  monitor's truth);
* ``ring_add_floats`` — :meth:`pmv_ros.analysis.statistics.OrbitRing.add`, the bin being filled in floats, which
  ``add_many`` takes below ``_FEW`` samples;
* the star tracker's one message in floats: ``tracker_measure_one`` (:meth:`StarTracker.measure_one` beside
  ``measure_groups``), ``tracker_grid_floats`` (:meth:`FrameGrid.add` with ``slerp`` beside ``add_many`` with
  ``slerp_each``), ``tracker_queue_singles`` (:class:`LatencyQueue`'s frames pushed one at a time beside its
  arrays), and ``tracker_one_message`` (all of them: a truth message through the array path).

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
import inspect
import os
import statistics
import sys
import tempfile
import textwrap
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

def _closed_form_scalar():
    from pmv_ros.physics.instrument import oblateness

    arrays = oblateness.closed_form_oblateness

    def scalar(u, h, inclination, ellipsoid, r):
        meridional, roll, pitch = arrays(np.array([u]), np.array([h]), inclination, ellipsoid, r)
        return float(meridional[0]), float(roll[0]), float(pitch[0])

    return patched((oblateness, "_closed_form_oblateness_scalar", scalar))


def _orbit_angles_floats():
    from pmv_ros.physics.orbit import two_body
    from pmv_ros.runtime.monitor import records

    def angles(position, velocity):
        u, inclination, altitude = two_body._orbit_angles_arrays(np.asarray(position, float).reshape(3, 1),
                                                                 np.asarray(velocity, float).reshape(3, 1))
        return float(u[0]), float(inclination[0]), float(altitude[0])

    return patched((records, "orbit_angles_from_state", angles))


def _orbital_axes_floats():
    import pmv_msgs_shim.conversions as conversions
    from pmv_ros.physics.orbit import two_body

    def axes(position, velocity):
        frame = two_body.orbital_frame_from_state(np.asarray(position, float), np.asarray(velocity, float))
        return tuple(tuple(frame[:, k].tolist()) for k in range(3))

    return patched((conversions, "orbital_axes_of_state", axes))


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


def _ring_add_floats():
    from pmv_ros.analysis import statistics as ring_module

    return patched((ring_module, "_FEW", 0))


def _measure_groups_on_arrays():
    """:meth:`StarTracker.measure_groups` without its one-frame branch to :meth:`measure_one` (its source, that
    branch cut out); LookupError where the branch is not there any more."""
    from pmv_ros.physics import star_tracker

    lines = textwrap.dedent(inspect.getsource(star_tracker.StarTracker.measure_groups)).splitlines()
    start = next((i for i, line in enumerate(lines) if "self.measure_one(" in line), None)
    if start is None:
        raise LookupError("StarTracker.measure_groups has no one-frame branch")
    branch = start - 1  # the ``if`` that leads to it, its call and its return
    if "if " not in lines[branch] or "return" not in lines[start + 1]:
        raise LookupError("StarTracker.measure_groups: its one-frame branch is not the expected three lines")
    del lines[branch:start + 2]
    namespace = dict(vars(star_tracker))
    exec("\n".join(lines), namespace)  # noqa: S102 - the module's own source, one branch cut
    return namespace["measure_groups"]


def _tracker_measure_one():
    from pmv_ros.physics import star_tracker

    on_arrays = _measure_groups_on_arrays()

    def measure_one(self, t_s, q_true, rate_rad_s):
        measured, outcome = on_arrays(self, np.array([t_s]), np.array(q_true, float).reshape(4, 1),
                                      np.array([rate_rad_s]), [1])
        return tuple(measured[:, 0].tolist()), int(outcome[0])

    return patched((star_tracker.StarTracker, "measure_groups", on_arrays),
                   (star_tracker.StarTracker, "measure_one", measure_one))


def _tracker_grid_floats():
    from pmv_ros.physics import star_tracker

    def add(self, t_s, q_xyzw):
        frames = self.add_many(np.array([float(t_s)]), np.asarray(q_xyzw, float).reshape(4, 1))
        if not frames.frame_s.size:
            return [], [], (0.0, 0.0, 0.0)
        return (frames.frame_s.tolist(), [tuple(q) for q in frames.attitude.T.tolist()],
                tuple(frames.turn_rate_rad_s[:, 0].tolist()))

    return patched((star_tracker.FrameGrid, "add", add))


def _release_on_arrays(self, t_s):
    frame_s, q, _ = self.release_many(np.array([float(t_s)]))
    return list(zip(frame_s.tolist(), map(tuple, q.T.tolist())))


def _tracker_queue_singles():
    from pmv_ros.physics import star_tracker

    def push(self, frame_s, q_xyzw):
        self.push_many(np.array([float(frame_s)]), np.asarray(q_xyzw, float).reshape(4, 1))

    return patched((star_tracker.LatencyQueue, "push", push), (star_tracker.LatencyQueue, "release", _release_on_arrays))


def _tracker_one_message():
    from pmv_ros.physics import star_tracker
    from pmv_ros.runtime.tracker import runtime

    on_arrays, floats = _measure_groups_on_arrays(), runtime.TrackerRuntime._add_truth

    def add_truth(self, t_s, q_xyzw):
        if isinstance(t_s, float):
            return floats(self, np.array([t_s]), np.asarray(q_xyzw, float).reshape(4, 1))
        return floats(self, t_s, q_xyzw)

    return patched((star_tracker.StarTracker, "measure_groups", on_arrays),
                   (runtime.TrackerRuntime, "_add_truth", add_truth),
                   (star_tracker.LatencyQueue, "release", _release_on_arrays))


#: Twin → (what replays it, the array path in its place).
TWINS = {
    "null (nothing replaced)": ("monitor", lambda: patched()),
    "closed_form_scalar": ("monitor", _closed_form_scalar),
    "orbit_angles_floats": ("monitor", _orbit_angles_floats),
    "true_roll_pitch_floats": ("monitor", _true_roll_pitch_floats),
    "ring_add_floats": ("monitor", _ring_add_floats),
    "tracker_measure_one": ("tracker", _tracker_measure_one),
    "tracker_grid_floats": ("tracker", _tracker_grid_floats),
    "tracker_queue_singles": ("tracker", _tracker_queue_singles),
    "tracker_one_message": ("tracker", _tracker_one_message),
    "orbital_axes_floats": ("odometry", _orbital_axes_floats),
}

#: The fast paths counted over a campaign task: (module, attribute).
FAST_PATHS = {
    "closed_form_scalar": ("pmv_ros.physics.instrument.oblateness", "_closed_form_oblateness_scalar"),
    "orbit_angles_floats": ("pmv_ros.runtime.monitor.records", "orbit_angles_from_state"),
    "orbital_axes_floats": ("pmv_msgs_shim.conversions", "orbital_axes_of_state"),
    "true_roll_pitch_floats": ("pmv_ros.runtime.monitor.scan", "true_roll_pitch"),
    "ring_add_floats": ("pmv_ros.analysis.statistics", "OrbitRing.add"),
    "tracker_measure_one": ("pmv_ros.physics.star_tracker", "StarTracker.measure_one"),
    "tracker_grid_floats": ("pmv_ros.physics.star_tracker", "FrameGrid.add"),
    "tracker_queue_singles": ("pmv_ros.physics.star_tracker", "LatencyQueue.push"),
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
    """Each fast path's float-path calls over one campaign task (the worker's ``run_task``, Meteor-M No.2, 10 Hz, 0.25 orbit)."""
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
    print(f"{'twin':26s} {'main job: without it':>22s} {'(quartiles)':>18s}   campaign: calls in a task of {samples} samples")
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
