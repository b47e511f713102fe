"""The star tracker's cost in the node and in the campaign, against another tree of pmv_ros in the same run.

    .venv/bin/python benchmarks/bench_tracker.py --baseline DIR [--rounds 3] [--seconds 300] [--frame-rate-hz F]

What star_tracker_node's runtime costs (no ROS): a Kondor truth stream at
10 Hz fed one message at a time through ``receive_truth`` (the node's path:
checks, the frame loop, the queue, /diagnostics once a second), per truth
message and per frame; and the whole stream as one batch
(``track_stream``: the campaign's path), per frame — both after the first ten
seconds of truth, whose time (the tables read, the compiled frame kernel
loaded from its cache or compiled) is printed apart. Each tree runs in its
own interpreter (``DIR/.venv/bin/python`` with ``DIR`` on the path), the two
alternating over ``--rounds`` rounds; each figure is the best of its
rounds, the load average beside it, and the ratios are this tree's speed
over the baseline's (≥ 1: this tree is as fast). The trees' own presets
are flown (their frame periods may differ: per frame and per truth message
are both printed); ``--frame-rate-hz`` flies both at one frame rate, so that
per frame compares the same number of truth messages a frame. The headline (README.md): the node's µs per
truth message against the baseline's; without ``--baseline`` one line says it cannot run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from headline import headline  # (this folder: the script's own)

HERE = Path(__file__).resolve().parents[1]

PROBE = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from pmv_ros.runtime.flight import flight_values
from pmv_ros.runtime.tracker.runtime import TrackerRuntime, track_stream
from pmv_ros.storage.files import read_yaml_file
seconds = float(sys.argv[2])
values = flight_values(read_yaml_file(sys.argv[1] + "/config/kondor.yaml", "preset")).star_tracker
rate_hz = float(sys.argv[3])
if rate_hz > 0.0:  # the frame rate, in whichever parameter the tree has
    values = dict(values, **({"frame_period_s": 1.0 / rate_hz} if "frame_period_s" in values else {"rate_hz": rate_hz}))
t = 100.0 + np.arange(int(seconds * 10)) / 10.0
angle = 2e-4 * np.sin(t / 300.0)
q = np.array([np.sin(angle / 2), np.zeros_like(t), np.zeros_like(t), np.cos(angle / 2)])
rows = [tuple(c) for c in q.T.tolist()]
began = time.perf_counter()
runtime = TrackerRuntime(values, 0.0)
frame = runtime.frames.orbital
warm = 100  # the first ten seconds: the tables, and a compiled kernel loaded (or compiled) at its first call
for stamp, q_k in zip(t.tolist()[:warm], rows[:warm]):
    runtime.receive_truth(frame, stamp, q_k, stamp)
first_s = time.perf_counter() - began
counted = sum(v for k, v in runtime.counters.items() if k.startswith("frames_"))
began = time.perf_counter()
for stamp, q_k in zip(t.tolist()[warm:], rows[warm:]):
    runtime.receive_truth(frame, stamp, q_k, stamp)
node_s = time.perf_counter() - began
frames = sum(v for k, v in runtime.counters.items() if k.startswith("frames_")) - counted
t, q = t[warm:], q[:, warm:]
began = time.perf_counter()
batch = track_stream(TrackerRuntime(values, 0.0), t, q)
batch_s = time.perf_counter() - began
print(json.dumps({"messages": int(t.size), "frames": int(frames), "node_s": node_s, "first_s": first_s,
                  "batch_frames": int(batch.frame_s.size), "batch_s": batch_s}))
"""


def measure(tree: Path, seconds: float, frame_rate_hz: float) -> dict:
    python = tree / ".venv" / "bin" / "python"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    out = subprocess.run([str(python), "-c", PROBE, str(tree), str(seconds), str(frame_rate_hz)], capture_output=True,
                         text=True, env=env, cwd=str(tree))
    if out.returncode:
        lines = out.stderr.strip().splitlines()
        raise SystemExit(f"{tree}: {lines[-1] if lines else f'exit {out.returncode}'}")
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["load"] = os.getloadavg()[0]
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="another checkout with its own .venv")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--frame-rate-hz", type=float, default=0.0,
                        help="fly both trees at this frame rate, one their parameters accept (default: each "
                             "tree's preset)")
    args = parser.parse_args(argv)
    if args.baseline is None:
        raise SystemExit("bench_tracker: needs --baseline DIR, another checkout with its own .venv to measure "
                         "against")
    runs = {"this": [], "baseline": []}
    for round_ in range(args.rounds):
        for name, tree in (("this", HERE), ("baseline", args.baseline)):
            runs[name].append(measure(tree, args.seconds, args.frame_rate_hz))
            r = runs[name][-1]
            print(f"round {round_ + 1} {name:8s}: node {1e6 * r['node_s'] / r['messages']:7.1f} µs/message, "
                  f"{1e6 * r['node_s'] / r['frames']:8.1f} µs/frame ({r['frames']} frames); campaign path "
                  f"{1e6 * r['batch_s'] / r['batch_frames']:7.1f} µs/frame; start (tables, first 10 s) "
                  f"{1e3 * r['first_s']:.0f} ms; load {r['load']:.1f}", flush=True)
    best = {name: {"message": min(r["node_s"] / r["messages"] for r in rows),
                   "frame": min(r["node_s"] / r["frames"] for r in rows),
                   "batch": min(r["batch_s"] / r["batch_frames"] for r in rows)} for name, rows in runs.items()}
    for key, what in (("message", "node, per truth message"), ("frame", "node, per frame"),
                      ("batch", "campaign path, per frame")):
        print(f"{what}: this {1e6 * best['this'][key]:.1f} µs, baseline {1e6 * best['baseline'][key]:.1f} µs, "
              f"speed ratio {best['baseline'][key] / best['this'][key]:.2f}")
    headline("tracker_message", "star_tracker_node's runtime, µs per truth message", 1e6 * best["this"]["message"],
             "µs/message", "lower", 1e6 * best["baseline"]["message"], "µs/message",
             f"the same stream in {args.baseline.name}", ratio=best["this"]["message"] / best["baseline"]["message"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
