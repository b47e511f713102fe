"""pmv_ros: emulator of the PMV scanning infrared Earth horizon sensor.

One folder per layer; every import points down the list:

* :mod:`pmv_ros.cli` — the ``pmv`` command line: argparse and printing only;
* :mod:`pmv_ros.apps` — the campaign on Dask, the analysis of recorded telemetry, the report;
* :mod:`pmv_ros.nodes` — the ROS 2 nodes: parameters in, runtime, shim, publish;
* :mod:`pmv_ros.hosts` — the runtime in other simulators (Basilisk): beside the nodes, neither imports the other;
* :mod:`pmv_ros.runtime` — what the nodes do, without ROS (the campaign drives it too);
* :mod:`pmv_ros.analysis` — error statistics and the flight-test procedure;
* :mod:`pmv_ros.physics` — the instrument and the Earth (numpy/scipy only);
* :mod:`pmv_ros.storage` — bounded file reading, strict JSON, rosbag2 recordings.
"""

__version__ = "0.1.0"

#: The layer folders, bottom to top: a module imports its own layer and those before it.
#: ``hosts`` and ``nodes`` are siblings above the runtime (tests/system/test_layers.py keeps them apart).
LAYERS = ("storage", "physics", "analysis", "runtime", "hosts", "nodes", "apps", "cli")
