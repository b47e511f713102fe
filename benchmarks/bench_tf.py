"""What /tf costs the main job: the in-process pipeline stepped with and without the sensor's transforms.

``pmv simulate`` (the main job) publishes no transforms unless it records
(:class:`pmv_ros.nodes.pipeline.Pipeline`, ``publish_tf``); this measures
what they would cost it per tick, with tf2_msgs importable (a ROS 2 install,
or the venv copy ``../shared/vendor/install-ros-tools.sh`` makes). The two
settings alternate over ``--rounds`` rounds on the Kondor preset in fast
time at 10 Hz, and each is the best of its rounds (a busy neighbour process
slows whichever round it overlaps). Prints the wall time per tick of each,
the difference, and what it would add to one Kondor orbit (56,681 ticks).

    python benchmarks/bench_tf.py [--ticks N] [--rounds R] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_bench_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

from pmv_ros.nodes.pipeline import Pipeline  # noqa: E402
from pmv_ros.nodes.tf import tf_message_type  # noqa: E402

KONDOR = Path(__file__).resolve().parents[1] / "config" / "kondor.yaml"
#: Ticks of one Kondor orbit at 10 Hz (`make demo`).
ORBIT_TICKS = 56_681


def seconds_per_tick(publish_tf: bool, ticks: int) -> float:
    """Wall time per tick of the pipeline stepped ``ticks`` times after a warm-up block, s."""
    with Pipeline(KONDOR, publish_tf=publish_tf) as pipeline:
        pipeline.step(600)  # the first blocks of samples and the monitor's start
        started = time.perf_counter()
        pipeline.step(ticks)
        return (time.perf_counter() - started) / ticks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if tf_message_type() is None:
        raise SystemExit("tf2_msgs cannot be imported here: run this with a ROS 2 install or the venv copy of "
                         "../shared/vendor/install-ros-tools.sh")
    rounds = {False: [], True: []}
    for _ in range(args.rounds):
        for publish_tf in (False, True):
            rounds[publish_tf].append(seconds_per_tick(publish_tf, args.ticks))
    without, with_tf = min(rounds[False]), min(rounds[True])
    result = {"ticks": args.ticks, "rounds": args.rounds, "without_tf_ms_per_tick": without * 1e3,
              "with_tf_ms_per_tick": with_tf * 1e3, "tf_cost_ms_per_tick": (with_tf - without) * 1e3,
              "ratio": with_tf / without, "orbit_added_s": (with_tf - without) * ORBIT_TICKS,
              "per_round_ms": {str(k).lower(): [round(v * 1e3, 4) for v in vs] for k, vs in rounds.items()}}
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"pipeline, Kondor, 10 Hz fast time, best of {args.rounds} × {args.ticks} ticks:")
    print(f"  without transforms {result['without_tf_ms_per_tick']:.3f} ms/tick, with /tf "
          f"{result['with_tf_ms_per_tick']:.3f} ms/tick: +{result['tf_cost_ms_per_tick']:.3f} ms/tick "
          f"(×{result['ratio']:.3f}), ≈ {result['orbit_added_s']:+.1f} s on one orbit ({ORBIT_TICKS} ticks)")
    print(f"  per round (ms/tick): {result['per_round_ms']}")
    from headline import headline
    headline("tf", "what /tf and /tf_static add to a pipeline tick, Kondor 10 Hz", result["tf_cost_ms_per_tick"] * 1e3,
             "µs/tick", "lower", result["without_tf_ms_per_tick"] * 1e3, "µs/tick",
             "the pipeline's tick without transforms")


if __name__ == "__main__":
    main()
