"""The PMV's local vertical as Basilisk attitude navigation: a ``NavAttMsg`` for Basilisk's FSW.

A horizon sensor measures two angles of the local vertical; an attitude
controller wants a three-axis attitude and the body rate.
:class:`PmvAttitudeNav` is the navigation step between them, all through
Basilisk messages:

* ``nadirInMsg`` (``BodyHeadingMsg``): the measured nadir in body components
  (:class:`~pmv_ros.hosts.basilisk.sensor.PmvHorizonSensor`'s ``nadirOutMsg``);
* ``attInMsg`` (``NavAttMsg``): where yaw and the body rate come from — any
  attitude navigation, ``simpleNav``'s ``attOutMsg``, a gyro-based estimator;
* ``transInMsg`` (``NavTransMsg``): the orbit, for the orbital frame
  (``simpleNav``'s ``transOutMsg``, an orbit determination).

``attNavOutMsg`` (``NavAttMsg``) then carries ``sigma_BN`` whose case frame
has the roll and pitch the PMV measured and the yaw of ``attInMsg``, both in
the orbital frame of ``transInMsg`` (:func:`~pmv_ros.hosts.basilisk.frames.navigation_sigma`),
with ``attInMsg``'s ``omega_BN_B`` and ``vehSunPntBdy``; its ``timeTag`` is the
time of the PMV reading used. ``attTrackingError`` → ``mrpFeedback`` then
steer what the PMV measures to the reference: on ``hillPoint``'s Hill frame
the body holds the *measured* local vertical, so the true attitude settles to
minus the sensor's error.

The newest reading is used until the next (the PMV writes none for a sample
with a lost chord pair). Before the first one — the sensor in no task, in a
task that runs after this one, or its first sample later — the bridge passes
``attInMsg``'s attitude on, said once through ``bskLogger``
(``BSK_WARNING``) and counted (:attr:`PmvAttitudeNav.stepsWithoutReading`):
never a made-up zero roll and pitch. An input that gives no attitude (an
orbit without an orbital frame, a non-finite attitude) does the same, said
once and counted (``stepsWithoutFrame``).
"""

from __future__ import annotations

import math

import numpy as np
from Basilisk.architecture import bskLogging, messaging, sysModel

from .frames import check_dcm, dcm_tuple, navigation_sigma
from .sensor import log_line


class PmvAttitudeNav(sysModel.SysModel):
    """``attNavOutMsg`` (``NavAttMsg``): the PMV's roll and pitch (``nadirInMsg``) with yaw and rate from
    ``attInMsg``, in the orbital frame of ``transInMsg``. Runs after the sensor (a lower priority, or a later
    task).

    Args:
        dcm_CB: the PMV's case frame in the body frame, ``[CB]`` (the sensor's ``dcm_CB``).
    """

    def __init__(self, dcm_CB=np.eye(3)):
        super().__init__()
        self.ModelTag = "pmvAttitudeNav"
        self.nadirInMsg = messaging.BodyHeadingMsgReader()
        self.attInMsg = messaging.NavAttMsgReader()
        self.transInMsg = messaging.NavTransMsgReader()
        self.attNavOutMsg = messaging.NavAttMsg()
        self.dcm_CB = check_dcm(dcm_CB)
        self._cb = dcm_tuple(self.dcm_CB)
        self._own_logger = None
        self._clear()

    def _log(self, level: int, text: str) -> None:
        self._own_logger = log_line(self, self._own_logger, level, text)

    def _clear(self) -> None:
        self.stepsWithoutReading = 0  #: steps before the first PMV reading (attInMsg's attitude passed on)
        self.stepsWithoutFrame = 0  #: steps whose inputs gave no attitude (attInMsg's attitude passed on)
        self.readingTime_s = math.nan  #: Basilisk time of the PMV reading used last, s
        self._said = set()

    def Reset(self, CurrentSimNanos):
        """A new run: no reading yet. ``BSK_ERROR`` (which ends the simulation) for an input not linked."""
        self._clear()
        for name in ("nadirInMsg", "attInMsg", "transInMsg"):
            if not getattr(self, name).isLinked():
                self._log(bskLogging.BSK_ERROR, f"{name} is not linked")

    def UpdateState(self, CurrentSimNanos):
        """Write the attitude the newest PMV reading gives with the newest yaw, rate and orbit."""
        navigation, orbit = self.attInMsg(), self.transInMsg()
        payload = messaging.NavAttMsgPayload()
        payload.omega_BN_B = navigation.omega_BN_B
        payload.vehSunPntBdy = navigation.vehSunPntBdy
        sigma = None
        if self.nadirInMsg.isWritten():
            self.readingTime_s = self.nadirInMsg.timeWritten() * 1e-9
            sigma = navigation_sigma(tuple(navigation.sigma_BN), tuple(orbit.r_BN_N), tuple(orbit.v_BN_N),
                                     tuple(self.nadirInMsg().rHat_XB_B), self._cb)
            if not sigma[0] == sigma[0]:
                sigma = None
                self.stepsWithoutFrame += 1
                if "frame" not in self._said:
                    self._said.add("frame")
                    self._log(bskLogging.BSK_WARNING, f"at {CurrentSimNanos * 1e-9:.3f} s attInMsg and transInMsg "
                                                      "give no attitude in an orbital frame: attInMsg's attitude "
                                                      "passed on (stepsWithoutFrame counts the steps)")
        else:
            self.stepsWithoutReading += 1
            if "reading" not in self._said:
                self._said.add("reading")
                self._log(bskLogging.BSK_WARNING, f"no PMV reading on nadirInMsg at {CurrentSimNanos * 1e-9:.3f} s "
                                                  "(is the sensor in a task that runs before this module?): "
                                                  "attInMsg's attitude passed on until the first "
                                                  "(stepsWithoutReading counts the steps)")
        if sigma is None:
            payload.sigma_BN = navigation.sigma_BN
            payload.timeTag = navigation.timeTag
        else:
            payload.sigma_BN = sigma
            payload.timeTag = self.readingTime_s
        self.attNavOutMsg.write(payload, CurrentSimNanos, self.moduleID)
