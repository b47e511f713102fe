"""Declared, described and validated node parameters.

Every parameter of every node is declared here from a :class:`ParamSpec`:
type, range or choices, unit and description land in its
``ParameterDescriptor`` (``ros2 param describe`` shows them). Ranges are
enforced by rclpy itself at declaration and on every set; choices and
cross-parameter checks by :func:`install_validation`, which rejects a bad
update with a reason naming the value and the allowed range — the node keeps
its old value and keeps running.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.parameter import Parameter


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: name, default, meaning, and what values are allowed."""

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None
    unit: str = ""
    read_only: bool = False

    def descriptor(self) -> ParameterDescriptor:
        """The ROS parameter descriptor of this spec."""
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
        return descriptor

    def check(self, value) -> str | None:
        """Why ``value`` is not allowed (None if it is). Covers what rclpy's ranges do not."""
        if self.choices is not None and value not in self.choices:
            return f"{self.name} = {value!r} is not one of the allowed values {list(self.choices)}"
        if isinstance(value, float) and not math.isfinite(value):
            return f"{self.name} = {value} is not a finite number"
        if isinstance(value, (list, tuple)) and self.low is not None and self.high is not None:
            for element in value:
                if not (self.low <= element <= self.high):
                    return (f"{self.name} has element {element} outside the allowed range "
                            f"[{self.low}, {self.high}]{(' ' + self.unit) if self.unit else ''}")
        if (self.low is not None and self.high is not None and isinstance(value, (int, float))
                and not isinstance(value, bool) and not (self.low <= value <= self.high)):
            return (f"{self.name} = {value} is outside the allowed range [{self.low}, {self.high}]"
                    f"{(' ' + self.unit) if self.unit else ''}")
        return None


class ParameterError(ValueError):
    """A node parameter has a value it must not have (at start-up)."""


def declare(node, specs: Sequence[ParamSpec]) -> dict:
    """Declare ``specs`` on ``node`` and return their current values by name.

    Raises:
        ParameterError: an override (YAML, command line) is of the wrong type,
            outside its range or not among its choices; the message names the
            value and the allowed range.
    """
    values = {}
    for spec in specs:
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
    text = str(error)
    if spec.choices is not None:
        return f"{spec.name}: {text} (allowed: {list(spec.choices)})"
    if spec.low is not None and spec.high is not None:
        return f"{spec.name}: {text} (allowed range [{spec.low}, {spec.high}]{(' ' + spec.unit) if spec.unit else ''})"
    return f"{spec.name}: {text} (expected type {type(spec.default).__name__})"


def install_validation(node, specs: Sequence[ParamSpec], values: dict,
                       rebuild: Callable[[dict], None]) -> None:
    """Validate run-time parameter updates and apply the accepted ones.

    ``rebuild(new_values)`` builds whatever the node derives from its
    parameters and raises ValueError if the combination is invalid; it is
    called before the update is accepted, so a bad update changes nothing.
    """
    by_name = {spec.name: spec for spec in specs}

    def on_set(parameters: list[Parameter]) -> SetParametersResult:
        candidate = dict(values)
        for parameter in parameters:
            spec = by_name.get(parameter.name)
            if spec is None:
                continue  # use_sim_time and friends are rclpy's own
            if spec.read_only:
                return SetParametersResult(successful=False, reason=f"{spec.name} is read-only")
            problem = spec.check(parameter.value)
            if problem:
                node.get_logger().warning(f"rejected parameter update: {problem}")
                return SetParametersResult(successful=False, reason=problem)
            candidate[parameter.name] = parameter.value
        try:
            rebuild(candidate)
        except ValueError as error:
            node.get_logger().warning(f"rejected parameter update: {error}")
            return SetParametersResult(successful=False, reason=str(error))
        values.update(candidate)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
