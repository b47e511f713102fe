"""What the nodes do, without ROS: parameters and presets, input guards, the sensor's sample
stream and health, the truth buffer, the monitor, and the flight that drives them for the campaign.

Imports :mod:`pmv_ros.physics`, :mod:`pmv_ros.analysis` and :mod:`pmv_ros.storage`; never rclpy.
"""
