"""Recordings survive the end of the process (issue 23): signals, kill -9, a full disk.

``pmv simulate --record`` runs as a child (``record_child.py``: the real
command, which also reports on a pipe how many messages it had handed to the
recording, every 100th). Then:

* SIGINT or SIGTERM: the run stops between two ticks, the MCAP file is
  closed whole (footer and summary: ``scan_mcap`` says complete, and it holds
  every message handed to it), one line says so, status 130 / 143; the
  recording's close begins within seconds of the signal (ms on a quiet machine);
* ``kill -9``: ``pmv analyze`` reads the file without its footer and says how
  much it recovered; the messages recovered are at least 95 % of those
  handed to the recording before the kill (counted to within 100, the
  count taken as its upper end), and they are the same messages, in order,
  as the first ones of the complete run (a run with the same seed);
* a full disk (a file-size limit, ``RLIMIT_FSIZE``, with SIGXFSZ ignored so
  that the write fails as on a full disk): one line, status 2, and the file
  is still analysable.

Short runs by default (the kill after ≈ 12,000 messages); ``--run-long`` waits
for ≈ 30,000.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pmv_ros.storage.recording import iter_recording, scan_mcap

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
KONDOR = REPO / "config" / "kondor.yaml"
ANALYZE = ["--altitude-km", "500", "--inclination-deg", "74.5"]
TOPICS = {"/pmv/attitude": ("geometry_msgs/msg/Vector3Stamped",),
          "/star_tracker/attitude": ("geometry_msgs/msg/QuaternionStamped",)}


#: Every Recorder made, so that the fixture below can end those a failed test left running (a 2-orbit run
#: goes on for minutes on its own otherwise).
_MADE: list = []


@pytest.fixture(autouse=True)
def _no_recorder_outlives_its_test():
    yield
    while _MADE:
        recorder = _MADE.pop()
        if recorder.process.poll() is None:
            recorder.process.kill()
            recorder.process.wait()


class Recorder:
    """``pmv simulate --record`` as a child, with the count of messages it has written."""

    def __init__(self, path: Path, tmp: Path, *extra, preexec=None, env=None, orbits: float = 2):
        reader, writer = os.pipe()
        self.process = subprocess.Popen(
            [sys.executable, str(HERE / "record_child.py"), "simulate", "--config", str(KONDOR), "--orbits",
             str(orbits), "--seed", "11", "--quiet", "--record", str(path), *extra],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, pass_fds=(writer,),
            preexec_fn=preexec, env=dict(env or os.environ, ROS_LOG_DIR=str(tmp / "log"), PMV_COUNT_FD=str(writer)),
            cwd=tmp)
        _MADE.append(self)
        os.close(writer)
        self._reader, self._buffer, self.written = reader, b"", 0
        self.closing = None  # messages in the recording when its finalisation began (PMV_CLOSE_PAUSE_S)

    def poll_count(self, timeout_s: float) -> int:
        ready, _, _ = select.select([self._reader], [], [], timeout_s)
        if ready:
            data = os.read(self._reader, 65536)
            self._buffer += data
            *lines, self._buffer = self._buffer.split(b"\n")
            for line in lines:
                if line.startswith(b"closing"):
                    self.closing = int(line.split()[1])
                elif line.isdigit():
                    self.written = int(line)
        return self.written

    def wait_for_closing(self, timeout_s: float = 300.0) -> int:
        """Until the recording's finalisation has begun (the child holds it open); the messages in it."""
        end = time.monotonic() + timeout_s
        while self.closing is None:
            self.poll_count(0.05)
            assert self.process.poll() is None or self.closing is not None, \
                self.process.communicate()[1].decode()[-2000:]
            assert time.monotonic() < end, "the run did not reach the end of its recording"
        return self.closing

    def wait_for(self, messages: int, timeout_s: float = 300.0) -> None:
        end = time.monotonic() + timeout_s
        while self.poll_count(0.05) < messages:
            assert self.process.poll() is None, self.process.communicate()[1].decode()[-2000:]
            assert time.monotonic() < end, "the run did not write enough messages"

    def finish(self, timeout_s: float = 60.0):
        _, stderr = self.process.communicate(timeout=timeout_s)
        while self.poll_count(0.0) and select.select([self._reader], [], [], 0)[0]:
            if not os.read(self._reader, 65536):
                break
        os.close(self._reader)
        return self.process.returncode, stderr.decode()


def _own_lines(stderr: str) -> list[str]:
    """What the command said (rclpy's [INFO] start-up lines of the nodes left out)."""
    return [line for line in stderr.splitlines() if line.strip() and not line.startswith("[INFO]")]


