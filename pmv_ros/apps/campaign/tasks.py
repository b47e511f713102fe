"""A campaign's tasks: days, seeds and components, the shared settings, the checks made before any worker
is asked, and one task flown (:func:`run_task`)."""

from __future__ import annotations

import datetime as dt
import json
import math
from dataclasses import dataclass


from ...storage.json_output import finite_json
from ...runtime.common.assembly import build_source_orbit
from ...runtime.flight import flight_values
from ...physics.orbit.two_body import CircularOrbit


#: Environment components a campaign can fly alone (``--components``), with the overrides that isolate each.
#: "total" is the preset as it is. The oblateness component keeps the GRS80 Earth under a uniform
#: horizon, so what it shows is what is left after the monitor removes the closed-form model; the
#: others fly a spherical Earth (nothing to remove: the monitor keeps its oblateness-free statistics).
COMPONENTS = {
    "total": {},
    "oblateness": {"sensor.earth_model": "GRS80", "environment.climatology": False, "environment.weather": False,
                   "environment.height_variation": False},
    "climatology": {"sensor.earth_model": "sphere", "environment.climatology": True, "environment.weather": False,
                    "environment.height_variation": False, "remove_oblateness": False},
    "weather": {"sensor.earth_model": "sphere", "environment.climatology": False, "environment.weather": True,
                "environment.height_variation": False, "remove_oblateness": False},
    "height": {"sensor.earth_model": "sphere", "environment.climatology": False, "environment.weather": False,
               "environment.height_variation": True, "remove_oblateness": False},
}

#: Meteorological seasons of the northern hemisphere, by month.
SEASONS = {"DJF": (12, 1, 2), "MAM": (3, 4, 5), "JJA": (6, 7, 8), "SON": (9, 10, 11)}

#: Latitude bins of the latitude × day map, deg.
LATITUDE_BIN_DEG = 10.0

#: Largest number of seeds and of orbits per task a campaign accepts (typo guards).
MAX_SEEDS = 100_000
MAX_ORBITS_PER_TASK = 100.0

#: Most tasks one campaign plans: a year of days × 27 seeds × the five components, or 136 seeds a day without
#: them. What grows with the tasks is small and linear: ≈ 0.2 kB a task planned, one file stat a task before the
#: run, a bounded window of tasks on the cluster (:data:`~pmv_ros.apps.campaign.cluster.TASKS_PER_WORKER`), and
#: each task's own statistics in budget.json (≈ 2 kB a task).
MAX_TASKS = 50_000

#: Most sensor samples one task may fly: a task holds its samples in memory (≈ 250 bytes each while it
#: runs), so 5 million is ≈ 1.3 GB on a worker. More orbits at a high rate: more days or seeds instead.
MAX_TASK_SAMPLES = 5_000_000


def parse_days(spec: str, year: int, from_elements: bool = False) -> list[int]:
    """Days of year from ``"1,91,182,274"``, ``"1-365:7"`` or a mix; ValueError naming a bad item.

    Days run 1 … 365 (366 in a leap year of the preset's epoch); a range
    ``a-b:s`` takes a, a + s, … up to b. With ``from_elements`` (orbit.source
    tle) they are days from the element set's epoch instead, 0 … 365.
    """
    last = 366 if _is_leap(year) else 365
    if from_elements:
        return _parse_day_items(spec, 0, 365, "days from the element set's epoch")
    return _parse_day_items(spec, 1, last, f"days of year {year}")


def _parse_day_items(spec: str, low: int, last: int, meaning: str) -> list[int]:
    days = set()
    for item in str(spec).split(","):
        item = item.strip()
        if not item:
            raise ValueError(f"--days {spec!r} has an empty item")
        body, _, step_text = item.partition(":")
        first_text, dash, last_text = body.partition("-")
        try:
            first = int(first_text)
            stop = int(last_text) if dash else first
            step = int(step_text) if step_text else 1
        except ValueError:
            raise ValueError(f"--days item {item!r} is not a day, a range a-b or a range a-b:step") from None
        for day in (first, stop):
            if not low <= day <= last:
                raise ValueError(f"--days: day {day} is outside the allowed range {low} … {last} ({meaning})")
        if step < 1:
            raise ValueError(f"--days item {item!r}: the step must be ≥ 1")
        if stop < first:
            raise ValueError(f"--days item {item!r}: the range ends before it starts")
        days.update(range(first, stop + 1, step))
    return sorted(days)


