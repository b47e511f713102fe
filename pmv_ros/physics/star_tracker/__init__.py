"""The star tracker: the truth source, with the failures the real one has (physics.md §6).

* :mod:`.model` — the frame model: the real sky, smear, recognition, accuracy from the stars in the field,
  proton hits and the video buffer, Sun/Moon/Earth exclusion, outage windows; :class:`Outcome` reason codes;
* :mod:`.sky` — the shipped Hipparcos-2 table at the run's date and the stars in a field;
* :mod:`.radiation` — the shipped AP8 grid (trapped protons, McIlwain L) and solar proton events;
* :mod:`.draws` — random draws keyed by the frame's time;
* :mod:`.frames` — the frame grid on a truth stream and the publication queue;
* :mod:`.tables` — the shipped tables' file format, read bounded.
"""

from .frames import RELEASE_TOLERANCE_S, FrameGrid, GridFrames, LatencyQueue, read_only
from .model import (REASON_ORDER, Outcome, StarTracker, FrameMeasurement, TrackerParameters, optimal_exposure_s,
                    smear_loss_mag, trail_rate)
from .radiation import SOLAR_EVENTS, RadiationGrid, SolarEvent
from .sky import Sky

__all__ = ["REASON_ORDER", "RELEASE_TOLERANCE_S", "FrameGrid", "GridFrames", "LatencyQueue", "Outcome",
           "RadiationGrid", "SOLAR_EVENTS", "Sky", "SolarEvent", "StarTracker", "FrameMeasurement", "TrackerParameters",
           "optimal_exposure_s", "read_only", "smear_loss_mag", "trail_rate"]
