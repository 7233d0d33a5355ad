"""Reading the input files armlab is given (robots, scenarios, URDFs): regular files of a
bounded size only, decoded and parsed with one-line errors.

Files travel between people, so none is trusted: before a byte is read the path must name a
regular file (a FIFO would block the reader forever, a device such as ``/dev/zero`` never
ends, a directory has no text) no larger than the limit of its kind.  The limits are far above
any real robot or scenario file and are documented in ``docs/robot-files.md`` and
``docs/scenario-files.md``.  Every problem raises the caller's :class:`FileFieldError`
subclass as ``<file>: file: <what is wrong>`` (or ``<file>: syntax: …`` for TOML syntax).
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path

from armlab.errors import FileFieldError

TOML_LIMIT = 2 * 1024 * 1024
"""Largest robot or scenario TOML file read [bytes] (2 MiB)."""

URDF_LIMIT = 16 * 1024 * 1024
"""Largest URDF file read [bytes] (16 MiB)."""

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def file_kind(mode: int) -> str:
    """What a path of ``st_mode`` ``mode`` is, when it is not a regular file ("a FIFO (named pipe)")."""
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def size_text(count: int) -> str:
    """A byte count as people read it ("3.0 MiB", "512 bytes")."""
    return f"{count / (1024 * 1024):.1f} MiB" if count >= 1024 * 1024 else f"{count} bytes"


def read_input_bytes(path, error: type[FileFieldError], limit: int) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them.

    A path that is not a regular file (after following symbolic links) or holds more than
    ``limit`` bytes raises ``error(path, "file", reason)`` without reading it.  The file is
    opened without blocking and checked again once open, so a FIFO swapped in after the first
    check cannot stall the reader, and at most ``limit + 1`` bytes are ever read.
    """
    path = Path(path)

    def refuse(reason: str):
        raise error(path, "file", reason)

    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        mode = os.stat(path).st_mode
        fd = os.open(path, flags) if stat.S_ISREG(mode) else None
    except OSError as problem:
        refuse(f"cannot be read ({problem.strerror or problem})")
    except ValueError:  # a NUL character in the path
        refuse("cannot be read (the path contains a NUL character)")
    if fd is None:
        refuse(f"is {file_kind(mode)}, not a regular file")
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            refuse(f"is {file_kind(info.st_mode)}, not a regular file")
        if info.st_size > limit:
            refuse(f"is {size_text(info.st_size)}, more than the {size_text(limit)} read at most")
        with os.fdopen(os.dup(fd), "rb") as stream:
            data = stream.read(limit + 1)
    except OSError as problem:
        refuse(f"cannot be read ({problem.strerror or problem})")
    finally:
        os.close(fd)
    if len(data) > limit:
        refuse(f"is more than the {size_text(limit)} read at most")
    return data


def read_input_text(path, error: type[FileFieldError], limit: int) -> str:
    """:func:`read_input_bytes` decoded as UTF-8 (``file: is not UTF-8 text`` otherwise)."""
    data = read_input_bytes(path, error, limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(path, "file", "is not UTF-8 text") from None


def read_input_toml(path, error: type[FileFieldError], limit: int = TOML_LIMIT) -> dict:
    """The parsed TOML of the input file ``path``.

    Besides syntax errors, ``tomllib`` lets some valid-looking text escape as other exceptions:
    an integer of more than 4300 digits (``ValueError``), arrays nested a thousand deep
    (``RecursionError``); each becomes ``<file>: syntax: <reason>``.
    """
    text = read_input_text(path, error, limit)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as problem:
        raise error(path, "syntax", str(problem)) from None
    except RecursionError:
        raise error(path, "syntax", "arrays or tables nested too deeply") from None
    except (ValueError, MemoryError) as problem:
        raise error(path, "syntax", str(problem) or type(problem).__name__) from None
