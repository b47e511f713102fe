"""Strict JSON of the package's outputs: non-finite floats become null."""

from __future__ import annotations

import math

_CONTAINERS = (dict, list, tuple)


def finite_json(value):
    """``value`` with every non-finite float (NaN, ±Inf) replaced by None, for strict JSON.

    Leaves are cleaned in the containers' own comprehensions (one call per
    container, not per number: a report of 500,000 rows holds millions).
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: (None if isinstance(v, float) and not math.isfinite(v)
                    else finite_json(v) if isinstance(v, _CONTAINERS) else v) for k, v in value.items()}
    if isinstance(value, _CONTAINERS):
        return [None if isinstance(v, float) and not math.isfinite(v)
                else finite_json(v) if isinstance(v, _CONTAINERS) else v for v in value]
    return value
