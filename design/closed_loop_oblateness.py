"""With compensation off and the geometric instrument, the attitude settles to minus the oblateness error.

    .venv/bin/python design/closed_loop_oblateness.py [--preset config/kondor.yaml] [--bandwidths 0.005,0.02,0.1]
        [--rate-hz 2] [--orbits 1]

physics.md §2.1: the sensor finds the geometric vertical, which on the ellipsoid differs from the direction
to the Earth's centre by the oblateness error e(u) (roll at the orbital frequency, pitch at twice it). A loop
closed on the sensor drives the *sensed* angle to zero, so the body turns until true = −e. Here the
instrument is geometric (``sensor.detector: ideal``: the horizon of the 40 km emitting layer, no radiance
errors; no bright-body exclusion), compensation off, no disturbance; one orbit per bandwidth through
:func:`pmv_ros.runtime.flight.fly_closed_loop`. Printed per bandwidth and axis, after the loop's settling
time:

* the rms of true + e (e from the ray geometry at each sample's orbit position,
  :func:`pmv_ros.physics.instrument.oblateness.oblateness_error`) — how far the attitude is from −e;
* the rms the loop's tracking lag predicts: e's harmonics k = 1 … 8 each times |1 − H(jkΩ)|
  (:func:`pmv_ros.physics.rigid_body.tracking_response`; for ω ≪ ω_n, |1 − H| ≈ 2ζω/ω_n: the lag grows with the
  harmonic and shrinks with the bandwidth);
* the rms of the flown true attitude against −H applied to e harmonic by harmonic (what is left when the
  lag is accounted for: the discrete controller, the held measurement, gravity gradient and coupling);
* the amplitude of e (roll k = 1, pitch k = 2) and of the true attitude at those harmonics.

tests/physics/test_closed_loop_physics.py checks the 0.02 Hz row's figures.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.constants import ARCMIN_RAD, GRS80  # noqa: E402
from pmv_ros.physics.instrument.oblateness import oblateness_error  # noqa: E402
from pmv_ros.physics.rigid_body import tracking_response  # noqa: E402
from pmv_ros.runtime.flight import flight_values, fly_closed_loop  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402

#: Harmonics of the orbital frequency fitted to the oblateness error (it has ≈ nothing beyond k = 4).
HARMONICS = np.arange(1, 9)

#: The geometric instrument with compensation off and nothing else in the loop.
GEOMETRIC = {"sensor.detector": "ideal", "sensor.bright_body_exclusion_deg": 0.0,
             "sensor.oblateness_compensation": False, "disturbance.gravity_gradient": True}


def fit(phase: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Complex amplitudes c_k of values ≈ c_0 + Σ Re(c_k·e^{jkφ}) for k in :data:`HARMONICS` (least squares)."""
    design = np.concatenate([np.ones((phase.size, 1)), np.cos(np.outer(phase, HARMONICS)),
                             np.sin(np.outer(phase, HARMONICS))], axis=1)
    coefficients = np.linalg.lstsq(design, values, rcond=None)[0]
    count = HARMONICS.size
    return coefficients[0], coefficients[1:1 + count] - 1j * coefficients[1 + count:]


def synthesise(phase: np.ndarray, mean: float, amplitudes: np.ndarray) -> np.ndarray:
    return mean + np.real(np.exp(1j * np.outer(phase, HARMONICS)) @ amplitudes)


def settle_to_minus_oblateness(document: dict, bandwidth_hz: float, rate_hz: float, orbits: float = 1.0) -> dict:
    """One closed-loop flight of the geometric instrument; the figures of the module docstring, arcmin."""
    values = flight_values(document, {**GEOMETRIC, "control.bandwidth_hz": bandwidth_hz, "sensor.rate_hz": rate_hz})
    from pmv_ros.runtime.control import plant_of

    mean_motion = plant_of(values.controller).mean_motion_rad_s
    samples = round(orbits * 2.0 * math.pi / mean_motion * rate_hz)
    flight = fly_closed_loop(values, samples)
    after = flight.t_s >= flight.pointing.skip_until_s
    orbit = flight.values.sensor
    from pmv_ros.physics.orbit.two_body import CircularOrbit

    circle = CircularOrbit(orbit["orbit.altitude_km"] * 1e3, math.radians(orbit["orbit.inclination_deg"]))
    error = oblateness_error(circle, flight.u_rad[after], GRS80, orbit["sensor.layer_height_km"] * 1e3)
    phase = flight.u_rad[after]
    damping = values.controller["control.damping_ratio"]
    response = tracking_response(HARMONICS * mean_motion, bandwidth_hz, damping)
    result = {"settling_time_s": flight.pointing.skip_until_s}
    for index, axis in enumerate(("roll", "pitch")):
        true = (flight.true_roll_rad, flight.true_pitch_rad)[index][after]
        e = error[index]
        mean, amplitudes = fit(phase, e)
        lag = np.sqrt(0.5 * np.sum(np.abs((1.0 - response) * amplitudes) ** 2))
        followed = -synthesise(phase, mean, response * amplitudes)
        _, true_amplitudes = fit(phase, true)
        k = 1 if axis == "roll" else 2
        result[axis] = {"rms_true_plus_error": float(np.sqrt(np.mean((true + e) ** 2)) / ARCMIN_RAD),
                        "rms_predicted_lag": float(lag / ARCMIN_RAD),
                        "rms_against_minus_H_e": float(np.sqrt(np.mean((true - followed) ** 2)) / ARCMIN_RAD),
                        "error_amplitude": float(abs(amplitudes[k - 1]) / ARCMIN_RAD),
                        "true_amplitude": float(abs(true_amplitudes[k - 1]) / ARCMIN_RAD), "k": k}
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="config/kondor.yaml")
    parser.add_argument("--bandwidths", default="0.005,0.02,0.1", help="Hz, comma-separated")
    parser.add_argument("--rate-hz", type=float, default=2.0, help="the sensor's rate (default 2 Hz)")
    parser.add_argument("--orbits", type=float, default=1.0)
    args = parser.parse_args(argv)
    document = read_yaml_file(args.preset, "preset")
    print(f"{args.preset}: geometric instrument, compensation off, sensor at {args.rate_hz:g} Hz, "
          f"{args.orbits:g} orbit per bandwidth; arcmin, after the settling time")
    print(f"{'bandwidth':>10} {'axis':>6} {'rms(true + e)':>14} {'lag predicts':>13} {'rms(true + H∗e)':>16} "
          f"{'|e_k|':>7} {'|true_k|':>9}")
    for bandwidth in (float(b) for b in args.bandwidths.split(",")):
        result = settle_to_minus_oblateness(document, bandwidth, args.rate_hz, args.orbits)
        for axis in ("roll", "pitch"):
            r = result[axis]
            print(f"{bandwidth:>10g} {axis:>6} {r['rms_true_plus_error']:14.4f} {r['rms_predicted_lag']:13.4f} "
                  f"{r['rms_against_minus_H_e']:16.4f} {r['error_amplitude']:7.3f} {r['true_amplitude']:9.3f} "
                  f"(k = {r['k']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
