"""Solar protons: a GEO unit through November 2000, and the share of a day low orbits give them (§6 item 7).

    python design/star_tracker_flare.py [--spectral-index 2.0]

1. config/geo_flare.yaml's tracker (GEO, 2 s exposure, the named event
   "2000-11-08": NOAA's ≥ 10 MeV peak scaled to 45 MeV with the integral
   spectral index), a frame every 2 s from 8 Nov 2000 12:00 UTC for three
   days: the hours of ``buffer_overflow``, when it starts and ends, and when
   whole frames come back (the thesis: overflow at 21:30 on 9 Nov, a full
   frame at 07:30 on 10 Nov, "about a day" after the flare).
2. The share of a day a low orbit spends where L ≥ 7.1 (the Størmer cut-off
   of 45 MeV): 500 km / 74.5°, 835 km / 98.8°, 400 km / 51.6° (§6 item 7:
   ≈ 16 %, ≈ 22 %, 0 %).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.orbit.ephemeris import Epoch  # noqa: E402
from pmv_ros.physics.orbit.two_body import CircularOrbit  # noqa: E402
from pmv_ros.physics.star_tracker import Outcome, RadiationGrid  # noqa: E402
from pmv_ros.physics.star_tracker.model import _eci_to_ecef, geodetic_from_ecef  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.tracker.runtime import TrackerRuntime  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402


def utc(epoch: Epoch, t_s: float) -> str:
    from datetime import datetime, timedelta, timezone

    start = datetime(2000, 1, 1, 12, tzinfo=timezone.utc) + timedelta(seconds=float(epoch.seconds_since_j2000(t_s)))
    return start.strftime("%d %b %H:%M UTC")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spectral-index", type=float, default=None, help="override protons.spectral_index")
    args = parser.parse_args(argv)
    overrides = {"sim.epoch_utc": "2000-11-08T12:00:00Z"}
    if args.spectral_index is not None:
        overrides["protons.spectral_index"] = args.spectral_index
    values = flight_values(read_yaml_file("config/geo_flare.yaml", "preset"), overrides).star_tracker
    tracker = TrackerRuntime(values, 0.0).tracker
    event = tracker.parameters.solar_event
    t = np.arange(0.0, 3 * 86400.0, values["frame_period_s"])
    q = np.tile([[0.0], [0.0], [0.0], [1.0]], t.size)
    frames = tracker.measure(t, q, np.zeros((3, t.size)))
    overflow = frames.outcome == Outcome.BUFFER_OVERFLOW
    epoch = tracker.clock_epoch
    peak_t = event.peak_s - float(epoch.seconds_since_j2000(0.0))
    print(f"GEO, exposure {tracker.parameters.exposure_s:g} s, event 2000-11-08 with spectral index "
          f"{values['protons.spectral_index']:g}: peak I(>45 MeV) {event.peak_pfu:.0f} pfu at {utc(epoch, peak_t)}, "
          f"decay {event.decay_s / 3600:g} h; most hits in a frame {frames.hits.max()}")
    if overflow.any():
        first, last = np.flatnonzero(overflow)[[0, -1]]
        whole = np.flatnonzero((t > t[last]) & (frames.outcome != Outcome.BUFFER_OVERFLOW))
        print(f"  buffer_overflow: {overflow.sum() * values['frame_period_s'] / 3600:.1f} h in all, from "
              f"{utc(epoch, t[first])} to {utc(epoch, t[last])}; whole frames again from "
              f"{utc(epoch, t[whole[0]]) if whole.size else 'never'} ({(t[whole[0]] - peak_t) / 3600:.1f} h after the "
              f"≥ 10 MeV peak, {(t[whole[0]] - (event.onset_s - float(epoch.seconds_since_j2000(0.0)))) / 3600:.1f} h "
              f"after the onset)")
    else:
        print("  no buffer_overflow")
    at = {name: int(np.searchsorted(t, peak_t + hours * 3600.0)) for name, hours in
          (("21:30 9 Nov", 5.58), ("07:30 10 Nov", 15.58))}
    for name, k in at.items():
        print(f"  at {name}: {frames.hits[k]} hits, {Outcome(int(frames.outcome[k])).reason}")
    grid = RadiationGrid()
    epoch = Epoch.from_utc("2016-11-11T00:00:00Z")
    for altitude_km, inclination_deg in ((500.0, 74.5), (835.0, 98.8), (400.0, 51.6)):
        orbit = CircularOrbit(altitude_km * 1e3, math.radians(inclination_deg))
        s = np.arange(0.0, 86400.0, 10.0)
        position, _ = orbit.state_eci(s)
        lat, lon, height = geodetic_from_ecef(_eci_to_ecef(position, epoch.earth_rotation_angle(s)))
        _, _, shell = grid.environment(lat, lon, height)
        print(f"{altitude_km:.0f} km / {inclination_deg}°: L ≥ 7.1 (solar protons above 45 MeV reach) "
              f"{100 * np.mean(shell >= 7.1):.1f} % of the day")
    return 0


if __name__ == "__main__":
    sys.exit(main())
