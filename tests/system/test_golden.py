"""No behaviour change across code moves: today's ``pmv`` outputs against the captured golden ones.

``tests/data/golden.json`` is captured with ``python tools/golden.py capture``
and re-captured only where a change says so in its commit message; every number must agree to 1e-9′
(tools/golden.py says why). A deliberate change of a figure re-captures the
file in the same commit, and the commit message says which figures moved.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.multi_process]

REPO = Path(__file__).resolve().parents[2]


def _golden_tool():
    spec = importlib.util.spec_from_file_location("pmv_golden_tool", REPO / "tools" / "golden.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cli_outputs_equal_the_golden_capture(tmp_path):
    """``tools/golden.py compare`` in a child process, with numpy's and OpenBLAS's kernels pinned (the tool says
    why: an AVX-512 CPU moves the figures by ≈ 1e-7′ otherwise)."""
    golden = _golden_tool()
    pinned = golden.PINNED_NUMERICS if golden.avx2_machine() else {}
    env = {**os.environ, **pinned, "ROS_LOG_DIR": str(tmp_path / "ros_log"),
           "ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}
    result = subprocess.run([sys.executable, str(REPO / "tools" / "golden.py"), "compare"], env=env,
                            capture_output=True, text=True, timeout=900)
    summary = result.stdout.strip().splitlines()
    assert result.returncode == 0, "\n".join(summary[-40:]) + result.stderr[-2000:]
    assert summary[-1] == f"{len(json.loads(golden.GOLDEN_PATH.read_text()))} outputs, 0 differences beyond 1e-09′"


def test_the_comparison_sees_a_change_beyond_the_tolerance():
    golden = _golden_tool()
    expected = {"a": {"sigma_arcmin": 4.0, "rows": [1.0, 2.0]}, "label": "x"}
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0 + 5e-10, "rows": [1.0, 2.0]}, "label": "x"}) == []
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0 + 2e-9, "rows": [1.0, 2.0]}, "label": "x"})
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0, "rows": [1.0]}, "label": "x"})
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0, "rows": [1.0, 2.0]}, "label": "y"})
    assert golden.differences(expected, {"a": {"rows": [1.0, 2.0]}, "label": "x"})
