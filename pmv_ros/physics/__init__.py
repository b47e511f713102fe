"""The instrument and the Earth, bottom up:

* modules here — constants, conventions, published figures, the compiled kernels' decorator
  (:mod:`.compiled`), ellipsoid geometry, attitude and the attitude profile, the horizon radiance
  profile (:mod:`.radiance`), the star tracker's measurement model, ground error; they import only
  each other;
* :mod:`.orbit` — orbits, the TLE orbit, time scales and ephemerides;
* :mod:`.chain` (the signal chain) and :mod:`.environment` (the radiance environment) — on the two above;
* :mod:`.instrument` — the sensor model, correction, oblateness, bright bodies, scenarios A–D — on all of them.

numpy/scipy (and numba, for the compiled kernels of the sensing path) only, never rclpy or a message
package. Units are SI and radians (REP-103); degrees, km and arcmin appear only at the edges (presets,
the CLI, reports).
"""
