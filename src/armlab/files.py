"""Atomic file writes: every file armlab writes appears complete or not at all.

Contract of :func:`replacing` (and of :func:`write_text`, :func:`write_bytes`, :func:`open_atomic`
built on it): the content goes to a temporary file of a unique name in the target's folder,
is flushed to disk (``fsync``) and renamed onto the target (``os.replace``, atomic on POSIX and
Windows within one file system).  Hence

* a reader sees the old file or the new one, never a mixture or a truncated file;
* concurrent writers of one target never corrupt it: the last complete write wins;
* a failure (full disk, read-only folder, an exception of the writer, Ctrl-C) removes the
  temporary file and raises the original error, an ``OSError`` naming the *target* file;
  a failure of that clean-up never hides it.

Temporary files are named ``.armlab-tmp.<pid>.<random>.<target name>``: hidden, recognisable,
and with the target's suffix (tools that choose a format by suffix still work).  A writer
killed outright (``kill -9``, power loss) cannot remove its own; the next write into the same
folder removes those whose process no longer runs on this machine (a temporary file of a live
writer is never touched).
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path

PREFIX = ".armlab-tmp."


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True            # exists (another user's process) or cannot tell: keep it
    return True


def sweep(folder: str | Path) -> list[Path]:
    """Remove the temporary files that dead writers left in ``folder``; returns them."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(PREFIX):
            continue
        pid = entry.name[len(PREFIX):].split(".", 1)[0]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        with contextlib.suppress(OSError):
            os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


def _target_error(error: OSError, path: Path) -> OSError:
    """``error`` as an OSError naming ``path`` (the temporary name means nothing to a user)."""
    if error.errno is None:
        return error
    named = OSError(error.errno, error.strerror or str(error), str(path))
    named.__cause__ = error
    return named


def _fsync(path, directory: bool = False) -> None:
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        if directory:
            return             # some systems cannot open a folder: the rename is still atomic
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not directory:
            raise
    finally:
        os.close(fd)


@contextlib.contextmanager
def replacing(path: str | Path):
    """Yield the :class:`Path` of a new empty temporary file beside ``path``; when the block
    ends without an exception it is synced and renamed onto ``path`` (see the module)."""
    path = Path(path)
    folder = path.parent
    sweep(folder)
    while True:
        temporary = folder / f"{PREFIX}{os.getpid()}.{secrets.token_hex(6)}.{path.name}"
        try:
            # Created like any new file (mode 0o666 less the umask), unlike mkstemp's 0o600.
            os.close(os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            break
        except FileExistsError:
            continue
        except OSError as error:
            raise _target_error(error, path) from None
    try:
        yield temporary
        _fsync(temporary)
        os.replace(temporary, path)
    except BaseException as error:
        with contextlib.suppress(OSError):
            temporary.unlink()
        if isinstance(error, OSError):
            raise _target_error(error, path) from None
        raise
    _fsync(folder, directory=True)


@contextlib.contextmanager
def open_atomic(path: str | Path, mode: str = "w", encoding: str | None = None, newline=None):
    """``open(path, mode)`` for writing (``"w"`` or ``"wb"``), through :func:`replacing`."""
    if mode not in ("w", "wb"):
        raise ValueError(f"mode: {mode!r} is not 'w' or 'wb'")
    if mode == "w" and encoding is None:
        encoding = "utf-8"
    with replacing(path) as temporary, open(temporary, mode, encoding=encoding, newline=newline) as handle:
        yield handle


def write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with open_atomic(path, "w", encoding=encoding) as handle:
        handle.write(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with open_atomic(path, "wb") as handle:
        handle.write(data)
    return Path(path)


def check_writable_folder(folder: str | Path) -> None:
    """Raise ``OSError`` (naming ``folder``) unless files can be created in ``folder``, or,
    when it does not exist yet, in its nearest existing ancestor; creates nothing that stays.
    For checks before long work whose output goes there (a run, a report)."""
    folder = Path(folder)
    probe = folder
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise NotADirectoryError(20, "exists and is not a directory" if probe == folder
                                 else f"{probe} is not a directory", str(folder))
    temporary = probe / f"{PREFIX}{os.getpid()}.{secrets.token_hex(6)}.write-test"
    try:
        # A real file, not os.access: access() says yes to root on a read-only mount.
        os.close(os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        os.unlink(temporary)
    except OSError as error:
        raise OSError(error.errno, error.strerror or "cannot be written", str(folder)) from None
