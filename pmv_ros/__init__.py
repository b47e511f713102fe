"""pmv_ros: emulator of the PMV scanning infrared Earth horizon sensor.

The physics lives in :mod:`pmv_ros.core` (numpy/scipy only, no ROS imports);
the ROS 2 nodes in :mod:`pmv_ros.nodes` are a thin skin over it, and the
``pmv`` command line in :mod:`pmv_ros.cli` uses the same core.
"""

__version__ = "0.1.0"
