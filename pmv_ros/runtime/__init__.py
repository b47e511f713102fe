"""What the nodes do, without ROS: one package per node runtime, one for what they share, and the flight.

* :mod:`.common` — parameters and presets (``assembly``, ``parameters``), input guards
  (``validation``), frames, records, the clock watch, the truth and orbit buffers;
* :mod:`.sensor` — :class:`~pmv_ros.runtime.sensor.SensorRuntime` (sensor_node), on its sample
  stream, health and estimator output;
* :mod:`.tracker` — :class:`~pmv_ros.runtime.tracker.TrackerRuntime` (star_tracker_node);
* :mod:`.monitor` — :class:`~pmv_ros.runtime.monitor.MonitorRuntime` (error_monitor_node), on the
  monitor core, its event scan, alignment and records;
* :mod:`.control` — :class:`~pmv_ros.runtime.control.ControllerRuntime` (attitude_controller_node: the
  closed loop's plant and PD law) and the true pointing error;
* :mod:`.flight` — drives the runtimes for the campaign.

Arrows point down that list: ``common`` imports none of the node packages, they import
``common`` and not each other, and only ``flight`` uses them all (tests/system/test_layers.py).
Imports :mod:`pmv_ros.physics`, :mod:`pmv_ros.analysis` and :mod:`pmv_ros.storage`; never rclpy.
"""
