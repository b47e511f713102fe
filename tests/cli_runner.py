"""``pmv`` in-process through ``main(argv)``: exit status, stdout and stderr as a child process would give them."""

from __future__ import annotations

import contextlib
import io
import subprocess

from pmv_ros.cli import main


def pmv(*args) -> subprocess.CompletedProcess:
    """Run ``pmv ARGS`` in this process; argparse's exits become the return code."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in args])
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
    return subprocess.CompletedProcess(["pmv", *map(str, args)], code, out.getvalue(), err.getvalue())
