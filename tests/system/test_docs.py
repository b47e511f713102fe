"""The documentation builds without a warning, and its parameter reference is the nodes' own.

``make docs`` builds ``docs/`` with warnings as errors; these tests run the same build (a few
seconds) and read what it wrote. The parameter reference is generated from
``pmv_ros.runtime.common.assembly.NODE_PARAMS`` at build time, each parameter with a doc line from
``docs/parameter_notes.yaml``: a parameter added without one, or a line left for a parameter that is
gone, fails here (and fails the build). The README stays a first screen: the two set-up commands
verbatim, at most 200 lines, every link into the docs alive.
"""

from __future__ import annotations

import html
import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pmv_ros.runtime.common.assembly import NODE_PARAMS
from pmv_ros.runtime.common.parameters import ParamSpec

pytestmark = pytest.mark.multi_process  # sphinx builds run as child processes

REPO = Path(__file__).resolve().parents[2]
DOCS = REPO / "docs"

#: The README's two commands, verbatim (the first thing a user runs).
SET_UP_COMMANDS = (
    "make demo    # the main job: one Kondor orbit in fast time, live statistics, a report in ./report",
    "make test    # the test suite",
)
README_MAX_LINES = 200


def _extension():
    """docs/_ext/pmv_parameters.py, imported as the docs build imports it."""
    spec = importlib.util.spec_from_file_location("pmv_parameters", DOCS / "_ext" / "pmv_parameters.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _build(source: Path, out: Path) -> subprocess.CompletedProcess:
    """``make docs``'s build of ``source`` into ``out``."""
    return subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-E", "-q", "-b", "html",
                           str(source), str(out)], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """The docs built once for the module, as ``make docs`` builds them."""
    out = tmp_path_factory.mktemp("docs_html")
    result = _build(DOCS, out)
    assert result.returncode == 0, f"the docs build failed:\n{result.stdout}\n{result.stderr}"
    assert result.stderr.strip() == "", f"the docs build warned:\n{result.stderr}"
    return out


def test_every_parameter_has_a_doc_line_and_none_is_stale():
    extension = _extension()
    problems = extension.note_problems(extension.load_notes(DOCS / extension.NOTES_FILE))
    assert problems == [], "\n".join(problems)


def test_the_check_names_a_missing_and_a_stale_doc_line():
    """The check above can fail: a parameter added without a line, a line whose parameter is gone,
    a line never shown."""
    extension = _extension()
    notes = extension.load_notes(DOCS / extension.NOTES_FILE)
    params = {node: tuple(specs) for node, specs in NODE_PARAMS.items()}
    already = set(extension.note_problems(notes, params))  # the test above reports those
    params["error_monitor_node"] += (ParamSpec("brand_new_rate_hz", 1.0, "a new parameter", 0.1, 10.0, unit="Hz"),)
    notes.setdefault("star_tracker_node", {})["gone_parameter_s"] = "a line for a parameter nobody declares"
    notes["/**"]["processing_s"] = "a shared line the star tracker's own line hides"
    problems = [problem for problem in extension.note_problems(notes, params) if problem not in already]
    assert sorted(problems) == sorted([
        "error_monitor_node: parameter brand_new_rate_hz has no doc line in docs/parameter_notes.yaml",
        "docs/parameter_notes.yaml: star_tracker_node: gone_parameter_s is no parameter of star_tracker_node "
        "(stale doc line)",
        "docs/parameter_notes.yaml: /**: processing_s has a line of its own on every node that declares it "
        "(this one is never shown)"])


def _reference_entries(page: Path) -> dict:
    """``{parameter name: its facts line}`` of the generated reference on a built node page."""
    text = page.read_text(encoding="utf-8")
    entries = re.findall(r'<dt><span class="target" id="param-[^"]*"></span><code[^>]*><span class="pre">([^<]+)'
                         r'</span></code></dt><dd><p>(.*?)</p>', text, flags=re.S)
    return {name: html.unescape(re.sub(r"<[^>]+>", "", facts)) for name, facts in entries}


def _yaml(value) -> str:
    """A default as written in a params file (independently of the extension's own rendering)."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml(v) for v in value) + "]"
    return repr(value)


@pytest.mark.parametrize("node", sorted(NODE_PARAMS))
def test_each_node_page_lists_exactly_its_parameters_with_their_defaults(built, node):
    entries = _reference_entries(built / "nodes" / f"{node}.html")
    specs = {spec.name: spec for spec in NODE_PARAMS[node]}
    assert sorted(entries) == sorted(specs)
    for name, spec in specs.items():
        facts = entries[name]
        assert f"default {_yaml(spec.default)}" in facts, (name, facts)
        assert ("read-only" in facts) == spec.read_only, (name, facts)
        if spec.unit:
            assert f"default {_yaml(spec.default)} {spec.unit};" in facts, (name, facts)


def test_a_parameter_named_in_prose_that_no_node_declares_fails_the_build(tmp_path):
    """-W bites: a page that names a parameter that is gone does not build."""
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("_build", "incoming"))
    page = source / "parameters.md"
    page.write_text(page.read_text(encoding="utf-8") + "\nSee {param}`sensor.no_such_parameter`.\n", encoding="utf-8")
    result = _build(source, tmp_path / "html")
    assert result.returncode != 0
    assert "sensor.no_such_parameter: no node declares this parameter" in result.stderr


def test_readme_is_a_first_screen():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    lines = text.splitlines()
    assert len(lines) <= README_MAX_LINES
    for command in SET_UP_COMMANDS:
        assert command in lines
    links = re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text)
    assert any(link.startswith("docs/") for link in links)
    missing = [link for link in links if not (REPO / link).exists()]
    assert missing == []
