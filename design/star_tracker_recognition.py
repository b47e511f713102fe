"""Recognition on the real sky: the stand experiment, and failures that come back at the same places (§6 item 4).

    python design/star_tracker_recognition.py [--pointings 6000] [--orbits 10] [--preset config/kondor.yaml]

1. The stand experiment (thesis l. 1052): random inertial pointings at rest,
   the sky shown as the 8350 catalogue stars only, then as all 26547 (the
   other 18197 unknown to the tracker), ranking scatter σ_rank = 0.75 mag
   (and the flight default 0.3, and 0), the [A] recognition defaults: the
   share of frames without attitude (``no_stars`` + ``recognition_failure``)
   and its rise (§6: "several-fold", 3.9× with these values).
2. Along ``--orbits`` successive orbits of the preset, nadir pointing, a
   frame a second: the failures by the number of catalogue stars sent to
   recognition, and the sky places (1° bins of the argument of latitude: the
   preset's orbit keeps its plane, so a bin is the same patch of sky on every
   orbit) where they fall — the share of places whose failures repeat on
   another orbit, for frames with 3–4 stars (the thesis: the same places on
   every pass) and with more than 8 (single, random), against the share a
   random placement of as many failures would repeat.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.orbit.ephemeris import Epoch  # noqa: E402
from pmv_ros.physics.star_tracker import Outcome, Sky, StarTracker, TrackerParameters  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.tracker.runtime import TrackerRuntime  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402

FAILED = (Outcome.NO_STARS.value, Outcome.RECOGNITION_FAILURE.value)


class StandOrbit:
    """A still 'orbit' whose orbital frame is fixed in ECI (no smear): the stand's pointing is the attitude."""

    def state_eci(self, t_s):
        n = np.size(t_s)
        return np.tile([[7e6], [0.0], [0.0]], n), np.tile([[0.0], [1e-6], [0.0]], n)


def stand(sky: Sky, pointings: int, seed: int, sky_stars: int, scatter: float, repeats: int = 5) -> float:
    """The share of frames without attitude over random pointings (each pointing drawn ``repeats`` times)."""
    epoch = Epoch.from_utc("2000-01-01T12:00:00Z")
    tracker = StarTracker(TrackerParameters(sky_stars=sky_stars, rank_scatter_mag=scatter, trapped="off",
                                            sun_exclusion_rad=0.0, moon_exclusion_rad=0.0,
                                            earth_limb_exclusion_rad=0.0, exposure_s=2.0),
                          StandOrbit(), epoch, seed=seed, sky=sky)
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(4, pointings))
    q /= np.linalg.norm(q, axis=0)
    failed = 0
    for r in range(repeats):
        t = 1000.0 * r + np.arange(pointings) * 0.5  # other frame times: other draws
        frames = tracker.measure(t, q, np.zeros((3, pointings)))
        failed += np.isin(frames.outcome, FAILED).sum()
    return failed / (pointings * repeats)


def repeat_share(places: np.ndarray, orbit: np.ndarray) -> tuple[int, float]:
    """(places with a failure, share of them failing on ≥ 2 orbits)."""
    if not places.size:
        return 0, math.nan
    unique, index = np.unique(places, return_inverse=True)
    orbits_per_place = np.array([np.unique(orbit[index == k]).size for k in range(unique.size)])
    return unique.size, float(np.mean(orbits_per_place >= 2))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pointings", type=int, default=6000)
    parser.add_argument("--orbits", type=int, default=10)
    parser.add_argument("--preset", default="config/kondor.yaml")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    sky = Sky(2451545.0)
    print(f"stand experiment, {args.pointings} random pointings × 5 frames, [A] recognition defaults:")
    for scatter in (0.75, 0.3, 0.0):
        small = stand(sky, args.pointings, args.seed, 8350, scatter)
        large = stand(sky, args.pointings, args.seed, 26547, scatter)
        print(f"  σ_rank {scatter:.2f} mag: 8350-star sky {100 * small:.2f} %, 26547-star sky {100 * large:.2f} % "
              f"of frames without attitude: ×{large / small:.1f}")

    values = flight_values(read_yaml_file(args.preset, "preset"), {"protons.trapped": "off"}).star_tracker
    tracker = TrackerRuntime(values, 0.0).tracker
    period = 2 * math.pi / tracker.orbit.mean_motion_rad_s
    t = np.arange(0.0, args.orbits * period, values["frame_period_s"])
    q = np.tile([[0.0], [0.0], [0.0], [1.0]], t.size)
    frames = tracker.measure(t, q, np.zeros((3, t.size)))
    orbit = (t // period).astype(int)
    phase = np.mod(t, period) / period
    failed = np.isin(frames.outcome, FAILED)
    rng = np.random.default_rng(args.seed)
    print(f"{args.preset}: {args.orbits} orbits, {t.size} frames; frames without attitude by reason: "
          + ", ".join(f"{o.reason} {int(np.sum(frames.outcome == o))}" for o in Outcome if o != Outcome.OK
                      and np.any(frames.outcome == o)))
    for bin_deg in (1.0, 0.1):
        place = np.floor(phase * 360.0 / bin_deg).astype(int)
        print(f"  sky places of {bin_deg:g}° of the orbit ({bin_deg / 360 * period:.1f} s):")
        for name, chosen in (("< 3 stars (no_stars)", failed & (frames.used < 3)),
                             ("3–4 stars", failed & (frames.used >= 3) & (frames.used <= 4)),
                             ("5–8 stars", failed & (frames.used >= 5) & (frames.used <= 8)),
                             ("> 8 stars", failed & (frames.used > 8))):
            count = int(chosen.sum())
            places, share = repeat_share(place[chosen], orbit[chosen])
            random_pick = rng.choice(t.size, count, replace=False) if count else np.array([], int)
            _, random_share = repeat_share(place[random_pick], orbit[random_pick])
            print(f"    failures with {name}: {count} frames ({100 * count / t.size:.2f} %) at {places} places; "
                  f"places failing on ≥ 2 orbits {100 * share:.0f} % (as many failures at random frames: "
                  f"{100 * random_share:.0f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
