"""The flight-test error statistics (physics.md §5, §5.1) of recorded telemetry: what ``pmv analyze`` reports.

Two CSV layouts (interfaces.md), each with a header row:

* ``orbit,u_deg,roll_arcmin,pitch_arcmin`` — the published form: the sensor
  error against the reference at orbital angles u, orbit by orbit;
* ``t_s,roll_rad,pitch_rad[,truth_roll_rad,truth_pitch_rad][,u_deg]`` — a
  recording of the sensor (and the star tracker): the error is sensor − truth,
  or the sensor output itself without truth columns (a nadir-holding
  spacecraft). The orbital angle is the ``u_deg`` column, or
  u(t) = u0 + 2π t / T with ``--u0-deg`` (u at t_s = 0) and T the period of
  the circular orbit. Stamps alone do not say where the orbit was (a
  real-time node's orbit starts at u0 when the node starts, whatever the
  wall clock reads), so a file with neither is refused.

And rosbag2 recordings (a directory, or a bare ``.mcap`` or ``.db3`` file) of
this package or of any stack with the same topics: see :func:`analyze_recording`.

Sign convention (``--convention paper|ros``): the published tables and
telemetry are in the paper convention (the default for CSV), recordings in
the convention their sensor states on ``/diagnostics``, else REP-103 (ros).
Every signed angle of the report is in the input's convention; the
oblateness model is removed in the paper convention it is published in,
through :func:`pmv_ros.physics.conventions.convert`.

Extra columns are ignored; blank lines and lines starting with ``#`` are
skipped; a row with a NaN/Inf cell (a telemetry drop-out) is skipped and
counted. Anything else wrong in the file is a one-line error naming the file,
line and column, exit status 2.
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..physics.constants import ARCMIN_RAD
from ..physics.conventions import PAPER, ROS, convert
from ..physics.ground_error import ground_error
from ..physics.orbit.two_body import CircularOrbit
from ..analysis.flight_test import correct_reference_drift, flight_test_statistics
from ..analysis.statistics import ORBIT_HARMONICS

ORBIT_LAYOUT = ("orbit", "u_deg", "roll_arcmin", "pitch_arcmin")
TIME_LAYOUT = ("t_s", "roll_rad", "pitch_rad")
TRUTH_COLUMNS = ("truth_roll_rad", "truth_pitch_rad")
PHASE_COLUMN = "u_deg"

#: Default u bin of step 2 for the time layout, deg (the orbit layout groups exact u).
DEFAULT_TIME_LAYOUT_BIN_DEG = 1.0


@dataclass(frozen=True)
class Telemetry:
    """Columns of a telemetry CSV as float arrays, with the layout and the rows skipped."""

    path: str
    layout: str
    columns: dict
    rows_skipped: int


def _parse_error(path: str, line: int, message: str) -> ValueError:
    return ValueError(f"{path}, line {line}: {message}")


#: Plausible range of every column a telemetry CSV row may carry (a value outside it is a one-line refusal
#: naming the file, line and column; NaN/Inf are drop-outs, skipped and counted). Angles: the monitor's bound on
#: a sensor sample (:class:`pmv_ros.runtime.common.validation.InputBounds`, 30°: the PMV sees no horizon beyond it);
#: u within one turn either way; orbit numbers and times those of a mission (10⁶ orbits ≈ 190 years in LEO).
def _column_bounds() -> dict:
    from ..runtime.common.validation import InputBounds

    angle_rad = InputBounds().max_abs_angle_rad
    angle_arcmin = angle_rad / ARCMIN_RAD
    return {"orbit": (-1e6, 1e6), "u_deg": (-360.0, 360.0), "t_s": (-1e10, 1e10),
            "roll_arcmin": (-angle_arcmin, angle_arcmin), "pitch_arcmin": (-angle_arcmin, angle_arcmin),
            "roll_rad": (-angle_rad, angle_rad), "pitch_rad": (-angle_rad, angle_rad),
            "truth_roll_rad": (-angle_rad, angle_rad), "truth_pitch_rad": (-angle_rad, angle_rad)}


def read_telemetry(path: str) -> Telemetry:
    """Read a telemetry CSV of either layout; ValueError with file, line and column on any defect.

    Streamed block by block through :func:`pmv_ros.storage.files.iter_csv_blocks`
    (a regular UTF-8 file, bounded line length and row count) into compact
    arrays: memory is ≈ 8 bytes a value, whatever the file holds. Every
    value of a used column is checked against :func:`_column_bounds`.
    """
    from ..storage.files import iter_csv_blocks

    blocks = iter_csv_blocks(path, "telemetry CSV")
    try:
        numbers, rows = next(blocks)
    except StopIteration:
        raise ValueError(f"{path}: empty file, expected a header row {','.join(ORBIT_LAYOUT)} "
                         f"or {','.join(TIME_LAYOUT)}") from None
    header_line, header = numbers[0], [name.strip() for name in rows[0]]
    layout, wanted = _layout(path, header_line, header)
    index = [header.index(name) for name in wanted]
    bounds = _column_bounds()
    parts, skipped = [], 0
    block = (numbers[1:], rows[1:])
    while True:
        numbers, rows = block
        if rows:
            values, dropped = _block_values(path, numbers, rows, len(header), wanted, index, bounds)
            parts.append(values)
            skipped += dropped
        try:
            block = next(blocks)
        except StopIteration:
            break
    columns = np.concatenate(parts, axis=1) if parts else np.empty((len(wanted), 0))
    if not columns.shape[1]:
        raise ValueError(f"{path}: no usable data rows after the header (line {header_line})")
    return Telemetry(path, layout, {name: columns[i] for i, name in enumerate(wanted)}, skipped)


def _block_values(path, numbers, rows, width, wanted, index, bounds):
    """``(values (len(wanted), n), rows skipped)`` of one block of rows; ValueError naming line and column."""
    widths = np.fromiter(map(len, rows), dtype=np.int64, count=len(rows))
    if np.any(widths != width):
        at = int(np.argmax(widths != width))
        raise _parse_error(path, numbers[at], f"{widths[at]} cells, the header has {width}")
    values = np.empty((len(wanted), len(rows)))
    for k, (name, column) in enumerate(zip(wanted, index)):
        cells = [row[column] for row in rows]
        try:
            values[k] = np.array(cells, dtype=float)
        except ValueError:
            for line, text in zip(numbers, cells):
                try:
                    float(text)
                except ValueError:
                    raise ValueError(f"{path}, line {line}, column '{name}': "
                                     f"{text.strip()!r} is not a number") from None
            raise
        low, high = bounds[name]
        with np.errstate(invalid="ignore"):
            outside = np.isfinite(values[k]) & ((values[k] < low) | (values[k] > high))
        if outside.any():
            at = int(np.argmax(outside))
            raise ValueError(f"{path}, line {numbers[at]}, column '{name}': {values[k, at]:g} is outside the "
                             f"allowed range [{low:g}, {high:g}]")
    finite = np.isfinite(values).all(axis=0)  # a NaN/Inf cell: a telemetry drop-out, skipped and counted
    return values[:, finite], int(finite.size - finite.sum())


def _layout(path: str, line: int, header: list[str]) -> tuple[str, tuple[str, ...]]:
    present = set(header)
    if set(ORBIT_LAYOUT) <= present:
        return "orbit", ORBIT_LAYOUT
    if set(TIME_LAYOUT) <= present:
        truth = [name for name in TRUTH_COLUMNS if name in present]
        if len(truth) == 1:
            missing = (set(TRUTH_COLUMNS) - set(truth)).pop()
            raise _parse_error(path, line, f"missing column '{missing}' (it goes with '{truth[0]}')")
        return "time", TIME_LAYOUT + (TRUTH_COLUMNS if truth else ()) + ((PHASE_COLUMN,) if PHASE_COLUMN in present
                                                                          else ())
    # Name the missing columns of the layout the header is closer to.
    closer = max((ORBIT_LAYOUT, TIME_LAYOUT), key=lambda layout: len(present & set(layout)))
    missing = ", ".join(f"'{name}'" for name in closer if name not in present)
    raise _parse_error(path, line, f"missing column {missing}; expected the columns {','.join(ORBIT_LAYOUT)} "
                                   f"or {','.join(TIME_LAYOUT)}[,{','.join(TRUTH_COLUMNS)}]")


def _arcmin(value) -> float:
    return float(value) / ARCMIN_RAD


def analyze_telemetry(telemetry: Telemetry, altitude_m: float, inclination_rad: float, *,
                      u0_rad: float | None = None, u_bin_rad: float | None = None, remove_oblateness: bool = True,
                      roll_drift_rad_per_orbit: float = 0.0, pitch_drift_rad_per_orbit: float = 0.0,
                      convention: str = PAPER) -> dict:
    """Run the flight-test statistics on read telemetry; the report as a dict (arcmin for people).

    ``convention`` is the sign convention of the telemetry's roll and pitch
    (and of the report's signed angles).
    """
    period = CircularOrbit(altitude_m, inclination_rad).period_s
    columns = telemetry.columns
    if telemetry.layout == "orbit":
        u = np.radians(columns["u_deg"])
        roll, pitch = columns["roll_arcmin"] * ARCMIN_RAD, columns["pitch_arcmin"] * ARCMIN_RAD
        orbit_index = columns["orbit"]
        phase_source = "u_deg column"
    else:
        if PHASE_COLUMN in columns:
            u, phase_source = np.radians(columns[PHASE_COLUMN]), "u_deg column"
        elif u0_rad is not None:
            u, phase_source = u0_rad + 2.0 * math.pi * columns["t_s"] / period, "t_s with --u0-deg"
        else:
            raise ValueError("the column 't_s' gives times but nothing gives the orbital phase: add a 'u_deg' "
                             "column (argument of latitude from the ascending node) or give --u0-deg (u at "
                             "t_s = 0) — stamps alone do not say where the orbit was")
        roll, pitch = columns["roll_rad"], columns["pitch_rad"]
        if "truth_roll_rad" in columns:
            roll, pitch = roll - columns["truth_roll_rad"], pitch - columns["truth_pitch_rad"]
        orbit_index = None
        if u_bin_rad is None:
            u_bin_rad = math.radians(DEFAULT_TIME_LAYOUT_BIN_DEG)
    report = _flight_test_report(u, roll, pitch, altitude_m, inclination_rad, convention, orbit_index=orbit_index,
                                 u_bin_rad=u_bin_rad, remove_oblateness=remove_oblateness,
                                 roll_drift_rad_per_orbit=roll_drift_rad_per_orbit,
                                 pitch_drift_rad_per_orbit=pitch_drift_rad_per_orbit)
    return {"file": telemetry.path, "layout": telemetry.layout, "rows_skipped": telemetry.rows_skipped,
            "phase_source": phase_source, **report}


def _flight_test_report(u, roll, pitch, altitude_m: float, inclination_rad: float, convention: str, *,
                        orbit_index=None, u_bin_rad=None, remove_oblateness=True, roll_drift_rad_per_orbit=0.0,
                        pitch_drift_rad_per_orbit=0.0) -> dict:
    """§5 steps 1–5 and §5.1 on sensor errors (rad) at orbital angles u, in ``convention``; the report dict."""
    period = CircularOrbit(altitude_m, inclination_rad).period_s
    # The core's statistics speak REP-103 (the oblateness model too): the procedure runs there, the report goes back.
    roll, pitch = convert(np.asarray(roll, float), np.asarray(pitch, float), convention, ROS)
    # Step 1: the reference is taken as reset at each ascending node (drifts given in the input's convention).
    roll_drift, pitch_drift = convert(roll_drift_rad_per_orbit, pitch_drift_rad_per_orbit, convention, ROS)
    elapsed_s = np.mod(u, 2.0 * math.pi) / (2.0 * math.pi) * period
    roll = correct_reference_drift(roll, elapsed_s, roll_drift / period)
    pitch = correct_reference_drift(pitch, elapsed_s, pitch_drift / period)
    result = flight_test_statistics(u, roll, pitch, altitude_m, inclination_rad, orbit_index=orbit_index,
                                    remove_oblateness=remove_oblateness, u_bin_rad=u_bin_rad)

    def signed(roll_value, pitch_value):
        """A (roll, pitch) pair back in the input's convention, arcmin."""
        r, p = convert(roll_value, pitch_value, ROS, convention)
        return _arcmin(r), _arcmin(p)

    channels = {}
    for channel in result.channels:
        sign = 1.0 if channel.channel == "meridional" else convert(1.0, 1.0, ROS, convention)[0]
        detail = {
            "count": channel.count, "mean_arcmin": sign * _arcmin(channel.mean_rad),
            "sigma_arcmin": _arcmin(channel.sigma_rad), "three_sigma_arcmin": _arcmin(channel.three_sigma_rad),
            "max_abs_arcmin": _arcmin(channel.max_abs_rad),
            "harmonics_arcmin": {str(k): _arcmin(a) for k, a in channel.harmonics_rad.items()},
            "harmonics_with_oblateness_arcmin": {str(k): _arcmin(a)
                                                 for k, a in channel.harmonics_with_oblateness_rad.items()},
            "orbits_in_harmonics": channel.orbits_in_harmonics,
        }
        if channel.channel != "meridional":
            detail = {"offset_arcmin": sign * _arcmin(channel.offset_rad), **detail}
        channels[channel.channel] = detail
    # One row per distinct orbital angle, built from whole columns (a Python step per value would be the
    # slowest part of a large file).
    columns = [np.degrees(result.u_rad), result.samples_per_u.astype(np.int64)]
    for r, p in ((result.roll_mean_rad, result.pitch_mean_rad),
                 (result.oblateness_roll_rad, result.oblateness_pitch_rad),
                 (result.roll_residual_rad, result.pitch_residual_rad)):
        columns += convert(r / ARCMIN_RAD, p / ARCMIN_RAD, ROS, convention)
    columns.append(result.meridional_rad / ARCMIN_RAD)
    keys = ("u_deg", "samples", "roll_arcmin", "pitch_arcmin", "oblateness_roll_arcmin", "oblateness_pitch_arcmin",
            "residual_roll_arcmin", "residual_pitch_arcmin", "meridional_arcmin")
    series = [dict(zip(keys, row)) for row in zip(*(column.tolist() for column in columns))]
    roll_offset, pitch_offset = signed(result.roll_offset_rad, result.pitch_offset_rad)
    limit_ground = ground_error(result.limit_high_rad, 0.0, altitude_m).circular_m
    return {
        "convention": convention,
        "altitude_km": altitude_m / 1e3, "inclination_deg": math.degrees(inclination_rad), "period_s": period,
        "samples": int(result.samples_per_u.sum()),
        "orbits": result.orbits, "orbital_angles": int(result.u_rad.size),
        "oblateness_removed": result.oblateness_removed,
        "roll_offset_arcmin": roll_offset, "pitch_offset_arcmin": pitch_offset,
        "mo_arcmin": _arcmin(result.mo_rad), "sigma_arcmin": _arcmin(result.sigma_m_rad),
        "limit_arcmin": _arcmin(result.limit_high_rad), "limit_low_arcmin": _arcmin(result.limit_low_rad),
        "limit_high_arcmin": _arcmin(result.limit_high_rad), "limit_ground_m": float(limit_ground),
        "harmonics": list(ORBIT_HARMONICS),
        "channels": channels, "series": series,
    }


# ----------------------------------------------------------------------------------- recordings

SENSOR_TOPIC = "/pmv/attitude"
#: Truth topics tried in this order when --truth is not given.
TRUTH_TOPICS = ("/star_tracker/attitude", "/attitude/truth")
ODOMETRY_TOPIC = "/orbit/odometry"
DIAGNOSTICS_TOPIC = "/diagnostics"
PHASE_SOURCES = ("auto", "odometry", "elements")

VECTOR3_STAMPED = ("geometry_msgs/msg/Vector3Stamped",)
QUATERNION_STAMPED = ("geometry_msgs/msg/QuaternionStamped",)
ODOMETRY = ("nav_msgs/msg/Odometry",)
DIAGNOSTIC_ARRAY = ("diagnostic_msgs/msg/DiagnosticArray",)

#: Magic bytes of the two rosbag2 storage formats.
_MAGIC = (b"\x89MCAP", b"SQLite format 3\x00")

#: Most sensor samples (aligned with truth) and odometry messages one analysis of a recording holds: 55 h at
#: 10 Hz, 23 days at 1 Hz. They are kept as numbers (24 bytes a sample) for the flight-test procedure, whose peak
#: is ≈ 0.2 kB a sample: ≈ 0.5 GB and ≈ 15 s of CPU at this bound. A longer recording: analyse a part of it.
MAX_RECORDING_SAMPLES = 2_000_000

#: Most messages logged at one instant that are held to put the truth first among them (a recording made under a
#: paused /clock logs everything at one time); beyond it they go on in the order they were logged.
MAX_SAME_TIME_MESSAGES = 1000

#: Relative disagreement allowed between the period a sensor states on /diagnostics and the period of the
#: circular orbit at the altitude it states: the secular J2 term changes the period of u by ≤ 0.5 %, an element
#: set's nodal period differs from the circular one of its mean altitude by ≈ 0.1 % (Meteor-M's); more is not
#: one orbit.
ELEMENTS_PERIOD_TOLERANCE = 0.02


def is_recording(path: str) -> bool:
    """True for a rosbag2 directory or an MCAP/sqlite3 file (by name or by its first bytes)."""
    from ..storage.files import open_regular_file

    candidate = Path(path)
    if candidate.is_dir() or candidate.suffix in (".mcap", ".db3"):
        return True
    try:  # never blocks: a FIFO or a device is not a recording (and the CSV reader refuses it)
        with open_regular_file(candidate, "file", max_bytes=1 << 62) as stream:
            start = stream.read(16)
    except (OSError, ValueError):
        return False
    return any(start.startswith(magic) for magic in _MAGIC)


def phase_from_odometry(messages, timeout_s: float):
    """The orbital angle from /orbit/odometry: a function stamp(s) → u (rad, unwrapped; NaN where unknown).

    u is the angle of the POSE position from the ascending node in the orbit
    plane. The plane and the sense of motion come from neighbouring positions
    (frame-free), or for a lone message from the twist as nav_msgs defines
    it: expressed in ``child_frame_id``, whose orientation in
    ``header.frame_id`` is the pose orientation. Stamps within ``timeout_s``
    outside the odometry's span are extrapolated at the end rate; further
    out, NaN. Also returns the mean inclination (deg) and altitude (km)
    the odometry flies, and how many messages were unreadable. Memory:
    ≈ 0.3 kB a message (the caller bounds how many it gives).
    """
    import pmv_msgs_shim as shim
    from ..physics.orbit.two_body import orbit_angles_from_state

    rows, unreadable = [], 0
    for recorded in messages:
        message = recorded.message
        try:
            stamp_s, position, velocity = shim.read_orbit_state(message)  # velocity by nav_msgs' rules
            rows.append((stamp_s, tuple(position), tuple(velocity)))
        except (ValueError, AttributeError):
            unreadable += 1
    rows.sort(key=lambda row: row[0])
    # One message per stamp (a duplicate stamp adds nothing).
    rows = [row for i, row in enumerate(rows) if i == 0 or row[0] > rows[i - 1][0]]
    if not rows:
        raise ValueError(f"no readable message on {ODOMETRY_TOPIC}")
    stamps = np.array([row[0] for row in rows])
    positions = np.array([row[1] for row in rows])
    u, inclination, altitude = [], [], []
    for i, (_, position, velocity) in enumerate(rows):
        position, velocity = np.array(position, float), np.array(velocity, float)
        before, after = positions[max(i - 1, 0)], positions[min(i + 1, len(rows) - 1)]
        chord = after - before
        ok = len(rows) > 1 and float(np.dot(before, after)) > 0.0 and np.linalg.norm(chord) > 0.0
        motion = chord if ok else velocity
        try:
            u_i, inclination_i, altitude_i = orbit_angles_from_state(position, motion)
        except ValueError:
            raise ValueError(f"{ODOMETRY_TOPIC} at stamp {rows[i][0]:.3f} s: position and motion give no orbit "
                             "plane") from None
        u.append(u_i)
        inclination.append(inclination_i)
        altitude.append(altitude_i)
    u = np.unwrap(np.array(u))
    if len(rows) > 1:
        first_rate = (u[1] - u[0]) / (stamps[1] - stamps[0])
        last_rate = (u[-1] - u[-2]) / (stamps[-1] - stamps[-2])
    else:
        first_rate = last_rate = 0.0

    def phase(t_s):
        t = np.asarray(t_s, float)
        value = np.interp(t, stamps, u)
        value = np.where(t < stamps[0], u[0] + first_rate * (t - stamps[0]), value)
        value = np.where(t > stamps[-1], u[-1] + last_rate * (t - stamps[-1]), value)
        outside = (t < stamps[0] - timeout_s) | (t > stamps[-1] + timeout_s)
        if len(rows) == 1:
            outside |= t != stamps[0]
        return np.where(outside, np.nan, value)

    return phase, math.degrees(float(np.mean(inclination))), float(np.mean(altitude)) / 1e3, unreadable


def _by_log_time(stream, first_topic: str, max_group: int = MAX_SAME_TIME_MESSAGES):
    """The (topic, message) stream with ``first_topic`` first among messages logged at the same time.

    At most ``max_group`` messages are held: a longer run of one log time goes
    on in logged order, group by group.
    """
    group, group_time = [], None
    for topic, recorded in stream:
        if group and (recorded.log_time_ns != group_time or len(group) >= max_group):
            yield from sorted(group, key=lambda item: item[0] != first_topic)
            group = []
        group_time = recorded.log_time_ns
        group.append((topic, recorded))
    yield from sorted(group, key=lambda item: item[0] != first_topic)


def orbit_from_elements(elements) -> tuple[float, float]:
    """``(altitude_m, inclination_rad)`` of the orbit a sensor states on /diagnostics, checked; ValueError if not one.

    The ranges are the circular orbit's (:class:`pmv_ros.physics.orbit.two_body.CircularOrbit`), and the stated
    period must be the period of that orbit within :data:`ELEMENTS_PERIOD_TOLERANCE`: the period sets where every
    sample is on the orbit (u), so a period that no orbit at that altitude has is not taken.
    """
    altitude_m, inclination_rad = elements.altitude_km * 1e3, math.radians(elements.inclination_deg)
    try:
        period_s = CircularOrbit(altitude_m, inclination_rad).period_s
    except ValueError as error:
        raise ValueError(f"the orbit on {DIAGNOSTICS_TOPIC}: {error}") from None
    if abs(elements.period_s / period_s - 1.0) > ELEMENTS_PERIOD_TOLERANCE:
        raise ValueError(f"the orbit on {DIAGNOSTICS_TOPIC}: period_s = {elements.period_s:g} s is not the period of "
                         f"an orbit at {elements.altitude_km:g} km ({period_s:.0f} s, ± "
                         f"{ELEMENTS_PERIOD_TOLERANCE:.0%})")
    return altitude_m, inclination_rad


def _recording_orbit(path, altitude_m, inclination_rad, elements, odometry_info) -> tuple[float, float, dict]:
    """The altitude (m) and inclination (rad) the analysis uses and where each came from.

    The flags first (``altitude_m``, ``inclination_rad`` not None), then the orbit the sensor states on
    /diagnostics, then the mean of /orbit/odometry; each checked as the circular orbit checks its own.
    """
    from ..storage.recording import RecordingError

    found = {}
    if elements is not None:
        try:
            found = dict(zip(("altitude", "inclination"), orbit_from_elements(elements)))
        except ValueError as error:
            raise RecordingError(f"{path}: {error}") from None
        where = f"orbit elements on {DIAGNOSTICS_TOPIC}"
    elif odometry_info is not None:
        found = {"altitude": odometry_info["altitude_km"] * 1e3,
                 "inclination": math.radians(odometry_info["inclination_deg"])}
        where = f"the mean of {odometry_info['messages']} messages on {ODOMETRY_TOPIC}"
    given = {"altitude": altitude_m, "inclination": inclination_rad}
    flags = {"altitude": "--altitude-km", "inclination": "--inclination-deg"}
    values, sources = {}, {}
    for name in given:
        if given[name] is not None:
            values[name], sources[name] = given[name], flags[name]
        elif name in found:
            values[name], sources[name] = found[name], where
        else:
            raise RecordingError(f"{path}: the recording carries no orbit (no orbit elements on {DIAGNOSTICS_TOPIC}, "
                                 f"no {ODOMETRY_TOPIC}): give {flags[name]}")
    try:
        CircularOrbit(values["altitude"], values["inclination"])
    except ValueError as error:
        raise RecordingError(f"{path}: the orbit from {sources['altitude']}: {error}") from None
    return values["altitude"], values["inclination"], sources


def analyze_recording(path: str, altitude_m: float | None = None, inclination_rad: float | None = None, *,
                      convention: str | None = None, truth_topic: str | None = None, phase: str = "auto",
                      u_bin_rad: float | None = None, remove_oblateness: bool = True,
                      roll_drift_rad_per_orbit: float = 0.0, pitch_drift_rad_per_orbit: float = 0.0,
                      namespace: str = "", max_samples: int = MAX_RECORDING_SAMPLES) -> dict:
    """The flight-test statistics of a rosbag2 recording of /pmv/attitude with truth; the report as a dict.

    The messages go, in the order they were logged, through the same
    alignment and per-sample statistics as ``error_monitor_node``
    (:func:`pmv_ros.runtime.monitor.runtime.build_monitor` with its default settings):
    truth interpolated at each sensor stamp, never across a truth gap; the
    oblateness model at the orbital angle of the sample. ``per_sample`` in
    the report is what ``/pmv/error_statistics`` says at the end of a live
    run; the rest is the flight-test procedure of physics.md §5 on the
    aligned residuals. The recording is read twice, message by message (the
    orbit first, then sensor and truth): memory holds plain numbers, not
    messages. ``namespace``: the spacecraft's topics are under it (``/sat1/pmv/attitude``; /diagnostics is
    shared, the orbit status is the namespaced sensor's). Raises ValueError (RecordingError) naming what is
    missing or wrong.

    The orbit (altitude and inclination, for the oblateness model and the
    period): ``altitude_m`` and ``inclination_rad`` where given, else the
    orbit the sensor states on /diagnostics (:func:`orbit_from_elements`),
    else the mean of /orbit/odometry; the report's ``orbit_source`` says
    which for each.

    Cost: linear in the messages read (each deserialised once a pass, two
    passes); memory ≈ 24 bytes an aligned sample while reading, ≈ 0.2 kB a
    sample in the procedure. More than ``max_samples`` aligned sensor
    samples (or odometry messages) is a RecordingError.
    """
    import pmv_msgs_shim as shim
    from ..runtime.common.assembly import MONITOR_PARAMS
    from ..runtime.monitor.runtime import build_monitor
    from ..runtime.common.parameters import preset_values
    from ..storage.recording import RecordingError, open_recording

    with open_recording(path) as recording:  # bounds first; a cut MCAP file is read up to its last whole chunk
        spacecraft = "/" + namespace.strip("/") if namespace.strip("/") else ""
        sensor_topic, odometry_topic = spacecraft + SENSOR_TOPIC, spacecraft + ODOMETRY_TOPIC
        orbit_status = shim.orbit_status_name(namespace)
        status = recording.status
        truth_topics = (truth_topic,) if truth_topic else tuple(spacecraft + topic for topic in TRUTH_TOPICS)
        wanted = {sensor_topic: VECTOR3_STAMPED, odometry_topic: ODOMETRY, DIAGNOSTICS_TOPIC: DIAGNOSTIC_ARRAY}
        wanted.update({topic: QUATERNION_STAMPED for topic in truth_topics})
        present = recording.topics(wanted)
        if sensor_topic not in present:
            raise RecordingError(f"{path}: no topic {sensor_topic} in the recording (the sensor's roll and pitch)")
        truth_topic = next((topic for topic in truth_topics if topic in present), None)
        if truth_topic is None:
            raise RecordingError(f"{path}: no truth in the recording: no topic " + " or ".join(truth_topics)
                                 + ("" if len(truth_topics) == 1 else " (give --truth TOPIC)"))
        counts = dict.fromkeys(sorted(present), 0)

        # Pass 1: the orbit — odometry and the sensor's orbit status on /diagnostics.
        seen = {"first": None, "last": None, "sets": 0}  # the first orbit status and how many times it changed

        def orbit_stream(topics):
            for topic, recorded in recording.messages({t: wanted[t] for t in topics}):
                counts[topic] += 1
                if topic == odometry_topic:
                    if counts[topic] > max_samples:
                        raise RecordingError(f"{path}: more than {max_samples} messages on {odometry_topic}, the most "
                                             "one analysis holds (analyse a part of the recording)")
                    yield recorded
                    continue
                try:
                    # The sensor whose topics are read (of this namespace), not another spacecraft's.
                    found = shim.find_orbit_elements(recorded.message, orbit_status)
                except (ValueError, AttributeError):
                    continue
                if found is not None and found != seen["last"]:
                    seen["first"] = seen["first"] or found
                    seen["last"] = found
                    seen["sets"] += 1

        use_odometry = phase in ("auto", "odometry") and odometry_topic in present
        orbit_topics = [t for t in (odometry_topic, DIAGNOSTICS_TOPIC)
                        if t in present and (t != odometry_topic or use_odometry)]
        phase_of = odometry_info = None
        timeout_s = preset_values({}, "error_monitor_node", MONITOR_PARAMS)["odometry_timeout_s"]
        if use_odometry:
            try:
                phase_of, odo_inclination, odo_altitude, odo_unreadable = phase_from_odometry(
                    orbit_stream(orbit_topics), timeout_s)
                odometry_info = {"messages": counts[odometry_topic], "unreadable": odo_unreadable,
                                 "inclination_deg": odo_inclination, "altitude_km": odo_altitude}
                phase_source = odometry_topic
            except RecordingError:
                raise
            except ValueError as error:
                if phase == "odometry":
                    raise RecordingError(f"{path}: {error}") from None
        else:
            for _ in orbit_stream(orbit_topics):
                pass
        elements = seen["first"]
        if phase_of is None and phase in ("auto", "elements") and elements is not None:
            try:
                orbit_from_elements(elements)  # the period gives u: checked before it is used
            except ValueError as error:
                raise RecordingError(f"{path}: {error}") from None
            phase_of, phase_source = elements.argument_of_latitude_rad, f"orbit elements on {DIAGNOSTICS_TOPIC}"
        if phase_of is None:
            needed = {"odometry": f"no messages on {odometry_topic}",
                      "elements": f"no orbit elements on {DIAGNOSTICS_TOPIC} (status '{orbit_status}')",
                      "auto": f"no messages on {odometry_topic} and no orbit elements on {DIAGNOSTICS_TOPIC}"}[phase]
            raise RecordingError(f"{path}: nothing gives the orbital phase: {needed} — stamps alone do not say where "
                                 "the orbit was")
        if convention is None:
            convention = elements.roll_pitch_convention if elements is not None else "ros"
        altitude_m, inclination_rad, orbit_source = _recording_orbit(path, altitude_m, inclination_rad, elements,
                                                                     odometry_info)
        monitor_values = preset_values({}, "error_monitor_node", MONITOR_PARAMS, {
            "orbit.altitude_km": altitude_m / 1e3, "orbit.inclination_deg": math.degrees(inclination_rad),
            "remove_oblateness": remove_oblateness})

        # Pass 2: sensor and truth in logged order (truth first within one log time, as it reached a live monitor).
        monitor = build_monitor(monitor_values)
        unreadable = {"sensor": 0, "truth": 0}
        used = tuple(array("d") for _ in range(3))  # stamp, residual roll, residual pitch in the wire's convention

        def collect(outcomes):
            for outcome in outcomes:
                if outcome.ok:
                    for column, value in zip(used, (outcome.stamp_s, outcome.residual_roll_rad,
                                                    outcome.residual_pitch_rad)):
                        column.append(value)
            if len(used[0]) > max_samples:
                raise RecordingError(f"{path}: more than {max_samples} sensor samples aligned with truth, the most one "
                                     "analysis holds (analyse a part of the recording)")

        stream = recording.messages({truth_topic: QUATERNION_STAMPED, sensor_topic: VECTOR3_STAMPED})
        for topic, recorded in _by_log_time(stream, truth_topic):
            counts[topic] += 1
            try:
                if topic == truth_topic:
                    stamp_s, q = shim.read_attitude_quaternion(recorded.message)
                    collect(monitor.add_truth_quaternion(stamp_s, q))
                    continue
                stamp_s, roll, pitch = shim.read_attitude_angles(recorded.message)
            except (ValueError, AttributeError) as error:
                if isinstance(error, RecordingError):
                    raise
                unreadable["truth" if topic == truth_topic else "sensor"] += 1
                continue
            roll, pitch = convert(roll, pitch, convention, shim.WIRE_CONVENTION)
            u_i = float(phase_of(stamp_s))
            collect(monitor.add_sensor(stamp_s, roll, pitch, u_rad=u_i if math.isfinite(u_i) else None,
                                       altitude_m=altitude_m, inclination_rad=inclination_rad))
        for topic in (sensor_topic, truth_topic):
            if not counts[topic]:
                raise RecordingError(f"{path}: no messages on {topic} in the recording")
        if len(used[0]) < 2:
            raise RecordingError(f"{path}: {len(used[0])} sensor samples could be aligned with truth on {truth_topic}; "
                                 "the statistics need at least 2")
        summary = monitor.summary()
        stamps, roll, pitch = (np.frombuffer(column, dtype=float) for column in used)
        u = phase_of(stamps)
        # Back from the wire's convention to the input's for the flight-test procedure.
        roll, pitch = convert(roll, pitch, shim.WIRE_CONVENTION, convention)
        report = _flight_test_report(u, roll, pitch, altitude_m, inclination_rad, convention,
                                     u_bin_rad=math.radians(DEFAULT_TIME_LAYOUT_BIN_DEG) if u_bin_rad is None
                                     else u_bin_rad, remove_oblateness=remove_oblateness,
                                     roll_drift_rad_per_orbit=roll_drift_rad_per_orbit,
                                     pitch_drift_rad_per_orbit=pitch_drift_rad_per_orbit)
        sign = convert(1.0, 1.0, shim.WIRE_CONVENTION, convention)[0]
        per_sample = {}
        for channel in summary.channels:
            s = 1.0 if channel.channel == "meridional" else sign
            per_sample[channel.channel] = {
                "count": channel.count, "mean_arcmin": s * _arcmin(channel.mean_rad),
                "sigma_arcmin": _arcmin(channel.sigma_rad), "three_sigma_arcmin": _arcmin(channel.three_sigma_rad),
                "max_abs_arcmin": _arcmin(channel.max_abs_rad)}
        counters = {k: v for k, v in summary.counters.items() if v}
        counters.update({f"unreadable_{k}": v for k, v in unreadable.items() if v})
        recording = {"messages": counts, "odometry": odometry_info,
                     "orbit_elements": None if elements is None else dict(vars(elements)),
                     "orbit_element_sets": seen["sets"]}
        if status is not None and not status.complete:
            recording["recovered"] = {"messages": status.messages, "bytes_read": status.bytes_read,
                                      "file_bytes": status.file_bytes, "stopped": status.stopped}
        return {
            "file": str(path), "layout": "recording", "rows_skipped": sum(unreadable.values()),
            "phase_source": phase_source, "truth_topic": truth_topic, "orbit_source": orbit_source,
            "recording": recording,
            **report, "per_sample": per_sample, "counters": counters,
        }
