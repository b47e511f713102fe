"""Records the runtime hands to the nodes and the shim lays out: the one home of the diagnostic level,
of a runtime's health status and of a line it asks the node to log.

The channel names and the channel-statistics record are the analysis layer's
(:data:`pmv_ros.analysis.statistics.CHANNELS`,
:class:`pmv_ros.analysis.statistics.ChannelStatistics`); the chord names the
physics' (:data:`pmv_ros.physics.geometry.CHORD_NAMES`).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple


class Level(IntEnum):
    """Level of a diagnostic status (the values of diagnostic_msgs/DiagnosticStatus)."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclass(frozen=True)
class HealthSummary:
    """One /diagnostics status as a runtime reports it: level, message, key/values (the node names it)."""

    level: Level
    message: str
    values: dict


class HealthAt(NamedTuple):
    """A runtime's status on ``/diagnostics`` at time ``stamp_s`` (s): an item of what a runtime publishes."""

    stamp_s: float
    health: HealthSummary


class LogLine(NamedTuple):
    """A line for the node's log (a runtime output's ``log``): ``level`` is ``"info"`` or ``"error"``."""

    level: str
    text: str
