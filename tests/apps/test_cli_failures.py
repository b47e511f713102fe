"""How ``pmv`` ends on a failure: one line and status 2 for what a command can expect to meet, a traceback for a bug.

The line drawn (pmv_ros.cli): a refused input or setting (ValueError, decode errors among them), what the system
refused (OSError: a file, a disk, a peer, a timeout) and a bound that did not hold (MemoryError, RecursionError)
are one line on stderr, status 2; Ctrl-C is one line and 130. Any other exception is a bug of ours and keeps
its traceback (status 1): nothing is swallowed into a line that would hide it. Before, only ValueError was a
line: a full disk, a missing folder or an allocation that failed was a traceback.
"""

from __future__ import annotations

import errno
import subprocess
import sys
from pathlib import Path

import pytest

from pmv_ros.cli import MAX_LINE_CHARS, main
from pmv_ros.cli import oblateness

pytestmark = pytest.mark.multi_process  # its child-process cases start `pmv`

OBLATENESS = ["oblateness", "--altitude-km", "500", "--inclination-deg", "74.5"]
REPO = Path(__file__).resolve().parents[2]


def _raising(error):
    def run(args):
        raise error
    return run


@pytest.mark.parametrize("error, phrase", [
    (OSError(errno.ENOSPC, "No space left on device", "/data/budget.json"),
     "/data/budget.json: No space left on device"),
    (FileExistsError(errno.EEXIST, "File exists", ".out.tmp", None, "out"), ".out.tmp -> out: File exists"),
    (ConnectionRefusedError(errno.ECONNREFUSED, "Connection refused"), "Connection refused"),
    (TimeoutError("Timed out trying to connect to tcp://10.0.0.1:8786 after 10 s"), "Timed out trying to connect"),
    (UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte"), "can't decode byte 0xff"),
    (MemoryError(), "out of memory: a bound of this command did not hold"),
    (RecursionError("maximum recursion depth exceeded"), "nested too deeply"),
    (ValueError("a reason\nsplit over lines"), "a reason split over lines"),
])
def test_an_expected_failure_is_one_line_and_status_2(monkeypatch, capsys, error, phrase):
    monkeypatch.setattr(oblateness, "run", _raising(error))
    assert main(OBLATENESS) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith("pmv oblateness: error: "), captured.err
    assert phrase in captured.err, captured.err


def test_a_very_long_reason_is_cut_to_one_readable_line(monkeypatch, capsys):
    monkeypatch.setattr(oblateness, "run", _raising(ValueError("x" * 100_000)))
    assert main(OBLATENESS) == 2
    line = capsys.readouterr().err
    assert line.count("\n") == 1 and len(line) < MAX_LINE_CHARS + 100 and line.rstrip().endswith("…")


def test_ctrl_c_is_one_line_and_130(monkeypatch, capsys):
    monkeypatch.setattr(oblateness, "run", _raising(KeyboardInterrupt()))
    assert main(OBLATENESS) == 130
    assert capsys.readouterr().err == "pmv oblateness: interrupted\n"


@pytest.mark.parametrize("bug", [TypeError("unsupported operand"), KeyError("channel"), AttributeError("no x"),
                                 AssertionError("invariant")])
def test_a_bug_keeps_its_traceback(monkeypatch, bug):
    monkeypatch.setattr(oblateness, "run", _raising(bug))
    with pytest.raises(type(bug)):
        main(OBLATENESS)


def test_a_bug_in_a_child_is_a_traceback_and_status_1():
    code = ("import sys\nimport pmv_ros.cli.oblateness as o\n"
            "def run(args):\n    return [][1]\n"
            "o.run = run\nfrom pmv_ros.cli import main\nsys.exit(main(sys.argv[1:]))\n")
    result = subprocess.run([sys.executable, "-c", code, *OBLATENESS], capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert "Traceback" in result.stderr and "IndexError: list index out of range" in result.stderr


def test_a_report_folder_that_cannot_be_made_is_one_line(tmp_path):
    """An OSError met for real: ``--report`` under a file (NotADirectoryError; a traceback before)."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    result = subprocess.run([sys.executable, "-m", "pmv_ros.cli", "simulate", "--config",
                             str(REPO / "config" / "kondor.yaml"), "--orbits", "0.001", "--quiet",
                             "--report", str(blocker / "report")], capture_output=True, text=True, timeout=300,
                            cwd=tmp_path)
    lines = [line for line in result.stderr.splitlines() if not line.startswith("[INFO]")]
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr[-3000:]
    assert lines == [f"pmv simulate: error: {blocker / 'report'}: Not a directory"], lines
