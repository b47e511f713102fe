"""Poisoned files and closed pipes (issue 23): every refusal is one line, fast, in bounded memory.

Every file the package reads is attacked the way a clumsy user or a hostile
neighbour would: a "billion laughs" YAML (nested aliases: 1 kB that expands
to gigabytes), nesting 100,000 levels deep, a FIFO (blocks a reader
forever), ``/dev/zero`` (never ends), a sparse 1 GB file, non-UTF-8 bytes; an
MCAP file whose one zstd chunk expands to 2 GB (declared honestly, and
declared as 1 MiB); a rosbag2 directory whose storage file is a FIFO; a CSV
with a 200,000-character field, with 2 million rows, with ``u_deg = 1e300``
or an orbit number of 2e300; a ``campaign.json`` that is ``/dev/zero``, a
FIFO or JSON nested 200,000 deep.

The ``pmv`` cases run one after another in one child process
(``cli_cases.py``), whose peak resident memory after each case bounds the
case: each must refuse with one line on stderr naming the file, status 2,
within 10 s, with the process's peak at most 300 MB. The node cases run as
the node executables (status 1, one line). Measured figures are printed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bounded_run import node, run_measured

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]

#: The bounds of the issue: peak memory of the refusing process, time to refuse.
PEAK_MB, REFUSAL_S = 300.0, 10.0

#: What the zstd chunk of the MCAP bombs really expands to: 2 GB with --run-long (as in the issue); in the short
#: run 128 MiB, twice the chunk cap (the reader decompresses at most the declared size + 1 byte either way).
BOMB_BYTES, LONG_BOMB_BYTES = 128 << 20, 2 << 30

ANALYZE = ["--altitude-km", "500", "--inclination-deg", "74.5"]
CAMPAIGN = ["--days", "1", "--seeds", "1", "--orbits-per-task", "0.01", "--workers", "1", "--quiet"]

BILLION_LAUGHS = "\n".join(
    ["a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    + [f"{name}: &{name} [{', '.join(['*' + previous] * 9)}]"
       for previous, name in zip("abcdefgh", "bcdefghi")]) + "\n"


def _zstd_bomb(uncompressed: int) -> bytes:
    """A zstd frame of ``uncompressed`` zero bytes, streamed (no content size in the frame header)."""
    import zstandard

    compressor = zstandard.ZstdCompressor(level=3).compressobj()
    block = bytes(16 << 20)
    parts = [compressor.compress(block) for _ in range(uncompressed // len(block))]
    parts.append(compressor.flush())
    return b"".join(parts)


def _mcap_with_chunk(path: Path, data: bytes, declared: int) -> Path:
    """A complete MCAP file (footer and all) whose one chunk is ``data`` declaring ``declared`` bytes."""
    from mcap.data_stream import RecordBuilder
    from mcap.records import Chunk, DataEnd, Footer, Header
    from mcap.writer import MCAP0_MAGIC

    builder = RecordBuilder()
    Header(profile="ros2", library="bomb").write(builder)
    Chunk(compression="zstd", data=data, message_start_time=0, message_end_time=0, uncompressed_crc=0,
          uncompressed_size=declared).write(builder)
    DataEnd(data_section_crc=0).write(builder)
    Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(builder)
    path.write_bytes(MCAP0_MAGIC + builder.end() + MCAP0_MAGIC)
    return path


def _files(folder: Path, bomb_bytes: int) -> dict:
    """Every poisoned file, by name."""
    folder.mkdir(parents=True, exist_ok=True)
    made = {}

    def text(name, content, encoding="utf-8"):
        path = folder / name
        path.write_bytes(content if isinstance(content, bytes) else content.encode(encoding))
        made[name] = path

    def fifo(name):
        path = folder / name
        os.mkfifo(path)
        made[name] = path

    text("laughs.yaml", BILLION_LAUGHS)
    text("deep.yaml", "a: " + "[" * 100_000 + "]" * 100_000 + "\n")
    fifo("fifo.yaml")
    text("latin1.yaml", b"sensor_node:\n  ros__parameters:\n    sim.epoch_utc: \"caf\xe9\"\n")
    huge = folder / "huge.yaml"
    with open(huge, "wb") as stream:
        stream.truncate(1 << 30)  # sparse: 1 GB that takes no disk
    made["huge.yaml"] = huge
    zero = folder / "zero.yaml"
    zero.symlink_to("/dev/zero")
    made["zero.yaml"] = zero
    fifo("fifo.csv")
    bomb = _zstd_bomb(bomb_bytes)
    made["honest_bomb.mcap"] = _mcap_with_chunk(folder / "honest_bomb.mcap", bomb, 2 << 30)
    made["lying_bomb.mcap"] = _mcap_with_chunk(folder / "lying_bomb.mcap", bomb, 1 << 20)
    bag = folder / "fifo_bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n"
                                       "  relative_file_paths: [fifo_bag_0.mcap]\n")
    os.mkfifo(bag / "fifo_bag_0.mcap")
    made["fifo_bag"] = bag
    laughing_bag = folder / "laughing_bag"
    laughing_bag.mkdir()
    (laughing_bag / "metadata.yaml").write_text(BILLION_LAUGHS)
    made["laughing_bag"] = laughing_bag
    header = "orbit,u_deg,roll_arcmin,pitch_arcmin\n"
    text("long_field.csv", header + "1,0," + "9" * 200_000 + ",0\n")
    rows = folder / "rows.csv"
    with open(rows, "w") as stream:
        stream.write(header)
        line = "1,90.0,0.25,-0.5\n"
        for _ in range(20):
            stream.write(line * 100_000)
    made["rows.csv"] = rows
    text("u_deg.csv", header + "1,0,0,0\n1,1e300,0,0\n")
    text("orbit.csv", header + "1,0,0,0\n2e300,15,0,0\n")
    for name, build in (("zero", lambda p: p.symlink_to("/dev/zero")), ("fifo", os.mkfifo),
                        ("deep", lambda p: p.write_text("[" * 200_000 + "]" * 200_000))):
        out = folder / f"campaign_{name}"
        out.mkdir()
        build(out / "campaign.json")
        made[f"campaign_{name}"] = out
    return made


def _cases(files: dict, tmp: Path) -> dict:
    """Case name → (pmv arguments, the file the line must name, a phrase the reason must have)."""
    config = REPO / "config" / "meteor_m2.yaml"
    cases = {}
    for name, phrase in (("laughs.yaml", "aliases"), ("deep.yaml", "nested deeper"), ("fifo.yaml", "FIFO"),
                         ("latin1.yaml", "not UTF-8"), ("huge.yaml", "more than the"),
                         ("zero.yaml", "a device")):
        path = files[name]
        cases[f"simulate_{name}"] = (["simulate", "--config", path, "--orbits", "0.001", "--quiet"], path, phrase)
        cases[f"campaign_{name}"] = (["campaign", "--config", path, *CAMPAIGN, "--out", tmp / f"out_{name}"],
                                     path, phrase)
    for name, phrase in (("fifo.csv", "FIFO"), ("honest_bomb.mcap", "declares 2147483648 bytes"),
                         ("lying_bomb.mcap", "beyond the 1048576 bytes it declares"), ("fifo_bag", "FIFO"),
                         ("laughing_bag", "aliases"), ("long_field.csv", "longer than"),
                         ("rows.csv", "more than 500000 data rows"), ("u_deg.csv", "column 'u_deg'"),
                         ("orbit.csv", "column 'orbit'")):
        cases[f"analyze_{name}"] = (["analyze", files[name], *ANALYZE], files[name], phrase)
    cases["analyze_dev_zero"] = (["analyze", "/dev/zero", *ANALYZE], "/dev/zero", "a device")
    for name, phrase in (("zero", "a device"), ("fifo", "FIFO"), ("deep", "nested deeper")):
        out = files[f"campaign_{name}"]
        cases[f"campaign_json_{name}"] = (["campaign", "--config", config, *CAMPAIGN, "--out", out],
                                          out / "campaign.json", phrase)
    return cases


@pytest.fixture(scope="module")
def refusals(tmp_path_factory, pytestconfig):
    """Every ``pmv`` case run in one child: name → (result dict, expected file, expected phrase)."""
    tmp = tmp_path_factory.mktemp("hostile")
    files = _files(tmp / "files", LONG_BOMB_BYTES if pytestconfig.getoption("--run-long") else BOMB_BYTES)
    cases = _cases(files, tmp)
    listing = tmp / "cases.json"
    listing.write_text(json.dumps({name: [str(a) for a in argv] for name, (argv, _, _) in cases.items()}))
    result = subprocess.run([sys.executable, str(HERE / "cli_cases.py"), str(listing)], capture_output=True,
                            text=True, timeout=900, cwd=tmp)
    assert result.returncode == 0, result.stderr[-3000:]
    outcomes = {line["name"]: line for line in map(json.loads, result.stdout.splitlines())}
    for name, outcome in outcomes.items():
        print(f"{name}: status {outcome['status']}, {outcome['wall_s']:.2f} s ({outcome['cpu_s']:.2f} s CPU), "
              f"peak so far "
              f"{outcome['peak_mb']:.0f} MB: {outcome['stderr'].strip()}")
    return {name: (outcomes.get(name), str(path), phrase) for name, (_, path, phrase) in cases.items()}


CASE_NAMES = sorted(_cases({name: Path(name) for name in (
    "laughs.yaml", "deep.yaml", "fifo.yaml", "latin1.yaml", "huge.yaml", "zero.yaml", "fifo.csv",
    "honest_bomb.mcap", "lying_bomb.mcap", "fifo_bag", "laughing_bag", "long_field.csv", "rows.csv",
    "u_deg.csv", "orbit.csv", "campaign_zero", "campaign_fifo", "campaign_deep")}, Path(".")))


@pytest.mark.parametrize("case", CASE_NAMES)
def test_a_poisoned_file_is_one_line_exit_2_fast_and_small(refusals, case):
    outcome, path, phrase = refusals[case]
    assert outcome is not None, f"{case} did not run"
    assert outcome["status"] == 2, outcome
    assert outcome["stdout"] == "" and "Traceback" not in outcome["stderr"], outcome
    lines = outcome["stderr"].strip().splitlines()
    assert len(lines) == 1, outcome["stderr"]
    assert path in lines[0] and phrase in lines[0], lines[0]
    # The time to refuse is the work the command does: its CPU time (its wall time on a loaded 2-core machine
    # took 10.45 s once for ≈ 2 s of CPU); a hang ends at cli_cases.CASE_LIMIT_S as "timeout", not status 2.
    assert outcome["cpu_s"] < REFUSAL_S, outcome
    assert outcome["peak_mb"] <= PEAK_MB, outcome


@pytest.fixture(scope="module")
def node_files(tmp_path_factory):
    """The poisoned params files for the node executables, a log folder, and the runs made so far."""
    tmp = tmp_path_factory.mktemp("hostile_nodes")
    files = {"laughs.yaml": tmp / "laughs.yaml", "deep.yaml": tmp / "deep.yaml", "fifo.yaml": tmp / "fifo.yaml",
             "latin1.yaml": tmp / "latin1.yaml", "missing.yaml": tmp / "missing.yaml"}
    files["laughs.yaml"].write_text(BILLION_LAUGHS)
    files["deep.yaml"].write_text("a: " + "[" * 100_000 + "]" * 100_000 + "\n")
    os.mkfifo(files["fifo.yaml"])
    files["latin1.yaml"].write_bytes(b"sensor_node:\n  ros__parameters:\n    sim.epoch_utc: \"caf\xe9\"\n")
    return files, dict(os.environ, ROS_LOG_DIR=str(tmp / "log")), {}


def _node_run(node_files, executable: str, name: str):
    files, env, done = node_files
    if (executable, name) not in done:
        done[(executable, name)] = run_measured([*node(executable), "--ros-args", "--params-file", files[name]],
                                                timeout_s=120, env=env)
        run = done[(executable, name)]
        print(f"{executable} {name}: status {run.status}, {run.wall_s:.2f} s, peak {run.peak_mb:.0f} MB: "
              f"{run.stderr.strip()}")
    return done[(executable, name)]


#: The node cases in the short run (the refusal is one function, shared by the nodes): all with --run-long.
SHORT_NODE_CASES = {("sensor_node", "laughs.yaml"), ("sensor_node", "fifo.yaml"), ("error_monitor_node", "latin1.yaml")}


@pytest.mark.parametrize("executable", ["sensor_node", "error_monitor_node", "star_tracker_node"])
@pytest.mark.parametrize("name, phrase", [("laughs.yaml", "aliases"), ("deep.yaml", "nested deeper"),
                                          ("fifo.yaml", "FIFO"), ("latin1.yaml", "not UTF-8")])
def test_a_node_refuses_a_poisoned_params_file_before_rclpy_reads_it(node_files, run_long, executable, name,
                                                                     phrase):
    """One line, status 1, as fast as the same start on a missing file (+ 10 s), peak ≤ 300 MB.

    The time of a node's refusal is mostly the interpreter and its imports
    (seconds on a loaded 2-core machine), so the bound is on what the file
    adds: the wall time beyond the same executable refusing a missing file.
    """
    if (executable, name) not in SHORT_NODE_CASES and not run_long:
        pytest.skip("the other node and file pairs run with --run-long")
    files = node_files[0]
    run = _node_run(node_files, executable, name)
    assert run.status == 1, run
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    assert lines[0].startswith(f"{executable}: cannot start: ") and str(files[name]) in lines[0] and phrase in lines[0]
    baseline = _node_run(node_files, "sensor_node", "missing.yaml")  # the nodes import the same modules
    assert baseline.status == 1 and "missing.yaml" in baseline.stderr, baseline
    assert run.wall_s - baseline.wall_s < REFUSAL_S and run.peak_mb <= PEAK_MB, (run, baseline.wall_s)


@pytest.mark.parametrize("argv", [
    ["oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--step-deg", "0.01", "--json"],
    ["oblateness", "--altitude-km", "500", "--inclination-deg", "74.5", "--step-deg", "0.01"],
])
def test_output_into_a_closed_pipe_ends_quietly(argv):
    """``pmv … | head -c 10``: the reader goes away; the command ends with 141 (or 0), nothing on stderr."""
    process = subprocess.Popen([sys.executable, "-m", "pmv_ros.cli", *argv], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE)
    assert len(process.stdout.read(10)) == 10
    process.stdout.close()
    _, stderr = process.communicate(timeout=60)
    assert process.returncode in (0, 141), stderr
    assert stderr == b"", stderr.decode()
