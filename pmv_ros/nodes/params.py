"""Declared, described and validated node parameters.

Every parameter of every node is declared here from a :class:`ParamSpec`:
type, range or choices, unit and description land in its
``ParameterDescriptor`` (``ros2 param describe`` shows them). A value is
checked in three places, all with a reason that names the parameter, the
value and what is allowed:

* at start-up, :func:`declare` checks each override (params file, ``-p``)
  before rclpy sees it and raises :class:`ParameterError` (the node's
  ``main`` turns that into one line on stderr and exit status 1);
* at run time, :class:`pmv_ros.nodes.base.PmvNode` checks the type of every
  update (:func:`coerce_parameters`) and :func:`install_validation` the
  range, the choices and the combination with the other parameters; a
  rejected update changes nothing — the node keeps its old value and keeps
  running;
* rclpy enforces the descriptor's range as well, as a second line.

An integer given for a floating-point parameter (``rate_hz: 10`` in YAML) is
taken as that number, not rejected: rclpy's static typing would refuse it
although nobody means anything else by it.
"""

from __future__ import annotations

import array
import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.parameter import Parameter


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
            each = "each element " if isinstance(self.default, (list, tuple)) else ""
            return f"{each}in [{self.low}, {self.high}]{unit}"
        if self.constraints:
            return self.constraints
        return self.kind

    def descriptor(self) -> ParameterDescriptor:
        """The ROS parameter descriptor of this spec (rclpy fills in the type from the default)."""
        text = f"{self.description}" + (f" [{self.unit}]" if self.unit else "")
        descriptor = ParameterDescriptor(name=self.name, description=text, read_only=self.read_only)
        if self.choices is not None:
            descriptor.additional_constraints = "one of: " + ", ".join(map(str, self.choices))
        elif self.low is not None and self.high is not None:
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                descriptor.integer_range = [IntegerRange(from_value=int(self.low), to_value=int(self.high), step=0)]
            elif isinstance(self.default, float):
                descriptor.floating_point_range = [FloatingPointRange(from_value=float(self.low),
                                                                      to_value=float(self.high), step=0.0)]
            else:
                descriptor.additional_constraints = f"each element in [{self.low}, {self.high}]"
        elif self.constraints:
            descriptor.additional_constraints = self.constraints
        return descriptor

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

    def check(self, value) -> str | None:
        """Why ``value`` (of the right type) is not allowed (None if it is). Covers what rclpy's ranges do not."""
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


def declare(node, specs: Sequence[ParamSpec]) -> dict:
    """Declare ``specs`` on ``node`` and return their current values by name.

    Raises:
        ParameterError: an override (YAML, command line) is of the wrong type,
            outside its range or not among its choices; the message names the
            value and the allowed range.
    """
    # rclpy keeps the overrides of the command line and params files in this
    # attribute (no public accessor); the type check and the int → float
    # coercion must happen before declare_parameter looks at them.
    overrides = getattr(node, "_parameter_overrides", {})
    values = {}
    for spec in specs:
        if spec.name in overrides:
            value, problem = spec.coerce(overrides[spec.name].value)
            if problem:
                raise ParameterError(problem)
            problem = spec.check(value)
            if problem:
                raise ParameterError(problem)
            overrides[spec.name] = Parameter(spec.name, value=value)
        try:
            parameter = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        except ParameterException as error:
            raise ParameterError(_explain(spec, error)) from None
        value = parameter.value
        problem = spec.check(value)
        if problem:
            raise ParameterError(problem)
        values[spec.name] = value
    return values


def _explain(spec: ParamSpec, error: Exception) -> str:
    return f"{spec.name}: {error} (allowed: {spec.allowed()})"


def coerce_parameters(specs: dict, parameters: Sequence[Parameter]) -> tuple[list[Parameter], str | None]:
    """Run-time updates with integers for floats turned into floats, or the reason one is not allowed.

    Checks type, range and choices — before rclpy's own descriptor check,
    whose reasons do not name the allowed values for a type mismatch.

    Args:
        specs: ``{name: ParamSpec}``; parameters not in it (rclpy's own) pass unchanged.
        parameters: the requested updates.
    """
    checked = []
    for parameter in parameters:
        spec = specs.get(parameter.name)
        if spec is None or parameter.type_ == Parameter.Type.NOT_SET:
            checked.append(parameter)
            continue
        value, problem = spec.coerce(parameter.value)
        problem = problem or spec.check(value)
        if problem:
            return list(parameters), problem
        checked.append(parameter if value is parameter.value else Parameter(parameter.name, value=value))
    return checked, None


def install_validation(node, specs: Sequence[ParamSpec], values: dict,
                       rebuild: Callable[[dict], None]) -> None:
    """Validate run-time parameter updates and apply the accepted ones.

    ``rebuild(new_values)`` builds whatever the node derives from its
    parameters and raises ValueError if the combination is invalid; it is
    called before the update is accepted, so a bad update changes nothing.
    The node's type gate (:meth:`pmv_ros.nodes.base.PmvNode.set_parameters`)
    learns the specs here.
    """
    by_name = {spec.name: spec for spec in specs}
    if hasattr(node, "parameter_specs"):
        node.parameter_specs.update(by_name)

    def on_set(parameters: list[Parameter]) -> SetParametersResult:
        candidate = dict(values)
        for parameter in parameters:
            spec = by_name.get(parameter.name)
            if spec is None:
                continue  # use_sim_time and friends are rclpy's own
            if spec.read_only:
                return SetParametersResult(successful=False, reason=f"{spec.name} is read-only")
            value, problem = spec.coerce(parameter.value)
            problem = problem or spec.check(value)
            if problem:
                node.get_logger().warning(f"rejected parameter update: {problem}")
                return SetParametersResult(successful=False, reason=problem)
            candidate[parameter.name] = value
        try:
            rebuild(candidate)
        except ValueError as error:
            reason = str(error)
            changed = [parameter.name for parameter in parameters if parameter.name in by_name]
            if not any(name in reason for name in changed):
                reason = f"{', '.join(changed)}: {reason}"
            node.get_logger().warning(f"rejected parameter update: {reason}")
            return SetParametersResult(successful=False, reason=reason)
        values.update(candidate)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
