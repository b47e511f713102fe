"""A preset's sensor flown without ROS, for the tests of the flight environment and of ``pmv simulate``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from pmv_ros.runtime.common import parameters
from pmv_ros.runtime.common.assembly import SENSOR_PARAMS, build_models

REPO = Path(__file__).resolve().parents[1]


def preset_values(name: str, **overrides) -> dict:
    """The sensor node's parameter values from a preset file, as rclpy would merge them, in fast time."""
    document = yaml.safe_load((REPO / "config" / f"{name}.yaml").read_text())
    given = {"sim.fast_time": True, **{k.replace("__", "."): v for k, v in overrides.items()}}
    return parameters.preset_values(document, "sensor_node", SENSOR_PARAMS, given)


def fly_one_orbit(values: dict):
    """Sensed roll/pitch (rad) over one orbit at zero attitude, every 4 s, and the orbit."""
    orbit, _, model = build_models(values)
    t = np.arange(0.0, orbit.period_s, 4.0)
    reading = model.sense(t, np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), t.size))
    return t, reading, orbit
