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
from fractions import Fraction
from pathlib import Path

from ...runtime.flight import FlightValues, flight_values
from ...storage.files import read_yaml_file

#: The runtime's clock at Basilisk's time 0, s (the sample at Basilisk's first step gets a stamp that is not 0).
HOST_CLOCK_OFFSET_S = 1.0

#: A sensor rate is taken as the nearest fraction with a denominator up to this (0.1 Hz, 2.5 Hz and 1/3 Hz exactly).
RATE_DENOMINATOR = 1_000_000

#: What the host sets whatever the preset says: the sensor follows Basilisk's spacecraft on Basilisk's clock;
#: the states reach it from the simulation the user runs, not from a neighbour on a network, so the input rate
#: guard (which thins a flood) is at its top: the module feeds the runtime the state at or before a sample time
#: and the one after it, which are a dynamics step apart (1 ms in a 1 kHz task).
HOST_SETTINGS = {"attitude.source": "follow", "orbit.source": "follow", "sim.fast_time": False,
                 "input.max_rate_hz": 1e5}


def read_preset(preset) -> dict:
    """A preset's document: a parsed params file (dict) as it is, or the params file at a path (bounded read).

    Either way it must have a params file's shape — a mapping of node sections, each a mapping with a
    ``ros__parameters`` mapping (or empty) — or ValueError says, in one line, which part is not.
    """
    if isinstance(preset, (str, Path)):
        document = read_yaml_file(preset, "params file")
        name = f"params file {preset}"
    elif isinstance(preset, dict):
        document, name = preset, "preset"
    else:
        raise ValueError(f"preset must be a params file path or its parsed document, got {type(preset).__name__}")
    if document is None:
        return {}
    if not isinstance(document, dict):
        raise ValueError(f"{name}: its top level is a {type(document).__name__}, not a mapping of node sections "
                         "(node_name: {ros__parameters: {...}})")
    for section, body in document.items():
        if body is not None and not isinstance(body, dict):
            raise ValueError(f"{name}: section {section!r} is a {type(body).__name__}, not a mapping "
                             "({ros__parameters: {...}})")
        parameters = (body or {}).get("ros__parameters")
        if parameters is not None and not isinstance(parameters, dict):
            raise ValueError(f"{name}: {section}.ros__parameters is a {type(parameters).__name__}, not a mapping "
                             "of parameter names")
    return document


def host_values(preset, overrides: dict | None = None) -> FlightValues:
    """Every node's parameter values for the PMV in Basilisk: the preset (a path or a parsed document) with
    ``overrides`` (dotted names, as ``-p``), checked by the nodes' specs, and :data:`HOST_SETTINGS`."""
    if overrides is not None and not isinstance(overrides, dict):
        raise ValueError(f"overrides must be a mapping of parameter names to values, got {type(overrides).__name__}")
    for name in overrides or {}:
        if not isinstance(name, str):
            raise ValueError(f"overrides: parameter name {name!r} is a {type(name).__name__}, not a dotted name "
                             "such as 'sensor.rate_hz'")
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


class SampleClock:
    """The sensor's sample times on Basilisk's clock (integer nanoseconds): sample k at k / ``rate_hz`` s,
    rounded to the nearest ns, k = 0, 1, …; computed from k each time, so no rounding accumulates over a run.

    The rate is taken as a fraction (:data:`RATE_DENOMINATOR`): 3 Hz gives 0, 333 333 333, 666 666 667,
    1 000 000 000 ns, …
    """

    def __init__(self, rate_hz: float):
        fraction = Fraction(rate_hz).limit_denominator(RATE_DENOMINATOR)
        # k / rate s = k · 10⁹ · q / p ns for a rate p / q Hz
        self._numerator, self._denominator = 10**9 * fraction.denominator, fraction.numerator

    def time_ns(self, index: int) -> int:
        """The Basilisk time of sample ``index``, ns."""
        return (2 * index * self._numerator + self._denominator) // (2 * self._denominator)

    def first_index_at_or_after(self, time_ns: int) -> int:
        """The first sample at or after ``time_ns`` (≥ 0)."""
        # time_ns(k) ≥ t  ⇔  k · n / d ≥ t − ½  ⇔  k ≥ (2t − 1) · d / (2n)
        return max(0, -((-(2 * time_ns - 1) * self._denominator) // (2 * self._numerator)))
