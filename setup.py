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
    install_requires=["setuptools"],
    # The Basilisk host (pmv_ros.hosts.basilisk); `make venv` pins it in requirements-basilisk.txt.
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
