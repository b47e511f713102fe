"""Make pmv_ros/data/radiation_grid.bin, the star tracker's proton environment, with the PyPI package ``aep8``.

physics.md §6 items 6 and 7, in AP8's own coordinates: the McIlwain L (as
1/L, 0 on open field lines) and ln(B/B0) of each model's magnetic field
(AP8MIN's and AP8MAX's) on a geodetic latitude × longitude × altitude grid
(:data:`LATITUDES_DEG`, :data:`LONGITUDES_DEG`, :data:`ALTITUDES_KM`), and
the omnidirectional integral proton flux above 45 and 100 MeV of each model
as log10(J + 1 cm⁻² s⁻¹) on an (L, ln B/B0) grid (:data:`SHELLS_L`,
:data:`LOG_FIELD_RATIOS`). The field is smooth where the flux is steep, so
interpolating L and B and then the flux table stays far closer to aep8 than
interpolating the flux on a geographic grid of the same size
(design/star_tracker_grid_error.py measures it). AP8's field models are
fixed (its MIN and MAX epochs), so nothing depends on the date given to aep8.

A development tool: ``pip install aep8`` (not a run-time dependency; it
needs astropy), then ``python tools/make_radiation_grid.py [--out FILE]``.
The same package version gives the same file, bit for bit
(tests/physics/test_star_tracker_data.py regenerates it and compares);
design/star_tracker_grid_error.py measures the interpolation against aep8.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.star_tracker.radiation import (FLUX_COLUMNS, INVERSE_L_SCALE, LOG_FIELD_SCALE,  # noqa: E402
                                                     LOG_FLUX_SCALE, RADIATION_FILE)
from pmv_ros.physics.star_tracker.tables import data_path, write_table  # noqa: E402

LATITUDES_DEG = np.linspace(-90.0, 90.0, 91)
LONGITUDES_DEG = np.linspace(-180.0, 180.0, 91)
#: Every 100 km through low orbits, sparse towards GEO (the field is smooth; L and B are all that is interpolated).
ALTITUDES_KM = np.concatenate([np.arange(150.0, 2000.0, 100.0), [2200, 2500, 3000, 4000, 5000, 6500, 8000, 10000,
                                                                  13000, 17000, 22000, 30000, 40000]])
#: The flux tables' axes: McIlwain L and ln(B/B0) (AP8's > 45 MeV protons are zero beyond L 3 and ln(B/B0) 2.6).
SHELLS_L = np.round(np.arange(1.0, 3.2001, 0.01), 2)
LOG_FIELD_RATIOS = np.round(np.arange(0.0, 3.0001, 0.01), 2)
#: The date given to aep8 (its field models do not depend on it).
DATE = "2000-01-01T00:00:00"


def aep8_field(latitude_deg, longitude_deg, altitude_km, solar: str):
    """aep8's McIlwain L and B/B0 of AP8's field model for ``solar`` ("min" or "max") at geodetic points."""
    import aep8
    from astropy import units as u
    from astropy.coordinates import EarthLocation
    from astropy.time import Time

    location = EarthLocation.from_geodetic(lon=np.asarray(longitude_deg) * u.deg, lat=np.asarray(latitude_deg) * u.deg,
                                           height=np.asarray(altitude_km) * u.km)
    shell, field = aep8.model("p", solar).geomagnetic_coordinates(location, Time(DATE, scale="utc"))
    return np.asarray(shell, float), np.asarray(field, float)


def aep8_flux(shell, field, solar: str, energy_mev: float):
    """aep8's omnidirectional integral proton flux above ``energy_mev`` at (L, B/B0), cm⁻² s⁻¹ (0 where undefined)."""
    import aep8
    from astropy import units as u

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # NaN where L is undefined
        flux = aep8.model("p", solar).integral_flux_for_geomagnetic_coordinates(shell, field, energy_mev * u.MeV).value
    return np.where(np.isfinite(flux) & (flux > 0.0), flux, 0.0)


def aep8_environment(latitude_deg, longitude_deg, altitude_km) -> dict:
    """aep8 itself at geodetic points: each flux column (cm⁻² s⁻¹) and 1/L of AP8MAX's field (0: undefined)."""
    columns = {}
    for solar in ("min", "max"):
        shell, field = aep8_field(latitude_deg, longitude_deg, altitude_km, solar)
        for (phase, energy_mev), name in FLUX_COLUMNS.items():
            if phase == solar:
                columns[name] = aep8_flux(shell, field, solar, energy_mev)
        if solar == "max":
            columns["inverse_l"] = inverse_shell(shell)
    return columns


def inverse_shell(shell):
    """1/L, 0 where L is undefined (open field lines)."""
    shell = np.asarray(shell, float)
    return np.where(np.isfinite(shell) & (shell > 0.0), 1.0 / np.where(shell > 0.0, shell, 1.0), 0.0)


def grid_columns() -> tuple[dict, dict]:
    """(provenance, columns) of the grid, computed with the installed ``aep8``."""
    from importlib.metadata import version

    alt, lat, lon = np.meshgrid(ALTITUDES_KM, LATITUDES_DEG, LONGITUDES_DEG, indexing="ij")
    columns = {"latitude_deg": LATITUDES_DEG.astype("<f8"), "longitude_deg": LONGITUDES_DEG.astype("<f8"),
               "altitude_km": ALTITUDES_KM.astype("<f8"), "shell_l": SHELLS_L.astype("<f8"),
               "log_field_ratio": LOG_FIELD_RATIOS.astype("<f8")}
    shells, fields = np.meshgrid(SHELLS_L, np.exp(LOG_FIELD_RATIOS), indexing="ij")
    for solar in ("min", "max"):
        shell, field = aep8_field(lat, lon, alt, solar)
        columns[f"{solar}_inverse_l"] = np.round(inverse_shell(shell) * INVERSE_L_SCALE).astype("<i2")
        log_field = np.log(np.where(np.isfinite(field) & (field >= 1.0), field, 1.0))
        columns[f"{solar}_log_field_ratio"] = np.round(np.minimum(log_field, 32767 / LOG_FIELD_SCALE)
                                                       * LOG_FIELD_SCALE).astype("<i2")
    for (solar, energy_mev), name in FLUX_COLUMNS.items():
        log_flux = np.log10(aep8_flux(shells, fields, solar, energy_mev) + 1.0)
        columns[name] = np.round(log_flux * LOG_FLUX_SCALE).astype("<i2")
    provenance = {
        "package": "aep8",
        "version": version("aep8"),
        "command": "python tools/make_radiation_grid.py",
        "model": "AP8MIN and AP8MAX (IRBEM): McIlwain L and B/B0 of each model's field on a geodetic grid, and "
                 "log10(omnidirectional integral proton flux + 1 cm-2 s-1) on an (L, ln B/B0) grid",
        "date": DATE,
        "coordinates": "geodetic (WGS84) latitude, longitude, height",
    }
    return provenance, columns


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=data_path(RADIATION_FILE), help="file to write")
    args = parser.parse_args(argv)
    provenance, columns = grid_columns()
    data = write_table(args.out, provenance, columns)
    print(f"{args.out}: {columns['max_inverse_l'].shape} field grid, {columns['ap8max_45mev'].shape} flux tables, "
          f"AP8MAX J(>45 MeV) up to {10 ** (columns['ap8max_45mev'].max() / LOG_FLUX_SCALE) - 1:.0f} cm-2 s-1, "
          f"{len(data)} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
