"""Strict JSON of the package's outputs: non-finite floats become null."""

from __future__ import annotations

import math


def finite_json(value):
    """``value`` with every non-finite float (NaN, ±Inf) replaced by None, for strict JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_json(v) for v in value]
    return value
