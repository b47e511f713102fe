"""A preset's parameters for the Basilisk host: the nodes' specs and guards, Basilisk's orbit and attitude.

The PMV in Basilisk reads the same presets (``config/*.yaml``) as the nodes
and the campaign, through the same parameter specs and checks
(:func:`pmv_ros.runtime.flight.flight_values`): a bad value, an unknown key or
an unreadable file is one ``ValueError`` naming it. What the host fixes: the
sensor follows the spacecraft Basilisk flies (``attitude.source`` and
``orbit.source`` ``follow``) on Basilisk's clock (``sim.fast_time`` false: the
host steps it, :meth:`pmv_ros.runtime.sensor.runtime.SensorRuntime.step_to`).

Basilisk's clock starts at 0 ns; a zero stamp means "unset" to the runtime
(as on the wire), so the runtime's clock reads Basilisk's time plus
:data:`HOST_CLOCK_OFFSET_S`, and the run's epoch (``sim.epoch_utc``, or
Basilisk's ``EpochMsg``) is at that reading.
"""

from __future__ import annotations

import math
from pathlib import Path

from ...runtime.flight import FlightValues, flight_values
from ...storage.files import read_yaml_file

#: The runtime's clock at Basilisk's time 0, s (the sample at Basilisk's first step gets a stamp that is not 0).
HOST_CLOCK_OFFSET_S = 1.0

#: What the host sets whatever the preset says: the sensor follows Basilisk's spacecraft on Basilisk's clock.
HOST_SETTINGS = {"attitude.source": "follow", "orbit.source": "follow", "sim.fast_time": False}


def read_preset(preset) -> dict:
    """A preset's document: a parsed params file (dict) as it is, or the params file at a path (bounded read)."""
    if isinstance(preset, dict):
        return preset
    if not isinstance(preset, (str, Path)):
        raise ValueError(f"preset must be a params file path or its parsed document, got {type(preset).__name__}")
    return read_yaml_file(preset, "params file") or {}


def host_values(preset, overrides: dict | None = None) -> FlightValues:
    """Every node's parameter values for the PMV in Basilisk: the preset (a path or a parsed document) with
    ``overrides`` (dotted names, as ``-p``), checked by the nodes' specs, and :data:`HOST_SETTINGS`."""
    overrides = dict(overrides or {})
    for name, value in HOST_SETTINGS.items():
        if name in overrides and overrides[name] != value:
            raise ValueError(f"{name} = {overrides[name]!r}: in Basilisk the sensor follows the spacecraft "
                             f"Basilisk flies ({name} is {value!r})")
    return flight_values(read_preset(preset), {**overrides, **HOST_SETTINGS})


def epoch_utc(year: int, month: int, day: int, hours: int, minutes: int, seconds: float) -> str:
    """The ``sim.epoch_utc`` of Basilisk's ``EpochMsgPayload`` fields (UTC calendar date and time)."""
    if not math.isfinite(seconds):
        raise ValueError(f"EpochMsg seconds = {seconds} is not a finite number")
    whole = math.floor(seconds)
    micro = round((seconds - whole) * 1e6)
    if micro == 1_000_000:
        whole, micro = whole + 1, 0
    return f"{year:04d}-{month:02d}-{day:02d}T{hours:02d}:{minutes:02d}:{whole:02d}.{micro:06d}Z"
