"""The package installs the two ways users install it: ``rosdep install --from-paths src`` and ``pip install``.

rosdep: every ``<*depend>`` key of package.xml must be a ROS package or a key of rosdep's rule files (ros/rosdistro
``rosdep/base.yaml`` and ``python.yaml``, vendored in ../shared/vendor/rosdep) with a rule for Ubuntu, the platform
of ROS 2 Jazzy; a key that is neither makes a user's ``rosdep install`` fail ("Cannot locate rosdep definition").
The ROS packages are those the pinned ROS 2 wheels install (the venv's ament index) and those vendored as
snapshots (launch, launch_ros, tf2_msgs, …); rosdep finds the others of a ROS 2 install in rosdistro's
distribution file, which is not vendored.

pip: setup.py's ``install_requires`` is what a plain ``pip install`` brings; requirements.txt pins the versions
the tests run with, and each pin must be inside the range setup.py states. The Basilisk extra's bsk pins some of
the same packages exactly: requirements.txt's pins must satisfy them, or ``pip install .[basilisk]`` beside
requirements.txt cannot be resolved.
"""

from __future__ import annotations

import ast
import importlib.metadata
import re
import sys
import tarfile
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest
import yaml
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from children import VENDOR

REPO = Path(__file__).resolve().parents[2]
RULE_FILES = (VENDOR / "rosdep" / "base.yaml", VENDOR / "rosdep" / "python.yaml")


def package_xml_keys() -> dict[str, str]:
    """Every ``<*depend>`` key of package.xml → its tag."""
    root = ElementTree.parse(REPO / "package.xml").getroot()
    return {element.text.strip(): element.tag for element in root if element.tag.endswith("depend")}


def ros_packages() -> set[str]:
    """The ROS packages at hand: the venv's ament index and the vendored snapshots' package.xml names."""
    index = Path(sys.prefix) / "share" / "ament_index" / "resource_index" / "packages"
    names = {path.name for path in index.iterdir()} if index.is_dir() else set()
    for archive in sorted((VENDOR / "snapshots").glob("*.tar.gz")):
        with tarfile.open(archive) as tar:
            for member in tar:
                if member.isfile() and member.name.endswith("/package.xml"):
                    text = tar.extractfile(member).read()
                    names.add(ElementTree.fromstring(text).findtext("name").strip())
    return names


def pins(*files: str) -> dict[str, str]:
    """``name==version`` lines of requirement files → {canonical name: version}."""
    found = {}
    for name in files:
        for line in (REPO / name).read_text().splitlines():
            match = re.match(r"^\s*([A-Za-z0-9_.\-]+)\s*==\s*([^\s;#]+)", line)
            if match:
                found[canonicalize_name(match.group(1))] = match.group(2)
    return found


def setup_keyword(keyword: str):
    """A literal keyword argument of the ``setup(...)`` call of setup.py."""
    tree = ast.parse((REPO / "setup.py").read_text())
    call = next(node for node in ast.walk(tree)
                if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "setup")
    return ast.literal_eval(next(item.value for item in call.keywords if item.arg == keyword))


@pytest.mark.skipif(not all(path.is_file() for path in RULE_FILES),
                    reason=f"no rosdep rule files in {VENDOR / 'rosdep'}: not checked")
def test_every_package_xml_key_resolves_with_rosdep():
    rules = {}
    for path in RULE_FILES:
        rules.update(yaml.load(path.read_text(), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)))
    ros = ros_packages()
    keys = package_xml_keys()
    assert {"rclpy", "python3-numpy"} <= set(keys)  # the file was read
    unresolved = [f"<{tag}>{key}" for key, tag in keys.items()
                  if key not in ros and not (isinstance(rules.get(key), dict) and "ubuntu" in rules[key])]
    assert not unresolved, (f"package.xml keys that are neither ROS packages nor rosdep keys with an Ubuntu rule: "
                            f"{unresolved}")


def test_every_install_requirement_is_pinned_inside_its_range():
    pinned = pins("requirements.txt")
    requirements = [Requirement(text) for text in setup_keyword("install_requires")]
    assert {"numpy", "scipy", "pyyaml"} <= {canonicalize_name(req.name) for req in requirements}
    outside = [f"{req} (requirements.txt: {pinned.get(canonicalize_name(req.name), 'not pinned')})"
               for req in requirements if pinned.get(canonicalize_name(req.name)) not in req.specifier]
    assert not outside, f"install_requires without a pin inside its range: {outside}"
    extra = [Requirement(text) for text in setup_keyword("extras_require")["basilisk"]]
    basilisk = pins("requirements-basilisk.txt")
    assert all(basilisk.get(canonicalize_name(req.name)) in req.specifier for req in extra), (extra, basilisk)


def test_the_pins_satisfy_the_ones_of_bsk():
    try:
        requires = importlib.metadata.requires("bsk")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("bsk (Basilisk) is not installed: pip install pmv_ros[basilisk]")
    pinned = pins("requirements.txt", "requirements-basilisk.txt")
    needed = [Requirement(text) for text in requires]
    needed = [req for req in needed if req.marker is None or req.marker.evaluate({"extra": ""})]
    assert {"sgp4", "tqdm", "matplotlib"} <= {canonicalize_name(req.name) for req in needed}
    fights = [f"bsk wants {req}, requirements pin {pinned[canonicalize_name(req.name)]}" for req in needed
              if canonicalize_name(req.name) in pinned and pinned[canonicalize_name(req.name)] not in req.specifier]
    assert not fights, fights


# The dependencies without a rosdep key are optional in the code: where one is missing, the feature that needs it
# says so in one line and the rest works. Here each is hidden from the import system.

def test_without_dask_pmv_campaign_refuses_in_one_line(monkeypatch, tmp_path):
    import importlib.util

    from cli_runner import pmv

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *rest: None if name in ("dask", "pyarrow")
                        else real(name, *rest))
    result = pmv("campaign", "--config", REPO / "config" / "kondor.yaml", "--days", "1", "--seeds", "1",
                 "--out", tmp_path / "out")
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "pmv campaign: error: pmv campaign needs dask, pyarrow, which cannot be imported: pip install dask pyarrow"]
    assert not (tmp_path / "out").exists()


def test_without_sgp4_an_element_set_is_refused_in_one_line(monkeypatch):
    from pmv_ros.physics.orbit.ephemeris import Epoch
    from pmv_ros.physics.orbit.tle import NO_SGP4, TleOrbit

    preset = yaml.safe_load((REPO / "config" / "meteor_m2_tle.yaml").read_text())["/**"]["ros__parameters"]
    monkeypatch.setitem(sys.modules, "sgp4.api", None)  # import sgp4.api raises ImportError
    with pytest.raises(ValueError) as refused:
        TleOrbit(preset["orbit"]["tle_line1"], preset["orbit"]["tle_line2"], Epoch.from_utc("2016-11-11T00:00:00Z"))
    assert str(refused.value) == NO_SGP4 and "pip install sgp4" in NO_SGP4


def test_without_threadpoolctl_the_nodes_run_and_say_so_once(monkeypatch):
    from pmv_ros.nodes import launch

    said = []
    monkeypatch.setattr(launch, "ThreadpoolController", None)
    monkeypatch.setattr(launch.rclpy.logging, "get_logger", lambda name: type("Logger", (), {
        "warning": staticmethod(said.append)}))
    for _ in range(2):
        launch.hold_single_threaded_blas()
        launch.release_single_threaded_blas()
    assert said == [launch.NO_THREADPOOLCTL]
