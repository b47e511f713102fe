"""Bounded reading of the files the package reads: regular files only, never blocking, never unbounded.

Every file a user names (a params file, a correction table, a recording, a
campaign result) is read through this module, so that the bounds live in one
place: a FIFO, a device or a directory is refused before it is opened, a file
larger than its cap is refused before it is read, and a refusal is one line
naming the file and the reason — never its contents.
"""

from __future__ import annotations

import os
import stat

#: Largest file a file-valued parameter may name, bytes (a correction table of 121 rows is ≈ 3 kB).
MAX_PARAMETER_FILE_BYTES = 1 << 20


def read_text_file(path, what: str, max_bytes: int = MAX_PARAMETER_FILE_BYTES) -> str:
    """The text of a regular UTF-8 file of at most ``max_bytes`` bytes; ValueError with a one-line reason.

    Never blocks and never reads more than ``max_bytes + 1`` bytes: the path
    is stat'ed first and must be a regular file (a FIFO, a device, a directory
    or a socket is refused before it is opened), then opened with
    ``O_NONBLOCK`` and checked again on the open descriptor (the name may have
    been swapped in between). A file with a NUL byte or that is not UTF-8 is
    refused as binary. The reason names the file and what is wrong with it —
    never its contents.

    Args:
        path: file name.
        what: what the file is, for the reason ("correction table").
    """
    name = _name(path)
    with open_regular_file(name, what, max_bytes) as stream:
        try:
            data = stream.read(max_bytes + 1)
        except OSError as error:
            raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    if len(data) > max_bytes:
        raise ValueError(f"{what} {name} is larger than the {max_bytes} bytes allowed")
    if b"\0" in data:
        raise ValueError(f"{what} {name} is a binary file, not text")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{what} {name} is not UTF-8 text") from None


def _check_regular(info: os.stat_result, name: str, what: str, max_bytes: int) -> None:
    mode = info.st_mode
    if not stat.S_ISREG(mode):
        kind = ("a directory" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
                else "a socket" if stat.S_ISSOCK(mode) else "not a regular file")
        raise ValueError(f"{what} {name} is {kind}, not a regular file")
    if info.st_size > max_bytes:
        raise ValueError(f"{what} {name} is {info.st_size} bytes, more than the {max_bytes} allowed")


# ----------------------------------------------------------------------------------- structured text

#: Deepest nesting of mappings and lists a YAML or JSON file may have (a params file has 3 or 4 levels).
MAX_NESTING = 64

#: Largest JSON document read (a campaign's ``campaign.json`` is ≈ 2 kB).
MAX_JSON_BYTES = 1 << 20


def parse_yaml(text: str, name: str, what: str, max_depth: int = MAX_NESTING):
    """The YAML document in ``text`` (safe types only); ValueError with a one-line reason.

    Bounded in memory and depth before anything is built: the event stream is
    walked first, and an alias (``*name``: "billion laughs" expands a 1 kB
    file into gigabytes) or a nesting deeper than ``max_depth`` is refused
    there; only then is the document composed.
    """
    import yaml

    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    try:
        depth = 0
        for event in yaml.parse(text, Loader=loader):
            if isinstance(event, yaml.AliasEvent):
                raise ValueError(f"{what} {name}: YAML aliases (*{event.anchor}) are not accepted"
                                 f"{_yaml_line(event)}")
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                depth += 1
                if depth > max_depth:
                    raise ValueError(f"{what} {name}: nested deeper than {max_depth} levels{_yaml_line(event)}")
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                depth -= 1
        return yaml.load(text, Loader=loader)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or type(error).__name__
        raise ValueError(f"{what} {name}: not valid YAML{where} ({problem})") from None


def _yaml_line(event) -> str:
    mark = getattr(event, "start_mark", None)
    return f" (line {mark.line + 1})" if mark is not None else ""


def read_yaml_file(path, what: str, max_bytes: int = MAX_PARAMETER_FILE_BYTES, max_depth: int = MAX_NESTING):
    """:func:`read_text_file`, then :func:`parse_yaml`: the document of a bounded YAML file."""
    return parse_yaml(read_text_file(path, what, max_bytes), _name(path), what, max_depth)


def parse_json(text: str, name: str, what: str, max_depth: int = MAX_NESTING):
    """The JSON document in ``text``; ValueError with a one-line reason.

    NaN and ±Infinity (not JSON) are refused, and so is a nesting deeper than
    ``max_depth`` (checked on the parsed value; the C parser's own recursion
    guard stops a document nested thousands deep before that).
    """
    import json

    def constant(word):
        raise ValueError(f"{what} {name}: {word} is not a JSON number")

    try:
        value = json.loads(text, parse_constant=constant)
    except RecursionError:
        raise ValueError(f"{what} {name}: nested deeper than {max_depth} levels") from None
    except json.JSONDecodeError as error:
        raise ValueError(f"{what} {name}: not valid JSON, line {error.lineno} ({error.msg})") from None
    pending = [(value, 1)]
    while pending:
        item, depth = pending.pop()
        if isinstance(item, (dict, list)):
            if depth > max_depth:
                raise ValueError(f"{what} {name}: nested deeper than {max_depth} levels")
            pending.extend((child, depth + 1) for child in (item.values() if isinstance(item, dict) else item))
    return value


