"""The package's folders are layers and every import points down (pmv_ros/__init__.py lists them).

Read from the source with ``ast`` (imports inside functions count too), so a
new upward arrow fails here before anyone draws the house again.
"""

from __future__ import annotations

import ast
from pathlib import Path

from pmv_ros import LAYERS

PACKAGE = Path(__file__).resolve().parents[2] / "pmv_ros"
SHIM = PACKAGE.parent / "pmv_msgs_shim"

#: The message shim sits between the runtime (whose records it lays out) and the nodes.
SHIM_RANK = LAYERS.index("runtime") + 0.5


def _rank(module: str) -> float | None:
    parts = module.split(".")
    if parts[0] == "pmv_msgs_shim":
        return SHIM_RANK
    if parts[0] != "pmv_ros" or len(parts) < 2 or parts[1] not in LAYERS:
        return None
    return LAYERS.index(parts[1])


def _module(path: Path) -> str:
    root = SHIM if path.is_relative_to(SHIM) else PACKAGE
    return ".".join([root.name, *path.relative_to(root).with_suffix("").parts])


def _imports(path: Path) -> list[str]:
    module_parts = _module(path).split(".")
    if module_parts[-1] == "__init__":
        module_parts.pop()
    package = module_parts if path.name == "__init__.py" else module_parts[:-1]
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
                if not node.module:  # from .. import campaign: the names are modules
                    found += [f"{target}.{alias.name}" for alias in node.names]
                    continue
                found.append(target)
            else:
                found.append(node.module)
    return found


#: Inside a layer, its parts in order (pmv_ros/runtime/__init__.py, pmv_ros/physics/__init__.py): a part imports
#: itself and the parts of lower rank, never one of its own rank or above. ``None`` names the layer's own modules.
INNER_RANKS = {
    "runtime": {"common": 0, "sensor": 1, "tracker": 1, "monitor": 1, "control": 1, "flight": 2},
    "physics": {None: 0, "orbit": 1, "chain": 2, "environment": 2, "star_tracker": 2, "instrument": 3},
}

#: The most modules one folder holds (the issue that grouped the runtime and the physics by part).
MAX_MODULES_PER_FOLDER = 12


def _part(module: str) -> tuple[str, str | None] | None:
    """(layer, part) of a module inside a layer with inner ranks; part is None for the layer's own modules."""
    parts = module.split(".")
    if parts[0] != "pmv_ros" or len(parts) < 3 or parts[1] not in INNER_RANKS:
        return None
    ranks = INNER_RANKS[parts[1]]
    if parts[2] in ranks:
        return parts[1], parts[2]
    return (parts[1], None) if None in ranks else None


def _inner_violation(source: str, target: str) -> bool:
    own, other = _part(source), _part(target)
    if own is None or other is None or own[0] != other[0] or own == other:
        return False
    ranks = INNER_RANKS[own[0]]
    return ranks[other[1]] >= ranks[own[1]]


def test_every_module_lives_in_a_layer():
    loose = [p.relative_to(PACKAGE).as_posix() for p in PACKAGE.rglob("*.py")
             if p.relative_to(PACKAGE).parts[0] not in LAYERS and p.name != "__init__.py"]
    assert not loose, f"modules outside the layer folders: {loose}"


def test_imports_point_down():
    upward = []
    for path in sorted([*PACKAGE.rglob("*.py"), *SHIM.rglob("*.py")]):
        own = _rank(_module(path))
        if own is None:
            continue
        for target in _imports(path):
            rank = _rank(target)
            if rank is not None and rank > own:
                upward.append(f"{_module(path)} → {target}")
    assert not upward, "imports pointing up:\n" + "\n".join(upward)


def test_parts_of_a_layer_import_down_and_not_sideways():
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        source = _module(path)
        if source.endswith(".__init__"):
            source = source[: -len(".__init__")]
        wrong += [f"{source} → {target}" for target in _imports(path) if _inner_violation(source, target)]
    assert not wrong, "imports across the parts of a layer, sideways or up:\n" + "\n".join(wrong)


def test_no_folder_holds_more_than_twelve_modules():
    crowded = {}
    for folder in [PACKAGE, SHIM, *[p for p in PACKAGE.rglob("*") if p.is_dir() and p.name != "__pycache__"]]:
        count = len([p for p in folder.glob("*.py") if p.name != "__init__.py"])
        if count > MAX_MODULES_PER_FOLDER:
            crowded[folder.relative_to(PACKAGE.parent).as_posix()] = count
    assert not crowded, f"folders over {MAX_MODULES_PER_FOLDER} modules: {crowded}"


