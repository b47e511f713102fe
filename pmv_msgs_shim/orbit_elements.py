"""The sensor's orbit on the wire: epoch and elements as a status of its ``/diagnostics``.

A recording of the sensor's topics has stamps but no orbit epoch: where the
spacecraft was at a stamp is not in the stamp (a real-time node's orbit starts
at u0 when the node starts, whatever the wall clock says). So every
``/diagnostics`` message of ``sensor_node`` carries, after its horizon status,
a status named :data:`ORBIT_STATUS_NAME` whose key/values say what orbit it
flies, readable by any node on the graph and in any recording years later:

==========================  =======================================================================
key                         value
==========================  =======================================================================
``epoch_utc``               UTC date-time of the epoch (``sim.epoch_utc``, ISO 8601)
``epoch_stamp_s``           the node clock (header stamps, s) at the epoch: the elements hold there
``altitude_km``             circular orbit altitude above the 6371 km mean radius
``inclination_deg``         inclination
``raan_deg``                right ascension of the ascending node at the epoch
``arg_latitude_deg``        argument of latitude u at the epoch (from the ascending node)
``period_s``                period of u (the J2 rate included when the node drifts)
``raan_rate_deg_per_day``   secular node drift (0 without J2)
``roll_pitch_convention``   sign convention of roll/pitch on the sensor's topics (``ros``/``paper``)
==========================  =======================================================================

u at a stamp t is ``arg_latitude_deg + 360 (t − epoch_stamp_s) / period_s``
(:meth:`OrbitElements.argument_of_latitude_rad`). Numbers are Python ``repr``
of floats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pmv_ros.physics.constants import SECONDS_PER_DAY

from .records import HealthStatus, Level

#: Name of the orbit status in the /diagnostics of a sensor_node without namespace; in a namespace
#: the node's fully qualified name stands between ``pmv_ros`` and ``: orbit`` (``pmv_ros/sat1/sensor_node: orbit``).
ORBIT_STATUS_NAME = "pmv_ros/sensor_node: orbit"
_ORBIT_STATUS_PREFIX, _ORBIT_STATUS_SUFFIX = "pmv_ros/", ": orbit"


def orbit_status_name(namespace: str = "") -> str:
    """The orbit status's name for the sensor_node in ``namespace`` ('', 'sat1' or '/sat1')."""
    inner = namespace.strip("/")
    return f"{_ORBIT_STATUS_PREFIX}{inner}/sensor_node{_ORBIT_STATUS_SUFFIX}" if inner else ORBIT_STATUS_NAME

#: Sign convention of roll and pitch on the sensor's topics: REP-103 (interfaces.md).
WIRE_CONVENTION = "ros"

_FLOAT_KEYS = ("epoch_stamp_s", "altitude_km", "inclination_deg", "raan_deg", "arg_latitude_deg", "period_s",
               "raan_rate_deg_per_day")


@dataclass(frozen=True)
class OrbitElements:
    """The orbit a sensor flies, as its /diagnostics says (see the module docstring for the fields)."""

    epoch_utc: str
    epoch_stamp_s: float
    altitude_km: float
    inclination_deg: float
    raan_deg: float
    arg_latitude_deg: float
    period_s: float
    raan_rate_deg_per_day: float = 0.0
    roll_pitch_convention: str = WIRE_CONVENTION

    def __post_init__(self) -> None:
        for key in _FLOAT_KEYS:
            value = getattr(self, key)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"orbit status: {key} = {value!r} is not a finite number")
        if not self.period_s > 0.0:
            raise ValueError(f"orbit status: period_s = {self.period_s!r} must be positive")
        if self.roll_pitch_convention not in ("ros", "paper"):
            raise ValueError(f"orbit status: roll_pitch_convention = {self.roll_pitch_convention!r}, "
                             "expected ros or paper")

    @classmethod
    def from_orbit(cls, orbit, epoch_utc: str) -> "OrbitElements":
        """From a :class:`pmv_ros.physics.orbit.two_body.CircularOrbit` (read by attribute) and the UTC of its epoch."""
        return cls(epoch_utc=str(epoch_utc), epoch_stamp_s=float(orbit.epoch_s),
                   altitude_km=orbit.altitude_m / 1e3, inclination_deg=math.degrees(orbit.inclination_rad),
                   raan_deg=math.degrees(orbit.raan_rad),
                   arg_latitude_deg=math.degrees(orbit.arg_latitude_at_epoch_rad),
                   period_s=float(orbit.period_s),
                   raan_rate_deg_per_day=math.degrees(orbit.raan_rate_rad_s) * SECONDS_PER_DAY)

    def argument_of_latitude_rad(self, stamp_s):
        """u at stamp(s) ``stamp_s`` (s on the node clock), rad, not wrapped; works on floats and numpy arrays."""
        return math.radians(self.arg_latitude_deg) + 2.0 * math.pi * (stamp_s - self.epoch_stamp_s) / self.period_s


def orbit_elements_status(elements: OrbitElements, name: str = ORBIT_STATUS_NAME,
                          hardware_id: str = "pmv") -> HealthStatus:
    """The /diagnostics status named ``name`` that carries ``elements``."""
    values = [("epoch_utc", elements.epoch_utc)]
    values += [(key, repr(float(getattr(elements, key)))) for key in _FLOAT_KEYS]
    values.append(("roll_pitch_convention", elements.roll_pitch_convention))
    message = (f"epoch {elements.epoch_utc} at stamp {elements.epoch_stamp_s:.3f} s: H = {elements.altitude_km:g} km, "
               f"i = {elements.inclination_deg:g}°, u0 = {elements.arg_latitude_deg:g}°")
    return HealthStatus(name=name, level=Level.OK, message=message, hardware_id=hardware_id,
                        values=tuple(values))


def orbit_elements_from_status(status) -> OrbitElements:
    """OrbitElements from a status named :data:`ORBIT_STATUS_NAME` (a HealthStatus or a DiagnosticStatus).

    Raises ValueError naming the key when one is missing or not a number.
    """
    pairs = status.values
    values = dict(pairs) if pairs and isinstance(next(iter(pairs)), tuple) else {kv.key: kv.value for kv in pairs}
    fields = {}
    for key in ("epoch_utc",) + _FLOAT_KEYS + ("roll_pitch_convention",):
        if key not in values:
            raise ValueError(f"orbit status: no key {key!r}")
        fields[key] = values[key]
    for key in _FLOAT_KEYS:
        try:
            fields[key] = float(fields[key])
        except ValueError:
            raise ValueError(f"orbit status: {key} = {fields[key]!r} is not a number") from None
    return OrbitElements(**fields)


def is_orbit_status_name(name: str) -> bool:
    """Whether ``name`` is the orbit status of some sensor_node (any namespace)."""
    return name.startswith(_ORBIT_STATUS_PREFIX) and name.endswith(_ORBIT_STATUS_SUFFIX)


def find_orbit_elements(diagnostic_array, name: str | None = None) -> OrbitElements | None:
    """The orbit elements of a /diagnostics message (DiagnosticArray or HealthReport), or None if it has none.

    ``name``: the status of one sensor (``pmv_ros/sat1/sensor_node: orbit``); None: the first sensor's found.
    """
    statuses = getattr(diagnostic_array, "status", None)
    if statuses is None:
        statuses = diagnostic_array.statuses
    for status in statuses:
        if status.name == name if name is not None else is_orbit_status_name(status.name):
            return orbit_elements_from_status(status)
    return None
