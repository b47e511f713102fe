"""Statistics of the sensor's error: running and harmonic statistics and the published
flight-test procedure (physics.md §5). Imports :mod:`pmv_ros.physics` only; no ROS.
"""