def test_a_signal_stops_the_run_and_closes_the_recording_whole(tmp_path):
    """SIGINT and SIGTERM, each to its own run (the two run side by side)."""
    runs = {stop: Recorder(tmp_path / f"{stop.name}.mcap", tmp_path) for stop in (signal.SIGINT, signal.SIGTERM)}
    for run in runs.values():
        run.wait_for(2000)
    for stop, run in runs.items():
        sent = time.monotonic()
        run.process.send_signal(stop)
        closing = run.wait_for_closing(timeout_s=60.0)  # the run stopped and began to close the recording
        took_s = time.monotonic() - sent
        status, stderr = run.finish()
        lines = _own_lines(stderr)
        print(f"{stop.name}: status {status}; the recording's close began {took_s:.2f} s after the signal; {lines}")
        assert status == 128 + stop and "Traceback" not in stderr
        assert len(lines) == 1 and f"stopped by {stop.name}" in lines[0] and "recording closed" in lines[0], lines
        scan = scan_mcap(tmp_path / f"{stop.name}.mcap")
        written = int(lines[0].rsplit(", ", 1)[1].split()[0])
        assert scan.complete and scan.messages == written == closing >= 2000, (scan, written, closing)
        # The stop is between two ticks (ms on a quiet machine); timed to the start of the recording's close, not
        # to the interpreter's exit (rclpy's shutdown: seconds on a loaded machine, nothing the run decides).
        assert took_s < 5.0


def test_kill_9_leaves_a_recording_analyze_reads(tmp_path, run_long, capsys):
    from pmv_ros.cli import main

    # Long enough that the last flush interval (0.1 s: up to a few hundred messages at fast time on a quick
    # machine) and the count's granularity (100) are a few per cent of what was written.
    target = 30_000 if run_long else 12_000
    path = tmp_path / "killed.mcap"
    run = Recorder(path, tmp_path)
    reference = tmp_path / "reference.mcap"
    whole = Recorder(reference, tmp_path)  # the same seed, side by side: the messages the killed run must hold
    run.wait_for(target)
    run.process.send_signal(signal.SIGKILL)
    status, _ = run.finish()
    assert status == -signal.SIGKILL
    written_at_most = run.written + 100  # the count is reported every 100 messages
    scan = scan_mcap(path)
    assert not scan.complete
    fraction = scan.messages / written_at_most
    with capsys.disabled():
        print(f"kill -9 after ≥ {run.written} messages: {scan.messages} recovered ({fraction:.1%} of ≤ "
              f"{written_at_most}); {scan.bytes_read} of {scan.file_bytes} bytes readable ({scan.stopped})")
    assert fraction >= 0.95

    # The recovered messages are those of a complete run with the same seed, in the same order.
    whole.wait_for(scan.messages + 200)
    whole.process.send_signal(signal.SIGTERM)
    assert whole.finish()[0] == 128 + signal.SIGTERM
    recovered = [(topic, m.log_time_ns) for topic, m in iter_recording(path, TOPICS)]
    expected = [(topic, m.log_time_ns) for topic, m in iter_recording(reference, TOPICS)][:len(recovered)]
    assert len(recovered) > 100 and recovered == expected

    assert main(["analyze", str(path), *ANALYZE]) == 0
    out = capsys.readouterr().out
    assert f"recovered {scan.messages} messages" in out, out


def test_a_full_disk_is_one_line_and_leaves_a_readable_file(tmp_path, capsys):
    from pmv_ros.cli import main

    path = tmp_path / "full.mcap"
    limit = 150_000  # bytes: the file cannot grow beyond, as on a disk that is full

    def limited():
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write then fails with EFBIG, as ENOSPC would
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path / "log"), FASTDDS_BUILTIN_TRANSPORTS="UDPv4")
    process = subprocess.run([sys.executable, "-m", "pmv_ros.cli", "simulate", "--config", str(KONDOR), "--orbits",
                              "0.3", "--seed", "11", "--quiet", "--record", str(path)], capture_output=True,
                             text=True, preexec_fn=limited, env=env, cwd=tmp_path, timeout=300)
    lines = _own_lines(process.stderr)
    with capsys.disabled():
        print(f"full disk: status {process.returncode}; {lines}")
    assert process.returncode == 2 and "Traceback" not in process.stderr
    assert len(lines) == 1 and str(path) in lines[0] and "cannot write the recording" in lines[0], lines
    scan = scan_mcap(path)
    assert not scan.complete and scan.messages > 0 and path.stat().st_size <= limit
    assert main(["analyze", str(path), *ANALYZE]) == 0
    assert f"recovered {scan.messages} messages" in capsys.readouterr().out


