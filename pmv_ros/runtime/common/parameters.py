"""Node parameters as plain data: name, default, meaning, allowed values — no ROS.

A :class:`ParamSpec` says what one parameter of one node is and what values
it may take; :mod:`pmv_ros.runtime.common.assembly` lists every node's specs and builds
the models from their values. The nodes turn a spec into a ROS
``ParameterDescriptor`` (:mod:`pmv_ros.nodes.params`); the CLI, the campaign
and the tests read presets through :func:`preset_values` without rclpy.

An integer given for a floating-point parameter (``rate_hz: 10`` in YAML) is
taken as that number, not rejected: nobody means anything else by it.

Sizes are bounded (anyone on the DDS domain can set parameters): a
list parameter declares its ``max_length`` (documented in its descriptor), a
string is at most :data:`MAX_STRING_LENGTH` characters; longer values are
refused before anything is built from them. A key that no parameter of the
node has is refused too (:func:`unknown_parameter_problem`), naming the
nearest valid name — a typo in a params file must not run the node on a
default silently.
"""

from __future__ import annotations

import array
import difflib
import math
from dataclasses import dataclass
from typing import Any, Sequence


#: Longest string parameter value, characters (a path, a date, a word: never more).
MAX_STRING_LENGTH = 4096

#: Parameters rclpy itself declares or reads on every node (never ours to refuse).
ROS_OWN_PARAMETERS = ("use_sim_time", "start_type_description_service")
#: Prefixes of parameters rclpy reads on every node (QoS overrides of publishers and subscriptions).
ROS_OWN_PREFIXES = ("qos_overrides.",)


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: name, default, meaning, and what values are allowed.

    Args:
        name: the parameter name (dots for YAML nesting).
        default: default value; its Python type is the parameter's type.
        description: one sentence for people.
        low, high: allowed closed range of a number (each element of a list).
        choices: allowed values of an enumeration.
        unit: unit of the value as written in YAML.
        constraints: what a free-form string must look like (says so in the descriptor).
        read_only: cannot change at run time.
        max_length: most elements of a list parameter (required for lists: memory is
            bounded whatever a peer sends); strings are bounded by MAX_STRING_LENGTH.
    """

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None
    unit: str = ""
    constraints: str = ""
    read_only: bool = False
    max_length: int | None = None

    def __post_init__(self) -> None:
        if isinstance(self.default, (list, tuple)) and not (isinstance(self.max_length, int) and self.max_length > 0):
            raise ValueError(f"list parameter {self.name} needs a max_length")

    @property
    def kind(self) -> str:
        """The value type for people: 'a number', 'an integer', 'true or false', 'a string', 'a list of numbers'."""
        return _kind_of_default(self.default)

    def allowed(self) -> str:
        """What values are allowed, for a reason text ('in [0.1, 100.0] Hz', 'one of [...]', ...)."""
        unit = f" {self.unit}" if self.unit else ""
        if self.choices is not None:
            return f"one of {list(self.choices)}"
        if self.low is not None and self.high is not None:
            if isinstance(self.default, (list, tuple)):
                return f"at most {self.max_length} elements, each in [{self.low}, {self.high}]{unit}"
            return f"in [{self.low}, {self.high}]{unit}"
        if self.constraints:
            return self.constraints
        return self.kind

    def coerce(self, value) -> tuple[Any, str | None]:
        """``value`` as this parameter's type, or the reason it is not one.

        Integers are accepted for floating-point parameters (and lists of
        them for lists of floats); anything else of another type is refused.
        """
        default = self.default
        if isinstance(default, bool):
            ok = isinstance(value, bool)
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = _is_number(value)
            value = float(value) if ok else value
        elif isinstance(default, str):
            ok = isinstance(value, str)
        else:  # a list of floats
            ok = isinstance(value, (list, tuple, array.array)) and all(_is_number(v) for v in value)
            value = [float(v) for v in value] if ok else value
        if ok:
            return value, None
        allowed = self.allowed()
        return value, (f"{self.name} = {value!r} is {_kind_of_value(value)}, but it must be {self.kind}"
                       + ("" if allowed == self.kind else f" ({allowed})"))

    def read_only_reason(self) -> str:
        """Why a run-time update of this read-only parameter is refused (a reason for people)."""
        return (f"{self.name} is read-only while the node runs: it defines the simulated world (orbit, epoch, "
                "seeds, correction table, Earth model, clock and attitude source); restart the node to change it")

    def check(self, value) -> str | None:
        """Why ``value`` (of the right type) is not allowed (None if it is). Covers what rclpy's ranges do not."""
        if isinstance(value, (list, tuple, array.array)) and self.max_length is not None \
                and len(value) > self.max_length:
            return f"{self.name} has {len(value)} elements, more than the {self.max_length} allowed"
        if isinstance(value, str) and len(value) > MAX_STRING_LENGTH:
            return f"{self.name} is a string of {len(value)} characters, more than the {MAX_STRING_LENGTH} allowed"
        if self.choices is not None and value not in self.choices:
            return f"{self.name} = {value!r} is not one of the allowed values {list(self.choices)}"
        if isinstance(value, float) and not math.isfinite(value):
            return f"{self.name} = {value} is not a finite number (allowed: {self.allowed()})"
        if isinstance(value, (list, tuple, array.array)) and self.low is not None and self.high is not None:
            for element in value:
                if not (self.low <= element <= self.high):
                    return (f"{self.name} has element {element} outside the allowed range "
                            f"[{self.low}, {self.high}]{(' ' + self.unit) if self.unit else ''}")
        if (self.low is not None and self.high is not None and isinstance(value, (int, float))
                and not isinstance(value, bool) and not (self.low <= value <= self.high)):
            return (f"{self.name} = {value} is outside the allowed range [{self.low}, {self.high}]"
                    f"{(' ' + self.unit) if self.unit else ''}")
        return None


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _kind_of_default(default) -> str:
    if isinstance(default, bool):
        return "true or false"
    if isinstance(default, int):
        return "an integer"
    if isinstance(default, float):
        return "a number"
    if isinstance(default, str):
        return "a string"
    return "a list of numbers"


