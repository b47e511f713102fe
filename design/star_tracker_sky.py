"""The real sky against a uniform one, and what the rate costs it (physics.md §6 items 1 and 3).

    python design/star_tracker_sky.py [--pointings 6000] [--seed 1]

1. Over random pointings (uniform on the sphere, random roll about the
   boresight) of the 7.81° square field: the mean number of catalogue stars
   (the 8350 brightest) in the field and the fraction with fewer than 3
   (star_tracker.md §6.7: mean 12.4, < 3 in 0.37 %; a uniform Poisson sky
   with the same mean gives 0.04 %).
2. The rate sweep of §6 item 3 with a 2 s exposure (the §6 table's case)
   and with each preset's exposure: the share of the same fields with fewer
   than 3 registered catalogue stars (they lose recognition: ``no_stars``)
   at 0, 250, 300, 400 and 600″/s across the boresight, and the share that
   gives no attitude at all (adding the expected recognition failures with
   the [A] defaults, no false objects).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.stats import poisson

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.constants import ARCSEC_RAD  # noqa: E402
from pmv_ros.physics.star_tracker import Sky, smear_loss_mag  # noqa: E402
from pmv_ros.physics.star_tracker.model import recognition_failure, rotation_matrices  # noqa: E402

FIELD_RAD = math.radians(7.81)
CATALOGUE = 8350
RATES_ARCSEC_S = (0.0, 250.0, 300.0, 400.0, 600.0)


def field_stars(sky: Sky, pointings: int, seed: int):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(4, pointings))
    return sky.stars_in_fields(rotation_matrices(q / np.linalg.norm(q, axis=0)), FIELD_RAD / 2.0)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pointings", type=int, default=6000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    sky = Sky(2451545.0 + 16 * 365.25)
    stars = field_stars(sky, args.pointings, args.seed)
    catalogue = stars.star < CATALOGUE
    counts = np.bincount(stars.field[catalogue], minlength=args.pointings)
    mean = counts.mean()
    print(f"{args.pointings} random pointings of a {math.degrees(FIELD_RAD):.2f}° square, the {CATALOGUE}-star "
          f"catalogue: mean {mean:.2f} stars, median {np.median(counts):.0f}, min {counts.min()}; fewer than 3 in "
          f"{100 * np.mean(counts < 3):.2f} % "
          f"(binomial 1σ ±{100 * math.sqrt(np.mean(counts < 3) / args.pointings):.2f} %), "
          f"3–4 in {100 * np.mean((counts >= 3) & (counts <= 4)):.1f} %, > 8 in {100 * np.mean(counts > 8):.1f} %; "
          f"a uniform Poisson sky of the same mean: {100 * poisson.cdf(2, mean):.3f} %")
    limit0 = sky.hp_mag[CATALOGUE - 1] + 1.0
    print(f"detection limit at rest m_det0 = {limit0:.2f} (catalogue limit {sky.hp_mag[CATALOGUE - 1]:.2f} + 1.0)")
    for exposure_s, label in ((2.0, "2 s (the GEO units; §6's table)"), (0.75, "0.75 s (Kondor)"),
                              (0.81, "0.81 s (Meteor-M)")):
        row = []
        for rate in RATES_ARCSEC_S:
            limit = limit0 - float(smear_loss_mag(rate * ARCSEC_RAD, exposure_s))
            registered = catalogue & (stars.hp_mag <= limit)
            n = np.bincount(stars.field[registered], minlength=args.pointings)
            used = np.minimum(n, 10)  # no false objects: the K = 10 brightest are catalogue stars or brighter
            expected_failure = np.where(used < 3, 1.0, np.vectorize(recognition_failure)(used, 0, 0.3, 1.5, 0.01))
            row.append(f"{rate:.0f}″/s: < 3 stars {100 * np.mean(n < 3):.1f} %, "
                       f"no attitude {100 * expected_failure.mean():.1f} %")
        print(f"exposure {label}: " + "; ".join(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
