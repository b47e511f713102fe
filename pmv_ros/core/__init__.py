"""Physics core of the PMV emulator: numpy/scipy only, never rclpy or *_msgs.

Units are SI and radians throughout (REP-103); degrees, km and arcmin appear
only at the edges (YAML presets, the CLI, reports).
"""