# ---------------------------------------------------------------------- while the recording is being finalised

@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_a_signal_while_the_recording_is_finalised(tmp_path, capsys, stop):
    """The run has done all its ticks and is writing the recording's summary when the signal comes (the child
    holds the finalisation open for a second): SIGINT/SIGTERM let it finish — the file is complete, holds every
    message, and the exit (128 + the signal) and its one line say the run was stopped with the recording closed;
    kill -9 leaves a file without its summary that ``pmv analyze`` reads, every message of it recovered up to the
    last flush."""
    from pmv_ros.cli import main

    path = tmp_path / "finalised.mcap"
    run = Recorder(path, tmp_path, orbits=0.02, env=dict(os.environ, PMV_CLOSE_PAUSE_S="1.0"))
    in_recording = run.wait_for_closing()
    run.process.send_signal(stop)
    status, stderr = run.finish()
    lines = _own_lines(stderr)
    scan = scan_mcap(path)
    with capsys.disabled():
        print(f"{stop.name} while finalising a recording of {in_recording} messages: status {status}; {lines}; "
              f"scan: complete {scan.complete}, {scan.messages} messages")
    assert "Traceback" not in stderr
    if stop == signal.SIGKILL:
        assert status == -signal.SIGKILL
        assert not scan.complete and scan.messages >= 0.95 * in_recording, (scan, in_recording)
        assert main(["analyze", str(path), *ANALYZE]) == 0
        assert f"recovered {scan.messages} messages" in capsys.readouterr().out
        return
    assert status == 128 + stop, (status, stderr)
    assert len(lines) == 1 and f"stopped by {stop.name}" in lines[0] and "recording closed" in lines[0], lines
    assert scan.complete and scan.messages == in_recording, (scan, in_recording)
    assert main(["analyze", str(path), *ANALYZE]) == 0


def _namespaces_allow_a_mount() -> str | None:
    """Why no small filesystem can be made here (None: it can): a tmpfs mounted in a private user and mount
    namespace (``unshare -Urm``), which needs no privilege where the kernel allows user namespaces."""
    import shutil

    if shutil.which("unshare") is None:
        return "no unshare command"
    probe = subprocess.run(["unshare", "-Urm", "sh", "-c", "mount -t tmpfs -o size=4096 tmpfs /mnt"],
                           capture_output=True, text=True, timeout=30)
    return None if probe.returncode == 0 else f"unshare -Urm cannot mount a tmpfs here: {probe.stderr.strip()}"


#: A shell run in the private namespaces: mount a small tmpfs, run the command, copy the recording out (the
#: filesystem goes with the namespace), exit with the command's status.
_ON_SMALL_FS = ('mount -t tmpfs -o size="$1" tmpfs "$2" || exit 97; dir="$2"; out="$3"; shift 3; "$@"; status=$?; '
                'df -k "$dir" | tail -1 >&2; cp "$dir"/*.mcap "$out"/ 2>/dev/null; exit $status')


def test_a_full_small_filesystem_is_one_line_and_leaves_a_readable_file(tmp_path, capsys):
    """A real full disk: a 256 KiB tmpfs the test mounts (ENOSPC, not the file-size limit above)."""
    from pmv_ros.cli import main

    reason = _namespaces_allow_a_mount()
    if reason:
        pytest.skip(f"{reason}: the file-size limit test above stands in for a full disk")
    mount, out = tmp_path / "small", tmp_path / "out"
    mount.mkdir()
    out.mkdir()
    size = 256 * 1024
    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path / "log"))
    process = subprocess.run(["unshare", "-Urm", "sh", "-c", _ON_SMALL_FS, "sh", str(size), str(mount), str(out),
                              sys.executable, "-m", "pmv_ros.cli", "simulate", "--config", str(KONDOR), "--orbits",
                              "0.3", "--seed", "11", "--quiet", "--record", str(mount / "full.mcap")],
                             capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    *said, usage = process.stderr.rstrip("\n").rsplit("\n", 1)
    lines = _own_lines("\n".join(said))
    with capsys.disabled():
        print(f"full tmpfs of {size // 1024} KiB: status {process.returncode}; {lines}; df: {usage.split()[1:5]}")
    assert process.returncode == 2 and "Traceback" not in process.stderr, process.stderr
    assert len(lines) == 1 and "cannot write the recording (No space left on device)" in lines[0], lines
    copy = out / "full.mcap"
    scan = scan_mcap(copy)
    assert not scan.complete and scan.messages > 0 and copy.stat().st_size <= size
    assert main(["analyze", str(copy), *ANALYZE]) == 0
    assert f"recovered {scan.messages} messages" in capsys.readouterr().out
