"""The frames of one spacecraft and the sensor's mounting on its body, as parameters: names, defaults, checks.

The one home of the frame names (interfaces.md "Frames"): ``eci`` (Earth-centred
inertial, J2000 axes), ``orbital`` (Z up along the geocentric radius, X towards
the velocity in the orbit plane), ``base_link`` (the body) and ``pmv_sensor``
(the instrument). Each is a parameter of every node (``frames.*``), and
``frames.prefix`` puts one spacecraft's own frames apart from another's:
``ros2 launch … namespace:=sat1`` sets it to ``sat1/``, so the frames become
``sat1/orbital``, ``sat1/base_link``, ``sat1/pmv_sensor``. The inertial frame is
the one frame all spacecraft share, so the prefix leaves ``frames.eci`` as it
is: two spacecraft hang under one ``eci`` root in a 3D view (give
``frames.eci`` a prefix of its own if you want separate trees).

The mounting is the orientation of the sensor frame in the body frame: roll,
pitch and yaw in the order and signs of the body attitude (REP-103,
``quaternion_from_roll_pitch_yaw``). A misaligned sensor reads its mounting as
a constant roll/pitch offset (physics.md §5: the Kondor flight's K and T
offsets were put down to it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ...physics.attitude import quaternion_from_roll_pitch_yaw
from ...physics.constants import ARCMIN_RAD
from .parameters import ParamSpec

#: What a frame name may look like: tf2's rules (no leading '/', no whitespace), ROS name characters.
_FRAME_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_/\-.]*$")
_FRAME_CONSTRAINTS = "letters, digits, '_', '-', '.', '/' inside (tf2 frame ids: no leading '/', no spaces)"


@dataclass(frozen=True)
class Frames:
    """The frame ids one spacecraft stamps its messages with (the defaults are interfaces.md's names)."""

    eci: str = "eci"
    orbital: str = "orbital"
    base_link: str = "base_link"
    sensor: str = "pmv_sensor"

    def __post_init__(self) -> None:
        for role in ("eci", "orbital", "base_link", "sensor"):
            name = getattr(self, role)
            if not (isinstance(name, str) and _FRAME_NAME.match(name) and "//" not in name and not name.endswith("/")):
                raise ValueError(f"frame {role} = {name!r} is not a frame id ({_FRAME_CONSTRAINTS})")
        names = [self.eci, self.orbital, self.base_link, self.sensor]
        if len(set(names)) != len(names):
            raise ValueError(f"frames eci, orbital, base_link, pmv_sensor must differ, got {names}")

    @classmethod
    def from_values(cls, values: dict) -> "Frames":
        """The frames from node parameter values (``frames.*``, see :data:`FRAME_PARAMS`); ValueError if not ids."""
        prefix = prefix_of(values["frames.prefix"])
        return cls(eci=values["frames.eci"], orbital=prefix + values["frames.orbital"],
                   base_link=prefix + values["frames.base_link"], sensor=prefix + values["frames.sensor"])


#: The frames without prefix and without parameters (the shim's record defaults, tests).
DEFAULT_FRAMES = Frames()


def prefix_of(text: str) -> str:
    """``frames.prefix`` as it goes in front of a frame name: '' or 'name/' (a namespace's slashes trimmed)."""
    stripped = text.strip().strip("/")
    return f"{stripped}/" if stripped else ""


def prefix_for_namespace(namespace: str) -> str:
    """The ``frames.prefix`` for nodes in ``namespace`` ('/sat1' or 'sat1' → 'sat1/'; '' or '/' → '')."""
    return prefix_of(namespace)


#: Frame parameters every node declares (read-only: a frame that changes under a running TF tree breaks it).
FRAME_PARAMS = (
    ParamSpec("frames.prefix", "", "prefix of this spacecraft's frames (orbital, base_link, pmv_sensor), "
              "e.g. sat1/ for the namespace sat1 (the launch file sets it from its namespace)",
              constraints="empty, or a frame-id prefix such as sat1/", read_only=True),
    ParamSpec("frames.eci", DEFAULT_FRAMES.eci, "Earth-centred inertial frame (J2000 axes); shared by every "
              "spacecraft, so the prefix does not apply", constraints=_FRAME_CONSTRAINTS, read_only=True),
    ParamSpec("frames.orbital", DEFAULT_FRAMES.orbital, "orbital frame: Z up along the geocentric radius, X "
              "towards the velocity in the orbit plane", constraints=_FRAME_CONSTRAINTS, read_only=True),
    ParamSpec("frames.base_link", DEFAULT_FRAMES.base_link, "body frame of the spacecraft",
              constraints=_FRAME_CONSTRAINTS, read_only=True),
    ParamSpec("frames.sensor", DEFAULT_FRAMES.sensor, "frame of the PMV sensor (boresight -Z, chords along "
              "+-X, +-Y)", constraints=_FRAME_CONSTRAINTS, read_only=True),
)


#: The sensor's mounting on the body (sensor_node; read-only: the instrument is bolted on).
MOUNTING_PARAMS = (
    ParamSpec("sensor.mounting_roll_arcmin", 0.0, "roll of the sensor frame in the body frame (misalignment)",
              -600.0, 600.0, unit="arcmin", read_only=True),
    ParamSpec("sensor.mounting_pitch_arcmin", 0.0, "pitch of the sensor frame in the body frame (misalignment)",
              -600.0, 600.0, unit="arcmin", read_only=True),
    ParamSpec("sensor.mounting_yaw_arcmin", 0.0, "yaw of the sensor frame in the body frame (misalignment)",
              -600.0, 600.0, unit="arcmin", read_only=True),
)


@dataclass(frozen=True)
class Mounting:
    """Orientation of the sensor frame in the body frame: roll, pitch, yaw, rad (REP-103 order and signs)."""

    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0

    @classmethod
    def from_values(cls, values: dict) -> "Mounting":
        """From ``sensor.mounting_*_arcmin`` parameter values."""
        return cls(*(values[f"sensor.mounting_{axis}_arcmin"] * ARCMIN_RAD for axis in ("roll", "pitch", "yaw")))

    @property
    def aligned(self) -> bool:
        """True when the sensor axes are the body axes."""
        return self.roll_rad == 0.0 and self.pitch_rad == 0.0 and self.yaw_rad == 0.0

    @property
    def q_body_to_sensor(self) -> tuple[float, float, float, float]:
        """(x, y, z, w) of the sensor frame in the body frame (:func:`quaternion_from_roll_pitch_yaw`)."""
        return tuple(float(c) for c in quaternion_from_roll_pitch_yaw(self.roll_rad, self.pitch_rad, self.yaw_rad))
