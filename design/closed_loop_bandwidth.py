"""Pointing σ against the controller's bandwidth, with the flight environment (physics.md §2.1; docs/closed_loop.md).

    .venv/bin/python design/closed_loop_bandwidth.py [--preset config/kondor.yaml]
        [--bandwidths 0.001,0.005,0.02,0.1] [--seeds 1,2,3,4,5,6] [--rate-hz 2] [--compensation off,on]
        [--torque-nm 5e-5] [--orbits 1]

Flies the closed loop (:func:`pmv_ros.runtime.flight.fly_closed_loop`: the sensor in follow mode inside
attitude_controller_node's plant and PD loop, the nodes' own runtimes) for each compensation setting,
bandwidth and seed, with disturbance torques of ``--torque-nm`` (a representative aerodynamic and magnetic
torque of a ≈ 1 t spacecraft at 500 km): constant about the body X axis (it moves the roll's mean by
τ/K_p, not its σ) and at the orbital frequency, a·sin(n·t), about Y (pitch, whose oblateness error is at
twice the orbital frequency, so the two do not meet: a torque at the orbital frequency about X would
meet roll's oblateness error in or out of phase by the orbit's geometry alone). It prints per bandwidth the
seeds' mean (and range) of:

* the true pointing σ, roll and pitch, after the loop's settling time — what the loop gives;
* the sensor's own error σ at the same samples (sensed − true) — what the loop closes on;
* the rms (√(mean² + σ²)) and the mean of the true pointing;
* the two parts a linear model of each axis predicts from the recorded sensor error and the disturbance:
  −H∗e, the sensor's error followed within the bandwidth (H the loop's response,
  :func:`pmv_ros.physics.rigid_body.tracking_response`), and the disturbance's own response
  τ / (J·(s² + 2ζω_n·s + ω_n²)); and their sum's σ beside the flown one (the explanation holds where the two
  agree; the linear model leaves out the gravity gradient and the gyroscopic coupling).

The sensor runs at ``--rate-hz`` (2 Hz by default: twenty samples per period of the fastest loop, 0.1 Hz,
and the environment's errors are fields along the track, so a faster rate samples the same error more
densely; ``--rate-hz 10`` flies the preset's own rate), the controller at its ``control.rate_hz``.
About 20–40 s an orbit at 2 Hz while the sensor's follow path costs ≈ 2 ms a sample.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402
from pmv_ros.runtime.control import LoopSettings, plant_of  # noqa: E402
from pmv_ros.runtime.flight import flight_values, fly_closed_loop  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402

AXES = ("roll", "pitch")


def held(values: np.ndarray) -> np.ndarray:
    """NaN (a lost chord pair) replaced by the last value before it, as the controller holds it."""
    out = values.copy()
    for i in range(1, out.size):
        if np.isnan(out[i]):
            out[i] = out[i - 1]
    return np.nan_to_num(out)


def linear_parts(flight, settings: LoopSettings, axis: int, torque_nm: float, mean_motion: float):
    """The linear model's two parts of the true angle on ``axis`` at the samples: (−H∗e, the response to a torque
    ``torque_nm``·sin(n·t))."""
    t = flight.t_s
    true = (flight.true_roll_rad, flight.true_pitch_rad)[axis]
    sensed = (flight.sensed_roll_rad, flight.sensed_pitch_rad)[axis]
    error = held(sensed - true)
    j = settings.gains.inertia_kg_m2[axis]
    kp, kd = settings.gains.proportional[axis], settings.gains.derivative[axis]
    plant = signal.lti([1.0], [j, kd, kp])
    start = t[0] - 1.0 / flight.values.sensor["sensor.rate_hz"]
    time_s = np.concatenate([[start], t]) - start
    followed = signal.lsim(plant, np.concatenate([[0.0], -kp * error]), time_s, interp=False)[1][1:]
    torque = torque_nm * np.sin(mean_motion * (np.concatenate([[start], t]) - start))
    disturbed = signal.lsim(plant, torque, time_s, interp=False)[1][1:]
    return followed, disturbed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="config/kondor.yaml")
    parser.add_argument("--bandwidths", default="0.001,0.005,0.02,0.1", help="Hz, comma-separated")
    parser.add_argument("--seeds", default="1,2,3,4,5,6")
    parser.add_argument("--rate-hz", type=float, default=2.0, help="the sensor's rate (default 2 Hz)")
    parser.add_argument("--compensation", default="off,on", help="on-board oblateness compensation settings")
    parser.add_argument("--torque-nm", type=float, default=5e-5,
                        help="disturbance, N·m: constant about X, at the orbital frequency about Y (default 5e-5)")
    parser.add_argument("--orbits", type=float, default=1.0)
    args = parser.parse_args(argv)
    document = read_yaml_file(args.preset, "preset")
    bandwidths = [float(b) for b in args.bandwidths.split(",")]
    seeds = [int(s) for s in args.seeds.split(",")]
    print(f"{args.preset}: sensor at {args.rate_hz:g} Hz, {args.orbits:g} orbit per run, disturbance "
          f"{args.torque_nm:g} N·m constant about X and at the orbital frequency about Y, seeds {seeds}")
    for compensation in args.compensation.split(","):
        print(f"\noblateness compensation {compensation}: σ, arcmin (mean over the seeds [min … max])")
        print(f"{'bandwidth':>10} {'axis':>6} {'pointing σ':>22} {'sensor error σ':>22} {'−H∗e σ':>8} "
              f"{'disturb. σ':>10} {'predicted σ':>11} {'mean':>7} {'rms':>6}")
        for bandwidth in bandwidths:
            rows = {axis: {"pointing": [], "sensor": [], "followed": [], "disturbed": [], "predicted": [],
                           "mean": [], "rms": []} for axis in AXES}
            started = time.perf_counter()
            for seed in seeds:
                overrides = {"seed": seed, "sensor.rate_hz": args.rate_hz, "control.bandwidth_hz": bandwidth,
                             "sensor.oblateness_compensation": compensation == "on",
                             "disturbance.constant_torque_nm": [args.torque_nm, 0.0, 0.0],
                             "disturbance.orbital_torque_nm": [0.0, args.torque_nm, 0.0]}
                values = flight_values(document, overrides)
                samples = round(args.orbits * 2 * np.pi / plant_of(values.controller).mean_motion_rad_s
                                * args.rate_hz)
                flight = fly_closed_loop(values, samples)
                settings = LoopSettings.from_values(values.controller)
                after = flight.t_s >= flight.pointing.skip_until_s
                for index, axis in enumerate(AXES):
                    true = (flight.true_roll_rad, flight.true_pitch_rad)[index]
                    sensed = (flight.sensed_roll_rad, flight.sensed_pitch_rad)[index]
                    followed, disturbed = linear_parts(flight, settings, index, args.torque_nm if index else 0.0,
                                                       plant_of(values.controller).mean_motion_rad_s)
                    row = rows[axis]
                    row["pointing"].append(np.std(true[after], ddof=1))
                    row["sensor"].append(np.nanstd((sensed - true)[after], ddof=1))
                    row["followed"].append(np.std(followed[after], ddof=1))
                    row["disturbed"].append(np.std(disturbed[after], ddof=1))
                    row["predicted"].append(np.std((followed + disturbed)[after], ddof=1))
                    row["mean"].append(np.mean(true[after]))
                    row["rms"].append(np.sqrt(np.mean(true[after] ** 2)))
            for axis in AXES:
                row = {k: np.array(v) / ARCMIN_RAD for k, v in rows[axis].items()}
                spread = lambda k: f"{row[k].mean():6.2f} [{row[k].min():5.2f} … {row[k].max():5.2f}]"  # noqa: E731
                print(f"{bandwidth:>10g} {axis:>6} {spread('pointing'):>22} {spread('sensor'):>22} "
                      f"{row['followed'].mean():8.2f} {row['disturbed'].mean():10.2f} {row['predicted'].mean():11.2f} "
                      f"{row['mean'].mean():+7.2f} {row['rms'].mean():6.2f}")
            print(f"{'':>10} ({len(seeds)} seeds in {time.perf_counter() - started:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
