"""attitude_controller_node's work without ROS: the rigid-body plant and its PD loop on the PMV
(:mod:`.controller`), and the true pointing error it gives (:mod:`.pointing`).

Imports :mod:`pmv_ros.runtime.common` and the physics; no other node's runtime (the flight drives it beside
them).
"""

from .controller import ControllerOutput, ControllerRuntime, LoopSettings, TruthPublication, plant_of
from .pointing import AXES, PointingStatistics

__all__ = ["AXES", "ControllerOutput", "ControllerRuntime", "LoopSettings", "PointingStatistics",
           "TruthPublication", "plant_of"]
