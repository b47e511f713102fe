"""Child process of the recording tests: ``pmv`` with a count of the messages handed to the recording.

Runs ``pmv_ros.cli.main`` on the arguments given; every 100th message
handed to :meth:`McapRecording.write` (after it returned) writes the running
count as one line to the file descriptor named by ``PMV_COUNT_FD``, unbuffered, so a parent that kills
this process knows how many messages had been written to the recording
before the kill — to within 100. The recording's finalisation is announced (and with
``PMV_CLOSE_PAUSE_S`` held open: below).
"""

from __future__ import annotations

import os
import sys
import time

from pmv_ros.storage import recording

COUNT_EVERY = 100
_COUNT_FD = int(os.environ["PMV_COUNT_FD"])

_write = recording.McapRecording.write


def _counted(self, topic, log_time_ns, data):
    _write(self, topic, log_time_ns, data)
    written = sum(self.counts.values())
    if written % COUNT_EVERY == 0:
        os.write(_COUNT_FD, f"{written}\n".encode())


recording.McapRecording.write = _counted

#: The finalisation of the recording (its summary and footer) is announced on the count pipe as
#: ``closing N`` (N messages in it) and ``closed`` after it; with ``PMV_CLOSE_PAUSE_S`` it is held open this
#: long, so that the parent can send a signal or kill -9 while the recording is being finalised.
_CLOSE_PAUSE_S = float(os.environ.get("PMV_CLOSE_PAUSE_S", "0") or 0)
_close = recording.McapRecording.close


def _announced_close(self):
    if not self._closed:
        os.write(_COUNT_FD, f"closing {sum(self.counts.values())}\n".encode())
        if _CLOSE_PAUSE_S > 0:
            time.sleep(_CLOSE_PAUSE_S)
    _close(self)
    os.write(_COUNT_FD, b"closed\n")


recording.McapRecording.close = _announced_close

if __name__ == "__main__":
    from pmv_ros.cli import main

    sys.exit(main(sys.argv[1:]))
