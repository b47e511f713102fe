"""Run every benchmark in this folder, one after the other, and print one table of their headlines (``make bench``).

Each ``bench_*.py`` runs as its own process with its default arguments; its own printout is passed through as it
comes, and its headline (the ``HEADLINE`` line, README.md) is collected. At the end one table: per benchmark what
it measures, the figure, the baseline it was measured against in the same run, and figure ÷ baseline where that
baseline does not depend on the product. A benchmark that fails (a traceback, or no headline) gets a row that
says so and makes the exit status 1; one that cannot run here says why in its row.

    .venv/bin/python benchmarks/run.py                    # every benchmark
    .venv/bin/python benchmarks/run.py chain basilisk     # those whose name contains a word given
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

from headline import read

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def benchmarks(words) -> list[Path]:
    """The benchmark scripts, by name; those whose name contains one of ``words`` when any are given."""
    found = sorted(HERE.glob("bench_*.py"))
    return [path for path in found if not words or any(word in path.stem for word in words)]


def run(path: Path) -> tuple[int, str, float]:
    """Run one benchmark, passing its output through; (exit status, output, wall s)."""
    print(f"\n=== {path.name} (load average {os.getloadavg()[0]:.1f})", flush=True)
    started = time.monotonic()
    lines = []
    with subprocess.Popen([sys.executable, str(path)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          stdin=subprocess.DEVNULL, text=True, errors="replace") as process:
        for line in process.stdout:
            sys.stdout.write(line)
            sys.stdout.flush()
            lines.append(line)
    return process.returncode, "".join(lines), time.monotonic() - started


def _number(value: float) -> str:
    return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.3g}"


def failed(status: int, output: str) -> bool:
    """A benchmark failed: a traceback, or no headline. One that cannot run here (a missing optional dependency)
    ends non-zero with one line that says why and no traceback (README.md): not a failure."""
    return "Traceback (most recent call last)" in output or (status == 0 and read(output) is None)


def row(path: Path, status: int, output: str, wall_s: float) -> list[str]:
    """The table's cells for one benchmark."""
    found = read(output)
    if status != 0 or found is None:
        last = next((line for line in reversed(output.splitlines()) if line.strip()), "no output")
        why = "FAILED" if failed(status, output) else "not run here"
        return [path.stem, f"{why} (exit {status}, its last line below)", "", "", "", f"{wall_s:.0f}",
                last.strip()]
    arrow = "↑" if found["better"] == "higher" else "↓"
    ratio = found["ratio"]
    return [path.stem, found["measures"], f"{_number(found['value'])} {found['unit']} {arrow}",
            f"{_number(found['baseline'])} {found['baseline_unit']}: {found['baseline_is']}",
            "—" if ratio is None else f"{_number(ratio)} {arrow}", f"{wall_s:.0f}"]


def table(rows: list[list[str]]) -> str:
    """The rows as a fixed-width table, then the last line of each benchmark that did not give a headline."""
    headings = ["benchmark", "measures", "figure (↑/↓: better)", "baseline, same run", "figure ÷ baseline", "s"]
    cells = [headings, *(r[:len(headings)] for r in rows)]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headings))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    lines += [f"{r[0]}: {r[-1]}" for r in rows if len(r) > len(headings)]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("words", nargs="*", help="run only the benchmarks whose name contains one of these")
    args = parser.parse_args(argv)
    chosen = benchmarks(args.words)
    if not chosen:
        parser.error(f"no benchmark matches {' '.join(args.words)}")
    load_start = os.getloadavg()[0]
    rows, failures = [], 0
    for path in chosen:
        status, output, wall_s = run(path)
        rows.append(row(path, status, output, wall_s))
        failures += failed(status, output)
    print(f"\n{len(chosen)} benchmarks; load average {load_start:.1f} at the start, {os.getloadavg()[0]:.1f} at the "
          "end (a figure is comparable only to its baseline of the same run)")
    print(table(rows))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
