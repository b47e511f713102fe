"""Shared pieces of the ``pmv`` command line: one-line errors, ranged arguments, output."""

from __future__ import annotations

import argparse
import json
import math
import sys

from ..storage.json_output import finite_json


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr and exit status 2."""

    def error(self, message):  # noqa: D102 - argparse hook
        self.exit(2, f"{self.prog}: error: {message}\n")


def ranged_float(low: float, high: float, unit: str = "", *, low_open: bool = False):
    """An argparse type: a finite float in [low, high] (or (low, high] with ``low_open``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        too_low = value <= low if low_open else value < low
        if not math.isfinite(value) or too_low or value > high:
            bracket = "(" if low_open else "["
            raise argparse.ArgumentTypeError(
                f"{text}{unit} is outside the allowed range {bracket}{low:g}, {high:g}]{unit}")
        return value

    return parse


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    """Add the ``--json`` flag every subcommand has."""
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")


def print_json(payload: dict) -> None:
    """Print ``payload`` as one JSON object (NaN becomes null)."""
    print(json.dumps(finite_json(payload), indent=None, separators=(",", ":"), allow_nan=False))


def format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """Render rows as a fixed-width table; ``columns`` are (key, heading, format spec)."""
    cells = [[heading for _, heading, _ in columns]]
    for row in rows:
        cells.append([format(row[key], spec) if row[key] is not None else "—" for key, _, spec in columns])
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def fail(prog: str, message: str) -> int:
    """Print a one-line error for a user mistake and return the exit status."""
    print(f"{prog}: error: {message}", file=sys.stderr)
    return 2
