"""Monte-Carlo error budgets over a year on Dask: tasks, their result files, and the budget (``pmv campaign``).

A campaign is a set of tasks (day of year, seed[, environment component]);
each flies K orbits from 00:00 of the preset's time of day on that day
through the core (:func:`pmv_ros.runtime.flight.fly`: the nodes' models and the
monitor's statistics, no ROS) on a Dask worker. Every finished task becomes
one Parquet file in the output folder, written by the client under a
temporary name and renamed into place, so a file is either whole or absent:
a re-run skips the tasks whose file is there, a killed worker or campaign
loses only the tasks in flight, and no task is counted twice. Dask reruns a
task whose worker died (the scheduler's ``allowed-failures``).

The budget reads the task files back, one at a time: statistics per channel
(roll, pitch, meridional: count, mean, σ, mean ± 3σ, max |e|) by season and
over the year, per day of year, on a latitude × day map, and — with
components — each environment component alone beside the total with their
root sum of squares (physics.md §4, last sentence). It writes
``budget.json`` and two PNG plots.

The package: :mod:`.tasks` (days, seeds, components, settings, the checks
before any worker is asked), :mod:`.results` (one task flown, its result
file written and trusted only when it matches), :mod:`.cluster` (the tasks
on Dask) and :mod:`.error_budget` (the files read back into the budget).
"""

from .error_budget import budget, write_budget
from .cluster import WORKER_ENVIRONMENT, open_client, run_campaign
from .results import (METADATA_KEY, RESULT_COLUMNS, RESULT_FORMAT, ResultRejected, check_result, prepare_folder,
                      read_result, run_task, stale_results, task_path, write_result)
from .tasks import (COMPONENTS, MAX_ORBITS_PER_TASK, MAX_SEEDS, MAX_TASK_SAMPLES, MAX_TASKS, SEASONS, Settings, Task,
                    check, day_epoch, elements_day_epoch, parse_days, plan, season_of, settings_digest,
                    task_overrides, task_samples)

__all__ = ["COMPONENTS", "MAX_ORBITS_PER_TASK", "MAX_SEEDS", "MAX_TASK_SAMPLES", "MAX_TASKS", "METADATA_KEY",
           "RESULT_COLUMNS", "RESULT_FORMAT", "ResultRejected", "SEASONS", "Settings", "Task", "WORKER_ENVIRONMENT",
           "budget", "check", "check_result", "day_epoch", "elements_day_epoch", "open_client", "parse_days", "plan",
           "prepare_folder", "read_result", "run_campaign", "run_task", "season_of", "settings_digest",
           "stale_results", "task_overrides", "task_path", "task_samples", "write_budget", "write_result"]
