"""The one machine-readable line a benchmark ends with (README.md, "Headline"), and its reader.

    from headline import headline
    headline("chain", "signal chain, chords/s", fast_rate, "chords/s", "higher", reference_rate, "chords/s",
             "the reference transcription (the test oracle's literal loop)", ratio=fast_rate / reference_rate)

prints ``HEADLINE {json}``; :func:`read` finds it in a benchmark's output for ``benchmarks/run.py``.
"""

from __future__ import annotations

import json
import math

PREFIX = "HEADLINE "
BETTER = ("higher", "lower")


def headline(name: str, measures: str, value: float, unit: str, better: str, baseline: float, baseline_unit: str,
             baseline_is: str, ratio: float | None = None) -> None:
    """Print a benchmark's headline.

    Args:
        name: short name of the figure (``main_job``).
        measures: what the figure is, for people, a few words.
        value: the figure; it must improve (move towards ``better``) when the product gets faster.
        unit: its unit.
        better: "higher" or "lower": the direction of an improvement of the figure and of ``ratio``.
        baseline: the baseline measured in the same run, in ``baseline_unit``.
        baseline_unit: its unit.
        baseline_is: what the baseline is, for people.
        ratio: value ÷ baseline where the baseline does not depend on the product (a bare library doing the same
            kind of work, a reference program, the host without our module), so that it too improves with the
            product and cancels the machine's speed; None where the baseline is a part of the product.
    """
    if better not in BETTER:
        raise ValueError(f"better = {better!r} must be one of {BETTER}")
    numbers = {"value": value, "baseline": baseline, **({} if ratio is None else {"ratio": ratio})}
    for key, number in numbers.items():
        if not math.isfinite(float(number)):
            raise ValueError(f"headline {name}: {key} = {number!r} is not a finite number")
    print(PREFIX + json.dumps({"name": name, "measures": measures, "value": float(value), "unit": unit,
                               "better": better, "baseline": float(baseline), "baseline_unit": baseline_unit,
                               "baseline_is": baseline_is, "ratio": None if ratio is None else float(ratio)},
                              ensure_ascii=False), flush=True)


def read(output: str) -> dict | None:
    """The last headline in a benchmark's output, or None."""
    lines = [line for line in output.splitlines() if line.startswith(PREFIX)]
    return json.loads(lines[-1][len(PREFIX):]) if lines else None
