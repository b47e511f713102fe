"""Typed domain records of the PMV topics and plain conversions to and from standard ROS 2 messages.

Importing this package imports the message packages (geometry_msgs, nav_msgs,
diagnostic_msgs, builtin_interfaces, rosgraph_msgs) but never rclpy: the conversions work
without ``rclpy.init()``.
"""

from .conversions import (
    ARCMIN_RAD,
    SAMPLES_STATUS_NAME,
    STATISTICS_STATUS_PREFIX,
    attitude_angles_from_msg,
    attitude_angles_to_msg,
    attitude_quaternion_from_msg,
    attitude_quaternion_to_msg,
    clock_from_msg,
    clock_to_msg,
    error_statistics_from_msg,
    error_statistics_to_msg,
    health_from_msg,
    health_to_msg,
    horizon_crossings_from_msg,
    horizon_crossings_to_msg,
    orbit_state_from_msg,
    orbit_state_to_msg,
    time_from_msg,
    time_to_msg,
    to_msg,
)
from .records import (
    BODY_FRAME,
    CHANNELS,
    CHORDS,
    ECI_FRAME,
    ORBITAL_FRAME,
    SENSOR_FRAME,
    AttitudeAngles,
    AttitudeQuaternion,
    ChannelStatistics,
    ErrorStatistics,
    HealthReport,
    HealthStatus,
    HorizonCrossings,
    Level,
    OrbitState,
)

__all__ = [
    "ARCMIN_RAD", "SAMPLES_STATUS_NAME", "STATISTICS_STATUS_PREFIX",
    "BODY_FRAME", "CHANNELS", "CHORDS", "ECI_FRAME", "ORBITAL_FRAME", "SENSOR_FRAME",
    "AttitudeAngles", "AttitudeQuaternion", "ChannelStatistics", "ErrorStatistics", "HealthReport",
    "HealthStatus", "HorizonCrossings", "Level", "OrbitState",
    "attitude_angles_from_msg", "attitude_angles_to_msg", "attitude_quaternion_from_msg",
    "attitude_quaternion_to_msg", "clock_from_msg", "clock_to_msg", "error_statistics_from_msg",
    "error_statistics_to_msg", "health_from_msg", "health_to_msg", "horizon_crossings_from_msg",
    "horizon_crossings_to_msg", "orbit_state_from_msg", "orbit_state_to_msg", "time_from_msg", "time_to_msg", "to_msg",
]
