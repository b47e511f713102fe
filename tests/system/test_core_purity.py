"""The ROS-free layers import with rclpy and every message package unavailable (style.md)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

pytestmark = [pytest.mark.multi_process]


def test_core_imports_without_ros():
    script = textwrap.dedent("""
        import importlib, pkgutil, sys

        class NoRos:
            def find_spec(self, name, path=None, target=None):
                root = name.split(".")[0]
                if root in ("rclpy", "rosidl_runtime_py", "builtin_interfaces") or root.endswith("_msgs"):
                    raise ImportError(f"blocked for this test: {name}")
                return None

        sys.meta_path.insert(0, NoRos())
        names = []
        for layer in ("physics", "analysis", "runtime", "storage", "apps"):
            package = importlib.import_module("pmv_ros." + layer)
            names += [m.name for m in pkgutil.walk_packages(package.__path__, package.__name__ + ".")]
        for name in names:
            importlib.import_module(name)
        try:
            import rclpy  # noqa: F401
        except ImportError:
            print("blocked-ok", len(names))
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "blocked-ok" in result.stdout
    assert int(result.stdout.split()[-1]) >= 60  # every module of the five layers, subpackages included
