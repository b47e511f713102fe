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

from typing import Callable, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.parameter import Parameter

from .rclpy_internals import parameter_overrides
from ..runtime.common.parameters import MAX_STRING_LENGTH, ParameterError, ParamSpec, unknown_parameter_problem


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The ROS parameter descriptor of this spec (rclpy fills in the type from the default)."""
    text = f"{spec.description}" + (f" [{spec.unit}]" if spec.unit else "")
    descriptor = ParameterDescriptor(name=spec.name, description=text, read_only=spec.read_only)
    if spec.choices is not None:
        descriptor.additional_constraints = "one of: " + ", ".join(map(str, spec.choices))
    elif spec.low is not None and spec.high is not None:
        if isinstance(spec.default, bool):
            pass
        elif isinstance(spec.default, int):
            descriptor.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high), step=0)]
        elif isinstance(spec.default, float):
            descriptor.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                                  to_value=float(spec.high), step=0.0)]
        else:
            descriptor.additional_constraints = f"each element in [{spec.low}, {spec.high}]"
    elif spec.constraints:
        descriptor.additional_constraints = spec.constraints
    if spec.max_length is not None:
        descriptor.additional_constraints += f"; at most {spec.max_length} elements"
    elif isinstance(spec.default, str):
        descriptor.additional_constraints += f"; at most {MAX_STRING_LENGTH} characters"
    return descriptor


def declare(node, specs: Sequence[ParamSpec]) -> dict:
    """Declare ``specs`` on ``node`` and return their current values by name.

    Raises:
        ParameterError: an override (YAML, command line) is of the wrong type,
            outside its range or not among its choices; the message names the
            value and the allowed range. Or an override names no parameter of
            any pmv_ros node (a typo): the message names the nearest valid name.
            (Overrides reach every node from a shared ``/**`` section, so a key of
            another pmv_ros node passes here; :func:`check_params_files` checks each
            node's own section exactly.)
    """
    from ..runtime.common.assembly import NODE_PARAMS  # the names a shared section may carry

    # The type check and the int → float coercion must happen before declare_parameter looks at the overrides
    # (rclpy has no public accessor for them: rclpy_internals; its fallback leaves the check to rclpy).
    overrides = parameter_overrides(node)
    if overrides is None:
        overrides = {}
    anyone = {spec.name for node_specs in NODE_PARAMS.values() for spec in node_specs} | {s.name for s in specs}
    for name in sorted(overrides):
        problem = unknown_parameter_problem(name, node.get_name(), anyone)
        if problem:
            raise ParameterError(problem)
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
        if node.has_parameter(spec.name):  # a managed node configured again: declared at the first configure
            parameter = node.get_parameter(spec.name)
        else:
            try:
                parameter = node.declare_parameter(spec.name, spec.default, descriptor(spec))
            except ParameterException as error:
                raise ParameterError(_explain(spec, error)) from None
        value = parameter.value
        problem = spec.check(value)
        if problem:
            raise ParameterError(problem)
        values[spec.name] = value
    return values


def params_files(args) -> list[str]:
    """The ``--params-file`` paths of a ROS command line (inside ``--ros-args``), in order."""
    paths, inside = [], False
    args = list(args or ())
    for index, word in enumerate(args):
        if word == "--ros-args":
            inside = True
        elif word == "--":
            inside = False
        elif inside and word == "--params-file" and index + 1 < len(args):
            paths.append(args[index + 1])
    return paths


def check_params_files(args, node_name: str) -> None:
    """Refuse a key of ``node_name``'s own section of any params file on the command line that it does not declare.

    Read once, at start-up, before rclpy reads the same files, through the
    package's bounded reader (:func:`pmv_ros.storage.files.read_yaml_file`): a
    file that is not a regular UTF-8 file of at most 1 MiB (a FIFO, a device,
    a binary file), that is not YAML, uses aliases or nests deeper than the
    cap never reaches rclpy. The ``/**`` section may carry any pmv_ros node's
    parameters; a key no node has is refused there too.

    Raises:
        ParameterError: one line naming the key, the node and the nearest valid name.
        ValueError: the file itself is refused; one line naming the file and the reason.
    """
    from ..runtime.common.assembly import NODE_PARAMS
    from ..runtime.common.parameters import flatten_parameters
    from ..storage.files import read_yaml_file

    own = {spec.name for spec in NODE_PARAMS[node_name]}
    anyone = {spec.name for specs in NODE_PARAMS.values() for spec in specs}
    for path in params_files(args):
        document = read_yaml_file(path, "params file") or {}
        if not isinstance(document, dict):  # rcl would refuse it with a traceback-sized message
            raise ValueError(f"params file {path}: a mapping of node sections expected, not a "
                             f"{type(document).__name__}")
        for section, body in document.items():
            name = str(section).rstrip("/").rsplit("/", 1)[-1]  # "/ns/sensor_node", "/**/sensor_node", "/**"
            known = own if name == node_name else anyone if name == "**" else None
            if known is None or not isinstance(body, dict):
                continue
            for key in flatten_parameters(body.get("ros__parameters") or {}):
                problem = unknown_parameter_problem(key, node_name, known)
                if problem:
                    raise ParameterError(f"{problem} ({path}, section {section})")


def _explain(spec: ParamSpec, error: Exception) -> str:
    return f"{spec.name}: {error} (allowed: {spec.allowed()})"


def coerce_parameters(specs: dict, parameters: Sequence[Parameter]) -> tuple[list[Parameter], str | None]:
    """Run-time updates with integers for floats turned into floats, or the reason one is not allowed.

    Checks type, range and choices — before rclpy's own descriptor check,
    whose reasons do not name the allowed values for a type mismatch — and
    refuses a read-only parameter with the reason it is read-only.

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
        problem = problem or spec.check(value) or (spec.read_only_reason() if spec.read_only else None)
        if problem:
            return list(parameters), problem
        checked.append(parameter if value is parameter.value else Parameter(parameter.name, value=value))
    return checked, None


def _refused(node, reason: str) -> None:
    """A refused update: counted and said sparingly by a pmv_ros node, logged by any other."""
    note = getattr(node, "note_parameter_refusal", None)
    if note is not None:
        note(reason)
    else:
        node.get_logger().warning(f"rejected parameter update: {reason}")


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
                return SetParametersResult(successful=False, reason=spec.read_only_reason())
            value, problem = spec.coerce(parameter.value)
            problem = problem or spec.check(value)
            if problem:
                _refused(node, problem)
                return SetParametersResult(successful=False, reason=problem)
            candidate[parameter.name] = value
        try:
            rebuild(candidate)
        except ValueError as error:
            reason = str(error)
            changed = [parameter.name for parameter in parameters if parameter.name in by_name]
            if not any(name in reason for name in changed):
                reason = f"{', '.join(changed)}: {reason}"
            _refused(node, reason)
            return SetParametersResult(successful=False, reason=reason)
        values.update(candidate)
        return SetParametersResult(successful=True)

    node.add_parameter_check(on_set)