def _is_leap(year: int) -> bool:
    return year % 4 == 0 and (year % 100 != 0 or year % 400 == 0)


def day_epoch(epoch_utc: str, day: int) -> str:
    """The preset's epoch moved to ``day`` of its year, same time of day, as ISO 8601 UTC."""
    moment = dt.datetime.fromisoformat(epoch_utc.strip())
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=dt.timezone.utc)
    moment = moment.astimezone(dt.timezone.utc)
    start = moment.replace(month=1, day=1) + dt.timedelta(days=day - 1)
    return start.strftime("%Y-%m-%dT%H:%M:%SZ")


def elements_day_epoch(epoch_utc: str, day: int) -> str:
    """``day`` days after an element set's epoch (ISO 8601 UTC, to the microsecond), as ISO 8601 UTC."""
    moment = dt.datetime.fromisoformat(epoch_utc.strip()).astimezone(dt.timezone.utc)
    return (moment + dt.timedelta(days=day)).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def season_of(epoch_utc: str) -> str:
    """The meteorological season (northern names DJF, MAM, JJA, SON) of a UTC date."""
    month = dt.datetime.fromisoformat(epoch_utc.replace("Z", "+00:00")).month
    return next(name for name, months in SEASONS.items() if month in months)


@dataclass(frozen=True)
class Task:
    """One unit of work: a day of year, a seed, an environment component."""

    day: int
    seed: int
    component: str = "total"

    @property
    def name(self) -> str:
        """The task's file stem (also its Dask key)."""
        return f"day{self.day:03d}-seed{self.seed}-{self.component}"


@dataclass(frozen=True)
class Settings:
    """What every task of a campaign shares: the parsed preset, its epoch, the rate and the length."""

    document: dict
    epoch_utc: str
    rate_hz: float | None
    orbits_per_task: float
    #: orbit.source tle: ``epoch_utc`` is the element set's epoch and the days count from it
    days_from_elements: bool = False
    #: fly the closed loop (:func:`pmv_ros.runtime.flight.fly_closed_loop`): the pointing error beside the residuals
    closed_loop: bool = False

    def manifest(self) -> dict:
        """The settings as JSON-ready data (``campaign.json``; ``closed_loop`` only when set, so an open-loop
        campaign's folder reads as it always did)."""
        manifest = {"preset": self.document, "rate_hz": self.rate_hz, "orbits_per_task": self.orbits_per_task}
        if self.closed_loop:
            manifest["closed_loop"] = True
        return manifest


