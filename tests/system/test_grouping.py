"""The suite's groups follow the test modules' own marks, and a module that forgets its mark fails.

tests/conftest.py checks two things on every run: a test that uses a session fixture running one long command
(``SESSION_RUNS``) must be in that fixture's ``xdist_group``, at collection; a test that starts a process must be
in a module marked ``multi_process``, at its tear-down. Here both checks run on small test modules in a child
``pytest`` with this suite's conftest, each once with the mark forgotten (it must fail, naming the module and
the mark to add) and once with it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.multi_process]

TESTS = Path(__file__).resolve().parents[1]

SESSION_USER = """
import pytest
{mark}
def test_uses_the_orbit(kondor_orbit_run):
    pass
"""

CHILD_STARTER = """
import subprocess, sys
import pytest
{mark}
def test_starts_a_child():
    subprocess.run([sys.executable, "-c", "pass"], check=True)
"""


def run_suite(tmp_path: Path, name: str, text: str, *arguments) -> subprocess.CompletedProcess:
    """``pytest`` in a child over one module ``name`` laid out as a test module of this suite, with its conftest."""
    (tmp_path / "tests").mkdir(exist_ok=True)
    shutil.copy(TESTS / "conftest.py", tmp_path / "tests" / "conftest.py")
    (tmp_path / "tests" / name).write_text(text)
    env = {key: value for key, value in os.environ.items() if not key.startswith("PMV_ROS_TEST_")}  # a run of its own
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                           *arguments, f"tests/{name}"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)


def test_a_session_fixture_user_outside_its_group_fails_the_collection(tmp_path):
    forgotten = run_suite(tmp_path, "test_renamed.py", SESSION_USER.format(mark=""), "--collect-only")
    assert forgotten.returncode != 0
    assert ("tests/test_renamed.py uses a session fixture of group 'kondor_orbit_run'" in forgotten.stderr
            and "add pytest.mark.xdist_group('kondor_orbit_run')" in forgotten.stderr), forgotten.stderr
    marked = run_suite(tmp_path, "test_renamed.py", SESSION_USER.format(
        mark='pytestmark = pytest.mark.xdist_group("kondor_orbit_run")'), "--collect-only")
    assert marked.returncode == 0, marked.stdout + marked.stderr
    assert "1 test collected" in marked.stdout


def test_a_test_that_starts_a_process_in_an_unmarked_module_fails(tmp_path):
    forgotten = run_suite(tmp_path, "test_child.py", CHILD_STARTER.format(mark=""))
    assert forgotten.returncode == 1
    assert ("ERROR at teardown of test_starts_a_child" in forgotten.stdout
            and "tests/test_child.py is not marked multi_process" in forgotten.stdout), forgotten.stdout
    marked = run_suite(tmp_path, "test_child.py", CHILD_STARTER.format(mark="pytestmark = pytest.mark.multi_process"))
    assert marked.returncode == 0, marked.stdout + marked.stderr
    assert "1 passed" in marked.stdout
