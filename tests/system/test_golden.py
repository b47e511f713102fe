"""No behaviour change across code moves: today's ``pmv`` outputs against the captured golden ones.

``tests/data/golden.json`` was captured with ``python tools/golden.py capture``
on main at 89715af, before the layout move, and re-captured only where a
change said so in its commit message; every number must agree to 1e-9′
(tools/golden.py says why). A deliberate change of a figure re-captures the
file in the same commit, and the commit message says which figures moved.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _golden_tool():
    spec = importlib.util.spec_from_file_location("pmv_golden_tool", REPO / "tools" / "golden.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cli_outputs_equal_the_golden_capture(tmp_path):
    golden = _golden_tool()
    expected = json.loads(golden.GOLDEN_PATH.read_text())
    actual = golden.run_all(tmp_path)
    assert set(actual) == set(expected)
    lines = golden.differences(expected, actual)
    assert not lines, "\n".join(lines[:40])


def test_the_comparison_sees_a_change_beyond_the_tolerance():
    golden = _golden_tool()
    expected = {"a": {"sigma_arcmin": 4.0, "rows": [1.0, 2.0]}, "label": "x"}
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0 + 5e-10, "rows": [1.0, 2.0]}, "label": "x"}) == []
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0 + 2e-9, "rows": [1.0, 2.0]}, "label": "x"})
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0, "rows": [1.0]}, "label": "x"})
    assert golden.differences(expected, {"a": {"sigma_arcmin": 4.0, "rows": [1.0, 2.0]}, "label": "y"})
    assert golden.differences(expected, {"a": {"rows": [1.0, 2.0]}, "label": "x"})