def settings_digest(settings: Settings) -> str:
    """SHA-256 of the campaign's settings (the preset and its overrides, rate, length), as a result file records it."""
    import hashlib

    text = json.dumps(finite_json(settings.manifest()), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def plan(days, seeds: int, components: bool) -> list[Task]:
    """Every task: days × seeds (0 … seeds − 1) × components (just "total" without ``components``).

    The count is checked before anything is built: more than :data:`MAX_TASKS`
    is a ValueError naming the bound.
    """
    names = list(COMPONENTS) if components else ["total"]
    count = len(days) * seeds * len(names)
    if count > MAX_TASKS:
        raise ValueError(f"{len(days)} days × {seeds} seeds" + (f" × {len(names)} components" if components else "")
                         + f" is {count} tasks, more than the {MAX_TASKS} one campaign plans (fewer days or seeds, "
                         "or several campaigns into several --out folders)")
    return [Task(day, seed, name) for name in names for day in days for seed in range(seeds)]


def task_overrides(settings: Settings, task: Task) -> dict:
    """The parameters a task sets on every node: its seed and epoch, the rate, its component."""
    epoch = (elements_day_epoch if settings.days_from_elements else day_epoch)(settings.epoch_utc, task.day)
    overrides = {"seed": task.seed, "sim.epoch_utc": epoch}
    if settings.rate_hz is not None:
        overrides["sensor.rate_hz"] = settings.rate_hz
    overrides.update(COMPONENTS[task.component])
    return overrides


def task_samples(values, orbits: float) -> int:
    """Sensor samples in ``orbits`` orbits, counted as ``pmv simulate --orbits`` counts its ticks."""
    sensor = values.sensor
    orbit = CircularOrbit(sensor["orbit.altitude_km"] * 1e3, math.radians(sensor["orbit.inclination_deg"]),
                          j2_node_drift=sensor["orbit.j2_node_drift"])
    if sensor["orbit.source"] != "circular":  # the element set's nodal period
        orbit = build_source_orbit(sensor, 0.0, check_span_s=0.0)
    return max(2, round(orbits * orbit.period_s * sensor["sensor.rate_hz"]))


def check(settings: Settings, tasks: list[Task]) -> None:
    """Raise ValueError for settings that no task could fly, before any worker is asked."""
    first = tasks[0]
    values = flight_values(settings.document, task_overrides(settings, first))
    if values.sensor["orbit.source"] == "follow":
        raise ValueError("orbit.source = follow: a campaign flies an orbit of its own (circular or tle), there is no "
                         "user's orbit/odometry to follow")
    if settings.closed_loop:
        check_closed_loop(values)
    elif values.sensor["attitude.source"] != "profile":
        raise ValueError("attitude.source = follow: a campaign flies the sensor's own attitude profile (or the "
                         "closed loop: --closed-loop)")
    if any(task.component != "total" for task in tasks) and values.sensor["radiance.source"] != "environment":
        raise ValueError("--components needs radiance.source: environment in the preset (the components are "
                         "the environment's)")
    samples = task_samples(values, settings.orbits_per_task)
    if samples > MAX_TASK_SAMPLES:
        raise ValueError(f"--orbits-per-task {settings.orbits_per_task:g} at {values.sensor['sensor.rate_hz']:g} Hz "
                         f"is {samples} samples a task, more than {MAX_TASK_SAMPLES} (fly fewer orbits per task)")
    period = 1.0 / values.sensor["sensor.rate_hz"]
    if period > values.star_tracker["max_truth_gap_s"]:
        raise ValueError(f"sensor rate {values.sensor['sensor.rate_hz']:g} Hz: samples {period:g} s apart are "
                         "longer than the star tracker's "
                         f"max_truth_gap_s = {values.star_tracker['max_truth_gap_s']:g} s"
                         ", so it would measure no frame")
    for name in {task.component for task in tasks} - {first.component}:  # each component's overrides once
        flight_values(settings.document, task_overrides(settings, Task(first.day, first.seed, name)))
    if values.sensor["orbit.source"] != "circular":  # SGP4 over every day's span: an error code now, not on a worker
        span_s = samples / values.sensor["sensor.rate_hz"]
        for day in sorted({task.day for task in tasks}):
            sensor = flight_values(settings.document, task_overrides(settings, Task(day, first.seed))).sensor
            build_source_orbit(sensor, sensor["sim.start_time_s"], check_span_s=span_s)


def check_closed_loop(values) -> None:
    """Raise ValueError for a controller no closed-loop task could fly (its gains, its body, its rate)."""
    from ...runtime.control import LoopSettings, plant_of

    plant_of(values.controller)
    LoopSettings.from_values(values.controller)
    period = 1.0 / values.controller["control.rate_hz"]
    if period > values.star_tracker["max_truth_gap_s"]:
        raise ValueError(f"control.rate_hz {values.controller['control.rate_hz']:g} Hz: the plant's states "
                         f"{period:g} s apart are longer than the star tracker's max_truth_gap_s = "
                         f"{values.star_tracker['max_truth_gap_s']:g} s, so it would measure no frame")
