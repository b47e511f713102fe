"""A day of trapped-proton hits along the presets' orbits: where, how many, when the buffer overflows (§6 item 6).

    python design/star_tracker_saa.py [--exposure-s 2.0] [--map saa.png]

For Kondor (500 km, 74.5°) and Meteor-M No.2 (835 km, 98.8°), AP8MAX, a
frame a second over one day from the preset's epoch, nadir pointing: the
share of frames with ≥ 5 proton hits and with ``buffer_overflow``, the
passes (runs of frames with ≥ 5 hits: start, length, where, most hits),
and the check that every such frame lies where the AP8 flux above 45 MeV is
non-zero (the grid's J(>45 MeV) at the spacecraft). The exposure is the
preset's (the optimum at the orbital rate), or ``--exposure-s`` (2 s: the
case of star_tracker.md §6.7's table, 3.7 % and 9.1 % of the day with ≥ 5
hits). ``--map FILE``: the frames with ≥ 5 hits on a longitude/latitude map.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.star_tracker import Outcome  # noqa: E402
from pmv_ros.physics.star_tracker.model import _eci_to_ecef, geodetic_from_ecef  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.tracker.runtime import TrackerRuntime  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402

PRESETS = ("config/kondor.yaml", "config/meteor_m2.yaml")


def fly_day(preset: str, exposure_s: float | None, seconds: float = 86400.0):
    overrides = {"protons.trapped": "max"}
    if exposure_s:
        overrides.update({"exposure_s": exposure_s, "frame_period_s": max(1.0, exposure_s)})
    values = flight_values(read_yaml_file(preset, "preset"), overrides).star_tracker
    tracker = TrackerRuntime(values, 0.0).tracker
    t = np.arange(0.0, seconds, values["frame_period_s"])
    q = np.tile([[0.0], [0.0], [0.0], [1.0]], t.size)
    frames = tracker.measure(t, q, np.zeros((3, t.size)))
    position, _ = tracker.orbit.state_eci(t)
    ecef = _eci_to_ecef(position, tracker.clock_epoch.earth_rotation_angle(t))
    latitude, longitude, height = geodetic_from_ecef(ecef)
    flux45, _, _ = tracker.radiation.environment(latitude, longitude, height, "max")
    return values, tracker, t, frames, np.degrees(latitude), np.degrees(longitude), flux45


def passes(t, hot, gap_s: float = 120.0):
    """(start, end) indices of the passes: runs of ``hot`` frames, joined across gaps shorter than ``gap_s`` (the
    Poisson counts flicker about 5 at a pass's edges)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], hot.astype(int), [0]])))
    runs = []
    for a, b in zip(edges[::2], edges[1::2]):
        if runs and t[a] - t[runs[-1][1] - 1] < gap_s:
            runs[-1] = (runs[-1][0], b)
        else:
            runs.append((a, b))
    return runs


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exposure-s", type=float, default=None)
    parser.add_argument("--map", type=Path, default=None)
    args = parser.parse_args(argv)
    drawn = []
    for preset in PRESETS:
        values, tracker, t, frames, lat, lon, flux45 = fly_day(preset, args.exposure_s)
        hot = frames.hits >= 5
        overflow = frames.outcome == Outcome.BUFFER_OVERFLOW
        print(f"{preset}: exposure {tracker.parameters.exposure_s:.2f} s, {t.size} frames over a day from "
              f"{values['sim.epoch_utc']}: ≥ 5 hits in {100 * hot.mean():.2f} % of frames, buffer_overflow in "
              f"{100 * overflow.mean():.2f} % (other reasons: "
              + ", ".join(f"{o.reason} {100 * np.mean(frames.outcome == o):.2f} %" for o in Outcome
                          if o not in (Outcome.OK, Outcome.BUFFER_OVERFLOW) and np.any(frames.outcome == o)) + ")")
        print(f"  most hits in a frame {frames.hits.max()}; frames with ≥ 5 hits where AP8 J(>45 MeV) is zero: "
              f"{int(np.sum(hot & (flux45 <= 0.0)))}; "
              f"where J(>45 MeV) < 1 cm-2 s-1: {int(np.sum(hot & (flux45 < 1.0)))}")
        runs = passes(t, hot)
        minutes = values["frame_period_s"] / 60.0
        longest = max((b - a for a, b in runs), default=0) * minutes
        print(f"  {len(runs)} passes with ≥ 5 hits (runs joined across gaps < 2 min), longest {longest:.1f} min:")
        for a, b in runs:
            peak = a + int(np.argmax(frames.hits[a:b]))
            print(f"    t {t[a] / 3600:6.2f} h, {(b - a) * minutes:4.1f} min, "
                  f"lat {lat[a:b].min():6.1f}…{lat[a:b].max():6.1f}°, "
                  f"lon {lon[a:b].min():7.1f}…{lon[a:b].max():7.1f}°, "
                  f"most hits {frames.hits[peak]} at ({lat[peak]:.1f}°, {lon[peak]:.1f}°), "
                  f"overflow {int(overflow[a:b].sum())} frames")
        drawn.append((preset, lat, lon, hot))
    if args.map:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(9, 4.5))
        for (preset, lat, lon, hot), colour in zip(drawn, ("tab:red", "tab:blue")):
            ax.plot(lon, lat, ",", color="0.85")
            ax.plot(lon[hot], lat[hot], ".", color=colour, markersize=2, label=f"{Path(preset).stem}: ≥ 5 hits")
        ax.set(xlabel="longitude, deg", ylabel="latitude, deg", xlim=(-180, 180), ylim=(-90, 90),
               title="Star-tracker frames with ≥ 5 proton hits, one day (AP8MAX)")
        ax.legend(loc="lower left")
        fig.savefig(args.map, dpi=120, bbox_inches="tight")
        print(f"map: {args.map}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