def read_json_file(path, what: str, max_bytes: int = MAX_JSON_BYTES, max_depth: int = MAX_NESTING):
    """:func:`read_text_file`, then :func:`parse_json`: the document of a bounded JSON file."""
    return parse_json(read_text_file(path, what, max_bytes), _name(path), what, max_depth)


def _name(path) -> str:
    return os.fsdecode(path) if isinstance(path, (bytes, os.PathLike)) else str(path)


# ----------------------------------------------------------------------------------- binary files

def check_regular_file(path, what: str, max_bytes: int) -> os.stat_result:
    """The ``stat`` of ``path`` if it is a regular file of at most ``max_bytes``; ValueError otherwise.

    For files another library opens (a recording, a Parquet result): a FIFO
    or a device would block or never end there.
    """
    name = _name(path)
    try:
        info = os.stat(name)
    except OSError as error:
        raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    _check_regular(info, name, what, max_bytes)
    return info


def open_regular_file(path, what: str, max_bytes: int):
    """A binary file object of the regular file ``path`` (at most ``max_bytes``), opened without blocking."""
    name = _name(path)
    check_regular_file(name, what, max_bytes)
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        descriptor = os.open(name, flags)
    except OSError as error:
        raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    try:
        _check_regular(os.fstat(descriptor), name, what, max_bytes)
    except ValueError:
        os.close(descriptor)
        raise
    return os.fdopen(descriptor, "rb")


# ----------------------------------------------------------------------------------- CSV

#: Longest line of a CSV file, characters (a telemetry row is ≈ 60; a field can be no longer than its line).
MAX_CSV_LINE_CHARS = 4096

#: Most data rows read from one CSV file (5.8 days at 1 Hz, 14 h at 10 Hz; ≤ 24 MB of numbers in memory, read in
#: a few seconds). Longer telemetry: a recording (MCAP, read as a stream) or several files.
MAX_CSV_ROWS = 500_000

#: Largest CSV file read, bytes.
MAX_CSV_BYTES = 256 << 20


def iter_csv_blocks(path, what: str, max_bytes: int = MAX_CSV_BYTES, max_line: int = MAX_CSV_LINE_CHARS,
                    max_rows: int = MAX_CSV_ROWS, block_bytes: int = 1 << 20):
    """The rows of a CSV file in blocks: ``(line numbers, rows)`` per block of ≈ ``block_bytes``;
    ValueError on a defect.

    Blank lines and lines starting with ``#`` are skipped; the first row of
    the first block is the header. Memory is one block, whatever the file
    holds: a line longer than ``max_line`` characters (and so any longer
    field), more than ``max_rows`` rows after the header, a file that is not
    UTF-8 text or not a regular file is refused where it is met, naming the
    file and the line. A quoted field cannot span lines.
    """
    import codecs
    import csv

    name = _name(path)
    stream = open_regular_file(name, what, max_bytes)
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    number, rows_seen, pending = 0, 0, ""
    with stream:
        while True:
            data = stream.read(block_bytes)
            try:
                text = pending + decoder.decode(data, final=not data)
            except UnicodeDecodeError:
                raise ValueError(f"{what} {name}, line {number + 1 + pending.count(chr(10))}: not UTF-8 text") from None
            lines = text.split("\n")
            pending = lines.pop() if data else ""
            if len(pending) > max_line:
                raise ValueError(f"{what} {name}, line {number + len(lines) + 1}: longer than {max_line} characters")
            if not lines:
                if not data:
                    return
                continue
            if "\0" in text:
                at = next(i for i, line in enumerate(lines + [pending]) if "\0" in line)
                raise ValueError(f"{what} {name}, line {number + at + 1}: a binary file, not text")
            if max(map(len, lines)) > max_line + 1:  # + 1: a "\r" before the "\n"
                at = next(i for i, line in enumerate(lines) if len(line) > max_line + 1)
                raise ValueError(f"{what} {name}, line {number + at + 1}: longer than {max_line} characters")
            kept = [(number + i + 1, line) for i, line in enumerate(lines)
                    if line.strip() and not line.lstrip().startswith("#")]
            number += len(lines)
            if kept:
                numbers = [n for n, _ in kept]
                try:
                    rows = list(csv.reader([line for _, line in kept], strict=True))
                except csv.Error as error:
                    raise ValueError(f"{what} {name}: not a CSV file ({error})") from None
                if len(rows) != len(kept):
                    raise ValueError(f"{what} {name}, line {numbers[0]}: a quoted field spans lines")
                rows_seen += len(rows)
                if rows_seen > max_rows + 1:
                    raise ValueError(f"{what} {name}: more than {max_rows} data rows")
                yield numbers, rows
            if not data:
                return


def iter_csv_rows(path, what: str, max_bytes: int = MAX_CSV_BYTES, max_line: int = MAX_CSV_LINE_CHARS,
                  max_rows: int = MAX_CSV_ROWS):
    """``(line number, cells)`` of every row of a CSV file, one at a time (:func:`iter_csv_blocks`' bounds)."""
    for numbers, rows in iter_csv_blocks(path, what, max_bytes, max_line, max_rows):
        yield from zip(numbers, rows)
