"""The instrument and the Earth: orbit, attitude, horizon geometry, radiance, the signal chain,
the flight environment, correction, oblateness, the star tracker's measurement model, ground error.

numpy/scipy only, never rclpy or a message package. Units are SI and radians (REP-103);
degrees, km and arcmin appear only at the edges (presets, the CLI, reports).
"""
