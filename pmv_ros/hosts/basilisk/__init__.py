"""The PMV in Basilisk (``pip install pmv_ros[basilisk]``): a sensor module on the nodes' runtimes.

* :class:`PmvHorizonSensor` — the sensor module: ``SCStatesMsg`` in; the measured nadir out as a
  ``BodyHeadingMsg``, the whole reading as a :class:`PmvReading` and in :class:`PmvRecorder` s;
* :class:`PmvAttitudeNav` — its roll and pitch with another navigation's yaw and rate as a ``NavAttMsg`` for
  Basilisk's FSW;
* :class:`PmvErrorMonitor` — the residual statistics of a run (physics.md §5), from the sensor;
* :func:`kondor_scenario` — a spacecraft on a preset's orbit, nadir-pointed by Basilisk's FSW, with the PMV.

docs/basilisk.md shows them wired; examples/basilisk_meteor.py is a scenario a user writes.
"""

from .frames import DCM_CB_HILL, attitude_in_orbital, sigma_from_roll_pitch_yaw
from .monitor import PmvErrorMonitor
from .nav import PmvAttitudeNav
from .scenario import Scenario, kondor_scenario
from .sensor import PmvHorizonSensor, PmvReading, PmvRecorder
from .values import HOST_CLOCK_OFFSET_S, host_values

__all__ = ["DCM_CB_HILL", "HOST_CLOCK_OFFSET_S", "PmvAttitudeNav", "PmvErrorMonitor", "PmvHorizonSensor",
           "PmvReading", "PmvRecorder", "Scenario", "attitude_in_orbital", "host_values", "kondor_scenario",
           "sigma_from_roll_pitch_yaw"]
