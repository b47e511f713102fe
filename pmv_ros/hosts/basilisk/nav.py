"""The PMV's roll and pitch as Basilisk attitude navigation: a ``NavAttMsg`` for Basilisk's FSW.

A horizon sensor measures two angles of the local vertical; an attitude
controller wants a three-axis attitude and the body rate. :class:`PmvAttitudeNav`
makes Basilisk's ``NavAttMsg`` from the PMV's newest valid roll and pitch,
the yaw of the case frame in the orbital frame and the body rate ``omega_BN_B``
taken from the spacecraft's states (what a gyro and a yaw source would
give; here the truth), and the orbital frame of the spacecraft's own state
(navigation). ``attTrackingError`` → ``mrpFeedback`` then steer what the PMV
measures to the reference: on ``hillPoint``'s Hill frame, the body holds the
*measured* local vertical, so the true attitude settles to minus the sensor's
error.

Until the PMV's first valid reading, roll and pitch are taken as zero (the
body on the local vertical); a reading with a lost pair keeps the last valid
one (counted, ``heldReadings``).
"""

from __future__ import annotations

import math

import numpy as np
from Basilisk.architecture import messaging, sysModel

from ...physics.attitude import roll_pitch_yaw_from_quaternion
from .frames import attitude_in_orbital, sigma_from_roll_pitch_yaw


class PmvAttitudeNav(sysModel.SysModel):
    """``attNavOutMsg`` (``NavAttMsg``): ``sigma_BN`` with the PMV's roll and pitch, yaw and ``omega_BN_B`` from
    ``scStateInMsg``. Runs after the sensor, in the same task (a lower priority)."""

    def __init__(self, sensor):
        super().__init__()
        self.ModelTag = "pmvAttitudeNav"
        self.sensor = sensor
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.attNavOutMsg = messaging.NavAttMsg()
        self.heldReadings = 0  #: readings with a lost pair (the last valid angles kept)
        self._angles = (0.0, 0.0)
        self._used = None  # the reading taken last

    def Reset(self, CurrentSimNanos):
        """A new run: no reading yet."""
        self.heldReadings = 0
        self._angles = (0.0, 0.0)
        self._used = None

    def UpdateState(self, CurrentSimNanos):
        """Write the attitude the PMV's newest reading gives at the spacecraft's newest state."""
        reading = self.sensor.reading
        if reading is not None and reading is not self._used:
            self._used = reading
            if math.isfinite(reading.roll_CO) and math.isfinite(reading.pitch_CO):
                self._angles = (reading.roll_CO, reading.pitch_CO)
            else:
                self.heldReadings += 1
        state = self.scStateInMsg()
        r, v = np.asarray(state.r_BN_N), np.asarray(state.v_BN_N)
        dcm_CB = self.sensor.dcm_CB
        yaw = float(roll_pitch_yaw_from_quaternion(attitude_in_orbital(r, v, state.sigma_BN, dcm_CB)[:, 0])[2])
        payload = messaging.NavAttMsgPayload()
        payload.timeTag = CurrentSimNanos * 1e-9
        payload.sigma_BN = sigma_from_roll_pitch_yaw(*self._angles, yaw, r, v, dcm_CB)[0].tolist()
        payload.omega_BN_B = list(state.omega_BN_B)
        self.attNavOutMsg.write(payload, CurrentSimNanos, self.moduleID)
