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


def test_the_check_sees_an_upward_import(tmp_path):
    assert _rank("pmv_ros.cli.common") > _rank("pmv_ros.apps.campaign") > _rank("pmv_ros.runtime.monitor")
    assert _rank("pmv_ros.physics.sensor") < SHIM_RANK < _rank("pmv_ros.nodes.base")
    assert _rank("numpy") is None
    assert _rank(_module(SHIM / "records.py")) == SHIM_RANK