def test_the_check_sees_an_upward_import(tmp_path):
    assert _rank("pmv_ros.cli.common") > _rank("pmv_ros.apps.campaign") > _rank("pmv_ros.runtime.monitor.core")
    assert _rank("pmv_ros.physics.instrument.sensor") < SHIM_RANK < _rank("pmv_ros.nodes.base")
    assert _rank("numpy") is None
    assert _rank(_module(SHIM / "records.py")) == SHIM_RANK
    assert _inner_violation("pmv_ros.runtime.common.assembly", "pmv_ros.runtime.monitor.core")
    assert _inner_violation("pmv_ros.runtime.sensor.runtime", "pmv_ros.runtime.monitor.records")
    assert not _inner_violation("pmv_ros.runtime.monitor.runtime", "pmv_ros.runtime.common.assembly")
    assert not _inner_violation("pmv_ros.runtime.flight", "pmv_ros.runtime.tracker.runtime")
    assert _inner_violation("pmv_ros.physics.constants", "pmv_ros.physics.orbit.two_body")
    assert _inner_violation("pmv_ros.physics.chain.fast", "pmv_ros.physics.environment.fields")
    assert not _inner_violation("pmv_ros.physics.instrument.sensor", "pmv_ros.physics.chain")
    assert not _inner_violation("pmv_ros.physics.geometry", "pmv_ros.physics.constants")


#: The simulator each host may import (its root package), and only that host.
HOST_SIMULATORS = {"basilisk": "Basilisk"}

#: What the hosts' siblings and what the hosts themselves must not import.
ROS_ROOTS = ("rclpy", "pmv_msgs_shim", "pmv_ros.nodes")


def _host_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[2] if parts[:2] == ["pmv_ros", "hosts"] and len(parts) > 2 else None


def _crossing_into_hosts(module: str, target: str) -> str | None:
    """Why ``module`` importing ``target`` breaks the hosts' rule, or None: only a host imports its simulator,
    nothing outside the hosts imports one (the core runs without any simulator installed), and a host imports
    no ROS (the ROS host, the nodes, is its sibling)."""
    host, root = _host_of(module), target.split(".")[0]
    simulators = {simulator: name for name, simulator in HOST_SIMULATORS.items()}
    if root in simulators and host != simulators[root]:
        return f"{module} imports {target}: only pmv_ros.hosts.{simulators[root]} imports {root}"
    if host is None and module.split(".")[0] in ("pmv_ros", "pmv_msgs_shim") and (
            target == "pmv_ros.hosts" or target.startswith("pmv_ros.hosts.")):
        return f"{module} imports {target}: nothing outside the hosts imports a host (and so its simulator)"
    if host is not None and any(target == name or target.startswith(name + ".") for name in ROS_ROOTS):
        return f"{module} imports {target}: a host runs without ROS"
    return None


def test_only_the_basilisk_host_imports_basilisk_and_hosts_import_no_ros():
    wrong = []
    for path in sorted([*PACKAGE.rglob("*.py"), *SHIM.rglob("*.py")]):
        module = _module(path)
        wrong += [problem for target in _imports(path) if (problem := _crossing_into_hosts(module, target))]
    assert not wrong, "\n".join(wrong)
    assert (PACKAGE / "hosts" / "basilisk" / "sensor.py").exists()  # the rule has a host to keep apart


def test_the_hosts_check_sees_a_crossing():
    assert _crossing_into_hosts("pmv_ros.runtime.flight", "Basilisk.architecture.messaging")
    assert _crossing_into_hosts("pmv_ros.apps.report", "pmv_ros.hosts.basilisk.sensor")
    assert _crossing_into_hosts("pmv_ros.nodes.base", "pmv_ros.hosts")
    assert _crossing_into_hosts("pmv_ros.hosts.basilisk.sensor", "pmv_ros.nodes.params")
    assert _crossing_into_hosts("pmv_ros.hosts.basilisk.nav", "rclpy.node")
    assert _crossing_into_hosts("pmv_ros.hosts.other.sensor", "Basilisk")
    assert not _crossing_into_hosts("pmv_ros.hosts.basilisk.sensor", "Basilisk.architecture.sysModel")
    assert not _crossing_into_hosts("pmv_ros.hosts.basilisk.sensor", "pmv_ros.runtime.sensor.runtime")
    assert not _crossing_into_hosts("pmv_ros.hosts.basilisk", "pmv_ros.hosts.basilisk.frames")
