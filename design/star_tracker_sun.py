"""The Sun in the field: once an orbit while the orbit's β angle is below 30° (physics.md §6 item 8).

    python design/star_tracker_sun.py [--preset config/kondor.yaml] [--days 0,30,…]

The preset's orbit (Kondor: no node drift, so β follows the Sun through the
year), nadir pointing, a frame every 10 s, one day at each of several dates:
per orbit, |β| (the Sun's angle from the orbit plane) and the number of
separate ``exclusion`` episodes with the Sun within 30° of the boresight
(an orbit cut by the day's start or end may split one in two); printed
grouped by |β| below and above the 30° exclusion angle.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.orbit.ephemeris import sun_direction_eci  # noqa: E402
from pmv_ros.physics.star_tracker import Outcome  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.tracker.runtime import TrackerRuntime  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="config/kondor.yaml")
    parser.add_argument("--days", default="0,20,40,60,80,100,120,140,160,180,200,220,240,260,280,300,320,340")
    args = parser.parse_args(argv)
    values = flight_values(read_yaml_file(args.preset, "preset"),
                           {"protons.trapped": "off", "frame_period_s": 10.0}).star_tracker
    rows = []
    for day in (float(d) for d in args.days.split(",")):
        tracker = TrackerRuntime(values, 0.0).tracker
        period = 2 * math.pi / tracker.orbit.mean_motion_rad_s
        t = day * 86400.0 + np.arange(0.0, 86400.0, 10.0)
        q = np.tile([[0.0], [0.0], [0.0], [1.0]], t.size)
        frames = tracker.measure(t, q, np.zeros((3, t.size)))
        position, velocity = tracker.orbit.state_eci(t)
        sun_position, _ = tracker.sun_and_moon_eci_m(t)
        seen = sun_position - position
        boresight = tracker.pointing(q, np.zeros((3, t.size)), tracker.orbit_environment(t)).axes_eci[:, 2, :]
        sun_angle = np.degrees(np.arccos(np.sum(boresight * seen, axis=0) / np.linalg.norm(seen, axis=0)))
        # The Sun's exclusions (the Moon's are exclusions too, at other places).
        excluded = (frames.outcome == Outcome.EXCLUSION) & (sun_angle < values["exclusion.sun_deg"])
        normal = np.cross(position, velocity, axis=0)
        normal /= np.linalg.norm(normal, axis=0)
        sun = sun_direction_eci(tracker.clock_epoch.julian_date_tt(t)).reshape(3, -1)
        beta = np.degrees(np.arcsin(np.sum(normal * sun, axis=0)))
        orbit_index = ((t - t[0]) // period).astype(int)
        for k in range(int(86400.0 // period)):
            mine = orbit_index == k
            starts = np.sum(np.diff(np.concatenate([[0], excluded[mine].astype(int)])) == 1)
            rows.append((day, k, float(np.abs(beta[mine]).mean()), int(starts), float(excluded[mine].mean())))
    rows = np.array(rows)
    low, high = rows[rows[:, 2] < 30.0], rows[rows[:, 2] >= 30.0]
    for name, group in (("|β| < 30°", low), ("|β| ≥ 30°", high)):
        if not group.size:
            print(f"{name}: no orbit")
            continue
        counts = {int(c): int(np.sum(group[:, 3] == c)) for c in np.unique(group[:, 3])}
        print(f"{name}: {group.shape[0]} orbits, exclusion episodes per orbit {counts}, share of the orbit excluded "
              f"{100 * group[:, 4].min():.1f}–{100 * group[:, 4].max():.1f} %")
    near = rows[np.abs(rows[:, 2] - 30.0) < 2.0]
    if near.size:
        print("within 2° of 30°: " + ", ".join(f"|β| {b:.1f}° → {int(c)}" for b, c in near[:, 2:4]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
