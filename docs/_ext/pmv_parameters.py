"""The parameter reference, generated at build time from the nodes' ``ParamSpec`` tables.

Every node declares its parameters from :data:`pmv_ros.runtime.common.assembly.NODE_PARAMS`
(name, default, one-line description, range or choices, unit, read-only). This extension
turns that table into each node page's reference and adds, from ``parameter_notes.yaml``
beside ``conf.py``, the doc line a reader needs beyond the one-line description (why the
value is what it is, what it changes, where physics.md explains it).

* ``{pmv-parameters} NODE`` (a directive): the reference of one node — a summary table and
  one entry per parameter (type, default, unit, allowed values, read-only, description, doc line).
* ``{param}`NODE:NAME``` or ``{param}`NAME``` (a role): a link to a parameter's entry; a name no
  node declares is a build warning (so prose cannot go on naming a parameter that is gone).

A parameter without a doc line, or a doc line for a parameter that no longer exists, is a
build warning too: ``make docs`` builds with warnings as errors, and ``tests/system/test_docs.py``
checks the same without Sphinx (:func:`note_problems`).
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml
from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective, SphinxRole

#: The notes file (beside conf.py); ``/**`` holds doc lines shared by every node that declares the name,
#: a node's own section wins over it (the layout of a ros__parameters file).
NOTES_FILE = "parameter_notes.yaml"
SHARED = "/**"

logger = logging.getLogger(__name__)


def node_params() -> dict:
    """``{node name: (ParamSpec, ...)}``: what the nodes declare."""
    from pmv_ros.runtime.common.assembly import NODE_PARAMS

    return NODE_PARAMS


def load_notes(path: Path) -> dict:
    """``{section: {parameter: doc line}}`` from the notes file (sections: ``/**`` and node names)."""
    document = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    return {str(section): {str(name): " ".join(str(text).split()) for name, text in (body or {}).items()}
            for section, body in document.items()}


def note_for(notes: dict, node: str, name: str) -> str | None:
    """The doc line of ``name`` on ``node``: the node's own, else the shared one, else None."""
    return notes.get(node, {}).get(name) or notes.get(SHARED, {}).get(name) or None


def note_problems(notes: dict, params: dict | None = None) -> list[str]:
    """Everything wrong between the notes and the declared parameters, one sentence each (empty: none).

    A declared parameter without a doc line; a doc line for a name its section's node (or, for ``/**``,
    any node) does not declare — stale; a shared line every node overrides (never shown); a section that
    is no node.
    """
    params = node_params() if params is None else params
    problems = []
    for node, specs in params.items():
        for spec in specs:
            if not note_for(notes, node, spec.name):
                problems.append(f"{node}: parameter {spec.name} has no doc line in docs/{NOTES_FILE}")
    everyone = {spec.name for specs in params.values() for spec in specs}
    for section, body in notes.items():
        if section != SHARED and section not in params:
            problems.append(f"docs/{NOTES_FILE}: section {section!r} is no node (nodes: {', '.join(params)})")
            continue
        declared = everyone if section == SHARED else {spec.name for spec in params[section]}
        for name in body:
            if name not in declared:
                problems.append(f"docs/{NOTES_FILE}: {section}: {name} is no parameter of "
                                f"{'any node' if section == SHARED else section} (stale doc line)")
            elif section == SHARED and all(name in notes.get(node, {}) for node, specs in params.items()
                                           if any(spec.name == name for spec in specs)):
                problems.append(f"docs/{NOTES_FILE}: {SHARED}: {name} has a line of its own on every node that "
                                "declares it (this one is never shown)")
    return problems


def type_name(default) -> str:
    """The ROS parameter type of a default value (what ``ros2 param describe`` calls it)."""
    if isinstance(default, bool):
        return "bool"
    if isinstance(default, int):
        return "integer"
    if isinstance(default, float):
        return "double"
    if isinstance(default, str):
        return "string"
    return "double array"


def default_text(default) -> str:
    """A default as it would be written in a params file."""
    if isinstance(default, bool):
        return "true" if default else "false"
    if isinstance(default, str):
        return f'"{default}"'
    if isinstance(default, (list, tuple)):
        return "[" + ", ".join(default_text(v) for v in default) + "]"
    return repr(default)


def _number(value) -> str:
    """A bound as people write it: 0.1, 3600, 1e6, 2147483647."""
    if isinstance(value, float):
        return f"{value:g}".replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")
    return str(value)


def allowed_text(spec) -> str:
    """What values are allowed, for people: a range, the choices, a string's form, or nothing."""
    if spec.choices is not None:
        return "one of " + ", ".join(default_text(c) for c in spec.choices)
    if spec.low is not None and spec.high is not None:
        span = f"{_number(spec.low)} … {_number(spec.high)}"
        if isinstance(spec.default, (list, tuple)):
            return f"at most {spec.max_length} elements, each {span}"
        return span
    return spec.constraints


def anchor(node: str, name: str) -> str:
    """The target name of a parameter's entry (unique across nodes)."""
    return f"param-{node}-{name}"


def _parse_inline(directive: SphinxDirective, text: str) -> list[nodes.Node]:
    """``text`` (the page's markup: Markdown on a MyST page) parsed as body elements."""
    container = nodes.container()
    directive.state.nested_parse(StringList([text], source=NOTES_FILE), directive.content_offset, container)
    return list(container.children)


def _table(header: list[str], rows: list[list[nodes.Node]], widths: list[int]) -> nodes.table:
    table = nodes.table(classes=["pmv-parameters"])
    group = nodes.tgroup(cols=len(header))
    table += group
    group += [nodes.colspec(colwidth=w) for w in widths]
    head = nodes.thead()
    head += nodes.row("", *(nodes.entry("", nodes.paragraph(text=h)) for h in header))
    body = nodes.tbody()
    for cells in rows:
        body += nodes.row("", *(nodes.entry("", nodes.paragraph("", "", cell)) for cell in cells))
    group += [head, body]
    return table


class ParametersDirective(SphinxDirective):
    """``{pmv-parameters} NODE``: the generated reference of one node's parameters."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        node = self.arguments[0]
        params = node_params()
        if node not in params:
            raise self.error(f"{node} is no node (nodes: {', '.join(params)})")
        notes_path = Path(self.env.srcdir) / NOTES_FILE
        notes = load_notes(notes_path)
        self._depend_on_sources(notes_path)
        first_node = next(iter(params))
        for problem in note_problems(notes, params):
            # A missing doc line on its node's page; a stale one (about the notes file) once, on the first node's.
            if problem.startswith(f"{node}:") or (node == first_node and problem.startswith("docs/")):
                logger.warning(problem, location=self.get_location())
        specs = params[node]
        rows, items = [], nodes.definition_list(classes=["pmv-parameters"])
        for spec in sorted(specs, key=lambda s: s.name):
            label = anchor(node, spec.name)
            target = nodes.target("", "", ids=[nodes.make_id(label)], names=[nodes.fully_normalize_name(label)])
            self.state.document.note_explicit_target(target)
            link = nodes.reference("", "", nodes.literal(text=spec.name), refid=nodes.make_id(label))
            rows.append([link, nodes.Text(type_name(spec.default)), nodes.literal(text=default_text(spec.default)),
                         nodes.Text(spec.unit), nodes.Text(allowed_text(spec)),
                         nodes.Text("read-only" if spec.read_only else "")])
            # type, default (a literal: no typographic quotes), unit, allowed values, read-only or dynamic
            facts = [nodes.emphasis(text=type_name(spec.default)), nodes.Text("; default "),
                     nodes.literal(text=default_text(spec.default))]
            tail = (f" {spec.unit}" if spec.unit else "") + (f"; {allowed_text(spec)}" if allowed_text(spec) else "")
            tail += "; read-only while the node runs." if spec.read_only else "; dynamic."
            facts.append(nodes.Text(tail))
            item = nodes.definition_list_item()
            item += nodes.term("", "", target, nodes.literal(text=spec.name))
            definition = nodes.definition()
            definition += nodes.paragraph("", "", *facts)
            definition += nodes.paragraph(text=spec.description[:1].upper() + spec.description[1:] + ".")
            definition += _parse_inline(self, note_for(notes, node, spec.name) or "")
            item += definition
            items += item
        summary = _table(["parameter", "type", "default", "unit", "allowed", ""], rows, [28, 9, 16, 8, 28, 9])
        return [summary, items]

    def _depend_on_sources(self, notes_path: Path) -> None:
        """Re-read this page whenever the notes or any pmv_ros module the specs come from changes."""
        self.env.note_dependency(str(notes_path))
        for name, module in list(sys.modules.items()):
            source = getattr(module, "__file__", None)
            if name.startswith("pmv_ros.") and source and source.endswith(".py"):
                self.env.note_dependency(source)


class ParamRole(SphinxRole):
    """``{param}`NODE:NAME``` / ``{param}`NAME```: a link to a parameter's entry (the first node declaring it)."""

    def run(self):
        text = self.text.strip()
        params = node_params()
        node, _, name = text.rpartition(":")
        if not node:
            node = next((n for n, specs in params.items() if any(s.name == name for s in specs)), "")
        if node not in params or not any(s.name == name for s in params[node]):
            message = self.inliner.reporter.warning(f"{text}: no node declares this parameter", line=self.lineno)
            return [nodes.literal(text=name)], [message]
        from sphinx.addnodes import pending_xref

        reference = pending_xref("", nodes.literal(text=name), refdomain="std", reftype="ref",
                                 reftarget=nodes.fully_normalize_name(anchor(node, name)), refexplicit=True,
                                 refwarn=True)
        return [reference], []


def setup(app):
    app.add_directive("pmv-parameters", ParametersDirective)
    app.add_role("param", ParamRole())
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
