"""ROS 2 nodes of pmv_ros: thin wiring around :mod:`pmv_ros.runtime` through :mod:`pmv_msgs_shim`."""
