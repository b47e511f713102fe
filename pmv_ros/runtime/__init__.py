"""What the nodes do, without ROS: parameters and presets (assembly, parameters), input guards
(validation), one runtime per node — the sensor's (sensor_runtime, on sample_stream, sensor_health,
truth_buffer, orbit_buffer), the star tracker's (tracker), the monitor's (monitor_runtime, on monitor) —
records, and the flight that drives them for the campaign.

Imports :mod:`pmv_ros.physics`, :mod:`pmv_ros.analysis` and :mod:`pmv_ros.storage`; never rclpy.
"""
