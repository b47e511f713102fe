"""What the nodes do, without ROS: parameters and presets (assembly, parameters), input guards
(validation), the sensor's samples and health (sample_stream, sensor_health, truth_buffer), the star
tracker's frames (tracker), the monitor, records, and the flight that drives them for the campaign.

Imports :mod:`pmv_ros.physics`, :mod:`pmv_ros.analysis` and :mod:`pmv_ros.storage`; never rclpy.
"""