def _kind_of_value(value) -> str:
    if isinstance(value, (list, tuple, array.array)):
        return "a list" + ("" if all(_is_number(v) for v in value) else " with non-numbers")
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (bytes, bytearray)):
        return "a byte array"
    return f"of type {type(value).__name__}"


class ParameterError(ValueError):
    """A node parameter has a value it must not have (at start-up)."""


def is_ros_own(name: str) -> bool:
    """Whether rclpy itself reads parameter ``name`` on every node (use_sim_time, QoS overrides)."""
    return name in ROS_OWN_PARAMETERS or name.startswith(ROS_OWN_PREFIXES)


def unknown_parameter_problem(name: str, node_name: str, valid_names) -> str | None:
    """Why ``name`` is no parameter of ``node_name`` (with the nearest valid name), or None if it is one.

    Args:
        valid_names: every name the node accepts (its own specs; where a shared
            ``/**`` section can reach it, the other nodes' as well).
    """
    valid = set(valid_names)
    if name in valid or is_ros_own(name):
        return None
    nearest = difflib.get_close_matches(name, sorted(valid), n=1, cutoff=0.6)
    hint = f" (did you mean {nearest[0]!r}?)" if nearest else ""
    return f"{name!r} is not a parameter of {node_name}{hint}"



def flatten_parameters(tree: dict, prefix: str = "") -> dict:
    """``{"a": {"b": 1}}`` → ``{"a.b": 1}``: a ``ros__parameters`` tree as dotted parameter names."""
    flat = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            flat.update(flatten_parameters(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def preset_values(document: dict, node_name: str, specs: Sequence[ParamSpec], overrides: dict | None = None,
                  shared_specs: Sequence[ParamSpec] | None = None) -> dict:
    """Parameter values of one node from a parsed params file, as rclpy merges them, checked.

    The ``/**`` section applies to every node, the node's own section wins
    over it, ``overrides`` win over both. A key of the node's own section (or
    of ``overrides``) that the node does not declare is an error; a key of the
    ``/**`` section only if no node in ``shared_specs`` declares it (that
    section is shared by nodes with different parameters). Raises
    :class:`ParameterError` naming a bad value or an unknown key.

    Args:
        shared_specs: every node's specs, against which the ``/**`` keys are checked
            (default: the ``/**`` keys are not checked).
    """
    by_name = {spec.name: spec for spec in specs}
    anyone = None if shared_specs is None else set(by_name) | {spec.name for spec in shared_specs}
    given = {}
    for section, known in (("/**", anyone), (node_name, by_name)):
        body = (document or {}).get(section) or {}
        flat = flatten_parameters(body.get("ros__parameters") or {})
        for name in flat if known is not None else ():
            problem = unknown_parameter_problem(name, node_name, known)
            if problem:
                raise ParameterError(problem)
        given.update(flat)
    for name in overrides or {}:
        problem = unknown_parameter_problem(name, node_name, by_name)
        if problem:
            raise ParameterError(problem)
    given.update(overrides or {})
    values = {spec.name: spec.default for spec in specs}
    for name, raw in given.items():
        spec = by_name.get(name)
        if spec is None:
            continue
        value, problem = spec.coerce(raw)
        problem = problem or spec.check(value)
        if problem:
            raise ParameterError(problem)
        values[name] = value
    return values
