"""Damaged compile caches are found, discarded and rebuilt, never trusted.

numba keeps each compiled kernel of armlab (``cache=True``) in a pair of files: an index
``<module>.<function>-<line>.py<ver>.nbi`` and data ``….<k>.nbc``, in the ``__pycache__``
folder beside the source (or under ``NUMBA_CACHE_DIR``); the generated dynamics modules of
``armlab.specialise`` keep theirs beside them in armlab's cache folder.  numba writes them
atomically, but a file damaged afterwards (a truncated copy, a full disk during a backup, a
bad sector) makes every later load of that kernel fail deep inside numba (an
``UnpicklingError`` or ``EOFError``), run after run, until someone deletes the file by hand.

:func:`repaired` runs a piece of work and, if it fails inside numba's cache loader
(recognised by the traceback passing through ``numba/core/caching.py``, no private names),
checks every cache file of armlab, deletes the damaged ones with one :class:`CacheWarning`
naming them, and runs the work once more: numba then compiles those kernels again and writes
fresh files.  A file is damaged when it is not what numba writes: an ``.nbc`` is one pickle,
an ``.nbi`` two (numba's version, then the index), read here with ``pickletools.genops``,
which parses the opcodes without building or running anything.  If the loader failed and no
file looks damaged, every armlab cache file is discarded (they are rebuilt the same way).
A failure to *write* the cache (a full or read-only disk) is not a damaged file: it is
reported as it is.
"""

from __future__ import annotations

import io
import os
import pickletools
import warnings
from pathlib import Path

from armlab.errors import CacheWarning

_PACKAGE = Path(__file__).resolve().parent
_SUFFIXES = (".nbi", ".nbc")


def _numba_frames(error: BaseException) -> bool:
    traceback = error.__traceback__
    while traceback is not None:
        name = traceback.tb_frame.f_code.co_filename.replace(os.sep, "/")
        if name.endswith("numba/core/caching.py"):
            return True
        traceback = traceback.tb_next
    return False


def is_cache_fault(error: BaseException) -> bool:
    """Whether ``error`` was raised while numba *read* a cache file (a damaged entry)."""
    if not isinstance(error, Exception) or not _numba_frames(error):
        return False
    # Writing needs space and permission: a damaged file is not the cause, deleting would not help.
    return not isinstance(error, OSError) or isinstance(error, FileNotFoundError)


def cache_folders() -> list[Path]:
    """Folders that may hold numba cache files of armlab's kernels and generated modules."""
    from armlab.specialise.closed_form import _private_folder, cache_dir

    folders = [_PACKAGE, cache_dir() / "closed_form", _private_folder()]
    numba_dir = os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir:
        folders.append(Path(numba_dir))
    return [folder for folder in folders if folder.is_dir()]


def cache_files() -> list[Path]:
    """The numba cache files of armlab (under ``NUMBA_CACHE_DIR``, those of paths naming armlab)."""
    files = []
    numba_dir = os.environ.get("NUMBA_CACHE_DIR")
    for folder in cache_folders():
        shared = numba_dir is not None and folder == Path(numba_dir)
        files += [path for path in folder.rglob("*.nb[ic]")
                  if path.suffix in _SUFFIXES and (not shared or "armlab" in str(path))]
    return files


def _pickles(data: bytes) -> int:
    """How many complete pickles ``data`` holds end to end; ValueError if it ends inside one."""
    stream, count = io.BytesIO(data), 0
    while stream.tell() < len(data):
        for _ in pickletools.genops(stream):
            pass
        count += 1
    return count


def is_damaged(path: Path) -> bool:
    """Whether the cache file ``path`` is not what numba writes (see the module)."""
    try:
        data = path.read_bytes()
        return _pickles(data) != (2 if path.suffix == ".nbi" else 1)
    except FileNotFoundError:
        return False
    except (OSError, ValueError, EOFError, IndexError, UnicodeDecodeError):
        return True


def discard_damaged(everything: bool = False) -> list[Path]:
    """Delete the damaged cache files of armlab (all of them with ``everything``); returns
    those deleted."""
    removed = []
    for path in cache_files():
        if everything or is_damaged(path):
            try:
                path.unlink()
            except FileNotFoundError:
                continue
            except OSError:
                continue          # cannot delete: numba will fail on it again and say so
            removed.append(path)
    return removed


def repaired(work, *args, **kwargs):
    """``work(*args, **kwargs)``; if it fails on a damaged numba cache entry, the damaged
    entries are discarded (one :class:`CacheWarning`) and ``work`` runs once more."""
    try:
        return work(*args, **kwargs)
    except Exception as error:
        if not is_cache_fault(error):
            raise
        removed = discard_damaged() or discard_damaged(everything=True)
        if not removed:
            raise
        names = ", ".join(path.name for path in removed[:4]) + (" …" if len(removed) > 4 else "")
        warnings.warn(f"damaged compile cache ({type(error).__name__}): discarded {len(removed)} "
                      f"file(s) ({names}); compiling again", CacheWarning, stacklevel=2)
    return work(*args, **kwargs)
