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
    name = os.fsdecode(path) if isinstance(path, (bytes, os.PathLike)) else str(path)
    try:
        info = os.stat(name)
    except OSError as error:
        raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    _check_regular(info, name, what, max_bytes)
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        descriptor = os.open(name, flags)
    except OSError as error:
        raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    try:
        _check_regular(os.fstat(descriptor), name, what, max_bytes)
        chunks, size = [], 0
        while size <= max_bytes:
            chunk = os.read(descriptor, max_bytes + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as error:
        raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    finally:
        os.close(descriptor)
    data = b"".join(chunks)
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
