"""Typed domain records of the PMV topics and plain conversions to and from standard ROS 2 messages.

Importing this package imports the message packages (geometry_msgs, nav_msgs,
diagnostic_msgs, builtin_interfaces, rosgraph_msgs) but never rclpy: the conversions work
without ``rclpy.init()``.
"""

from .conversions import (
    PENDING,
    SAMPLES_STATUS_NAME,
    STATISTICS_STATUS_PREFIX,
    attitude_angles_from_msg,
    attitude_quaternion_from_msg,
    clock_from_msg,
    error_statistics_from_msg,
    health_from_msg,
    horizon_crossings_from_msg,
    orbit_state_from_msg,
    read_attitude_angles,
    read_attitude_quaternion,
    read_orbit_state,
    read_transform,
    time_from_msg,
    write_attitude_angles,
    write_attitude_quaternion,
    write_clock,
    write_error_statistics,
    write_health,
    write_horizon_crossings,
    write_attitude_imu,
    read_attitude_imu,
    write_statistics_vector,
    write_orbit_state,
    write_orbital_transform,
    write_stamp,
    write_transform,
)
from .orbit_elements import (
    ORBIT_STATUS_NAME,
    orbit_status_name,
    WIRE_CONVENTION,
    OrbitElements,
    find_orbit_elements,
    orbit_elements_from_status,
    orbit_elements_status,
)
from .records import (
    BODY_FRAME,
    ECI_FRAME,
    ORBITAL_FRAME,
    SENSOR_FRAME,
    AttitudeAngles,
    AttitudeQuaternion,
    ErrorStatistics,
    HealthReport,
    HealthStatus,
    HorizonCrossings,
    Level,
    OrbitState,
    check_stamp,
    checked_lines_of_sight,
)

__all__ = [
    "SAMPLES_STATUS_NAME", "STATISTICS_STATUS_PREFIX",
    "BODY_FRAME", "ECI_FRAME", "ORBITAL_FRAME", "SENSOR_FRAME",
    "AttitudeAngles", "AttitudeQuaternion", "ErrorStatistics", "HealthReport",
    "HealthStatus", "HorizonCrossings", "Level", "OrbitState",
    "attitude_angles_from_msg", "attitude_quaternion_from_msg", "clock_from_msg", "error_statistics_from_msg",
    "health_from_msg", "horizon_crossings_from_msg", "orbit_state_from_msg", "time_from_msg",
    "check_stamp", "checked_lines_of_sight", "read_attitude_angles", "read_attitude_quaternion", "read_orbit_state",
    "write_attitude_angles", "write_attitude_quaternion", "write_clock", "write_error_statistics", "write_health",
    "write_horizon_crossings", "write_attitude_imu", "read_attitude_imu", "write_statistics_vector",
    "write_orbit_state", "write_stamp", "read_transform", "write_orbital_transform", "write_transform",
    "PENDING", "ORBIT_STATUS_NAME", "orbit_status_name", "WIRE_CONVENTION", "OrbitElements", "find_orbit_elements",
    "orbit_elements_from_status",
    "orbit_elements_status",
]
