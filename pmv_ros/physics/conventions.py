"""The two roll/pitch sign conventions, and the one function that converts between them.

physics.md "Sign conventions":

* ``ros`` (REP-103) — every topic and every internal value: roll and pitch are
  the body's attitude relative to the orbital frame as right-hand rotations
  (tf2's roll/pitch/yaw, R = R_z(yaw)·R_y(pitch)·R_x(roll)). A body turned by
  +1° about the orbital +X reads roll = +1°.
* ``paper`` — the signs of the published tables and flight telemetry: roll and
  pitch of the local vertical as the sensor sees it, the opposite of REP-103
  for both angles.

Published numbers are converted here, at the edge, and nowhere else: a command
that reads or prints them names its convention and calls :func:`convert`.
"""

from __future__ import annotations

#: The conventions a command can name (``--convention``): the published tables' (also the default for CSV
#: telemetry and the convention of the closed-form oblateness model) and REP-103's.
PAPER, ROS = "paper", "ros"
CONVENTIONS = (PAPER, ROS)


def _sign(source: str, target: str) -> float:
    for name in (source, target):
        if name not in CONVENTIONS:
            raise ValueError(f"sign convention {name!r}: expected one of {', '.join(CONVENTIONS)}")
    return 1.0 if source == target else -1.0


def convert(roll, pitch, source: str, target: str):
    """Roll and pitch (scalars or arrays, any angle unit) from convention ``source`` to ``target``.

    The paper convention is REP-103 with both signs reversed (physics.md
    "Sign conventions"), so the conversion is its own inverse.
    """
    sign = _sign(source, target)
    return sign * roll, sign * pitch
