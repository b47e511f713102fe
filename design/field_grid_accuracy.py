#!/usr/bin/env python3
"""Why the horizon fields' grid is as fine as it is (pmv_ros/physics/instrument/horizon_fields.py).

The weather and the window-layer height along the horizon are kept on a (time, azimuth) grid and
interpolated: a cubic in time through nodes FIELD_TIME_FRACTION of a field's shortest scale apart (in the
time a horizon point takes to cross it), a line in azimuth between nodes FIELD_AZIMUTH_FRACTION of that
scale apart along the horizon circle. This script senses ten minutes at 10 Hz with each preset's own
attitude (and once more turned by a yaw of 0.7°, so that every chord sits between azimuth nodes) on grids
of several spacings, against a grid twenty times finer than the finest (the fields evaluated, in effect,
where each sample's horizon point is), and prints the largest and the rms difference of the sensed roll and
pitch, arcmin, with the CPU time a sample costs in blocks of 512.

    .venv/bin/python design/field_grid_accuracy.py
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import yaml

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw, quaternion_product
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.instrument import sensor
from pmv_ros.runtime.common import parameters
from pmv_ros.runtime.common.assembly import SENSOR_PARAMS, build_models

REPO = Path(__file__).resolve().parents[1]
#: (time fraction, azimuth fraction) pairs tried; the first is the reference (much finer than any).
SPACINGS = [(0.005, 0.00125), (0.05, 0.025), (0.1, 0.025), (0.15, 0.025), (0.25, 0.025), (0.1, 0.05), (0.1, 0.1)]


def sense(preset: str, time_fraction: float, azimuth_fraction: float, yaw_rad: float):
    """Sensed roll and pitch (rad), 10 min at 10 Hz, and the CPU seconds a sample cost."""
    sensor.FIELD_TIME_FRACTION, sensor.FIELD_AZIMUTH_FRACTION = time_fraction, azimuth_fraction
    document = yaml.safe_load((REPO / "config" / f"{preset}.yaml").read_text())
    values = parameters.preset_values(document, "sensor_node", SENSOR_PARAMS, {"sim.fast_time": True, "seed": 3})
    _, profile, model = build_models(values)
    model.prepare()
    t = 1000.0 + 0.1 * np.arange(6000)
    q = profile.quaternion(t)
    if yaw_rad:
        q = quaternion_product(q, np.repeat(quaternion_from_roll_pitch_yaw(0.0, 0.0, yaw_rad)[:, None], t.size, 1))
    start = time.process_time()
    roll, pitch = [], []
    for first in range(0, t.size, 512):
        reading = model.sense(t[first:first + 512], q[:, first:first + 512])
        roll.append(reading.sensed_roll_rad.copy())
        pitch.append(reading.sensed_pitch_rad.copy())
    return np.concatenate(roll), np.concatenate(pitch), (time.process_time() - start) / t.size


def main() -> None:
    for preset in ("kondor", "meteor_m2", "meteor_m2_2"):
        for yaw in (0.0, math.radians(0.7)):
            reference = sense(preset, *SPACINGS[0], yaw)
            print(f"{preset}, yaw {math.degrees(yaw):.1f}°: reference grid {SPACINGS[0]}, "
                  f"{reference[2] * 1e6:.0f} µs/sample")
            for spacing in SPACINGS[1:]:
                roll, pitch, cost = sense(preset, *spacing, yaw)
                d = np.abs(np.concatenate([roll - reference[0], pitch - reference[1]])) / ARCMIN_RAD
                print(f"  time {spacing[0]:5.3f}, azimuth {spacing[1]:5.3f}: largest {np.nanmax(d):.4f}′, "
                      f"rms {np.sqrt(np.nanmean(d ** 2)):.5f}′, {cost * 1e6:5.1f} µs/sample")


if __name__ == "__main__":
    main()
