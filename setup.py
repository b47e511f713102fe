from glob import glob

from setuptools import find_packages, setup

PACKAGE = "pmv_ros"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=["pmv_ros", "pmv_ros.*", "pmv_msgs_shim", "pmv_msgs_shim.*"]),
    package_data={PACKAGE: ["data/*"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
    ],
    python_requires=">=3.11",
    # What pmv_ros imports at run time, as ranges; requirements.txt pins the versions the tests run with
    # (tests/system/test_install.py: each pin is inside its range). The ROS 2 wheels (rclpy, the messages)
    # come from a ROS 2 install or requirements.txt: the nodes need them, the physics and `pmv oblateness` do not.
    install_requires=[
        "numpy~=2.4",
        "scipy~=1.17",
        "numba~=0.68.1",
        "PyYAML~=6.0",
        "matplotlib~=3.10",
        "tqdm~=4.67",
        "threadpoolctl~=3.8",
        "rosbags~=0.11.9",
        "mcap~=1.6",
        "zstandard>=0.25",
        "dask>=2026.8.0",
        "distributed>=2026.8.0",
        "pyarrow>=26.0",
        "sgp4~=2.25",
        "pyerfa~=2.0.1",
    ],
    # The Basilisk host (pmv_ros.hosts.basilisk): bsk brings pooch, which Basilisk's helpers need;
    # `make venv` pins it in requirements-basilisk.txt.
    extras_require={"basilisk": ["bsk==2.12.1"]},
    zip_safe=True,
    maintainer="pmv_ros maintainers",
    maintainer_email="pmv-ros@example.com",
    description="Emulator of the PMV scanning infrared Earth horizon sensor for ROS 2 Jazzy.",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "pmv = pmv_ros.cli:main",
            "sensor_node = pmv_ros.nodes.sensor_node:main",
            "star_tracker_node = pmv_ros.nodes.star_tracker_node:main",
            "error_monitor_node = pmv_ros.nodes.error_monitor_node:main",
            "attitude_controller_node = pmv_ros.nodes.attitude_controller_node:main",
        ],
    },
)
