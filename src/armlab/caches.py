"""Damaged compile caches are discarded and rebuilt, never trusted.

numba keeps each compiled kernel of armlab (``cache=True``) in a pair of files: an index
``<module>.<function>-<line>.py<ver>.nbi`` and data ``….<k>.nbc``, in the ``__pycache__``
folder beside the source (or under ``NUMBA_CACHE_DIR``); the generated dynamics modules of
``armlab.specialise`` keep theirs beside them in armlab's cache folder.  numba writes them
atomically, but a file damaged afterwards (a truncated copy, a full disk during a backup, a
bad sector) makes every later load of that kernel fail deep inside numba (an
``UnpicklingError`` or ``EOFError``), run after run, until someone deletes the file by hand.

:func:`repaired` runs a piece of work and, if it fails inside numba's cache loader
(recognised by the traceback passing through ``numba/core/caching.py``, no private names),
deletes every cache file of armlab once, with one :class:`CacheWarning`, and runs the work
once more: numba then compiles those kernels again and writes fresh files.  Which file was
damaged does not matter: all of them are rebuilt the same way.
A failure to *write* the cache (a full disk, a read-only or missing folder) is not a damaged
file: the kernel has been compiled and registered in memory before numba tries to save it, so
:func:`repaired` warns once (:class:`CacheWarning`) and runs the work again, as often as there
are kernels to compile (each retry finds the kernels compiled so far in memory): the process
works without a disk cache, and compiles again next time.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from armlab.errors import CacheWarning

_PACKAGE = Path(__file__).resolve().parent
_SUFFIXES = (".nbi", ".nbc")


def _numba_frames(error: BaseException) -> list[str]:
    """Names of the functions of numba's cache module the traceback of ``error`` passes through."""
    names, traceback = [], error.__traceback__
    while traceback is not None:
        code = traceback.tb_frame.f_code
        if code.co_filename.replace(os.sep, "/").endswith("numba/core/caching.py"):
            names.append(code.co_name)
        traceback = traceback.tb_next
    return names


def is_cache_write_fault(error: BaseException) -> bool:
    """Whether ``error`` was raised while numba *saved* a compiled kernel (no space, no
    permission): the kernel itself was compiled and is in memory."""
    return isinstance(error, OSError) and "save_overload" in _numba_frames(error)


def is_cache_fault(error: BaseException) -> bool:
    """Whether ``error`` was raised while numba *read* a cache file (a damaged entry)."""
    if not isinstance(error, Exception) or not _numba_frames(error):
        return False
    # A failure to write is not a damaged file: deleting files would not help.
    return not is_cache_write_fault(error)


def cache_folders() -> list[Path]:
    """Folders that may hold numba cache files of armlab's kernels and generated modules."""
    from armlab.specialise.closed_form import _private_folder, cache_dir

    folders = [_PACKAGE, cache_dir() / "closed_form", _private_folder(), cache_dir() / "law_entries",
               _private_folder("law_entries")]
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


def discard_all() -> list[Path]:
    """Delete every numba cache file of armlab; returns those deleted."""
    removed = []
    for path in cache_files():
        try:
            path.unlink()
        except OSError:
            continue          # gone already, or cannot delete: numba will say so again
        removed.append(path)
    return removed


MAX_RETRIES = 1000
"""Most runs of the work by :func:`repaired` when numba cannot write its cache (one per kernel
compiled in memory; a whole report compiles a few hundred)."""


def repaired(work, *args, **kwargs):
    """``work(*args, **kwargs)``; if it fails on a damaged numba cache entry, armlab's cache
    files are discarded (one :class:`CacheWarning`) and ``work`` runs once more; if it fails
    because numba cannot write its cache, it runs again until every kernel it needs is
    compiled in memory (one :class:`CacheWarning`)."""
    repaired_once, warned = False, False
    for _ in range(MAX_RETRIES):
        try:
            return work(*args, **kwargs)
        except Exception as error:
            if is_cache_write_fault(error):
                if not warned:
                    where = f" ({error.filename})" if error.filename else ""
                    warnings.warn(f"the compile cache cannot be written{where}: "
                                  f"{error.strerror or error}; compiling in memory for this run",
                                  CacheWarning, stacklevel=2)
                    warned = True
                continue
            if repaired_once or not is_cache_fault(error):
                raise
            removed = discard_all()
            if not removed:
                raise
            repaired_once = True
            names = ", ".join(path.name for path in removed[:4]) + (" …" if len(removed) > 4 else "")
            warnings.warn(f"damaged compile cache ({type(error).__name__}): discarded {len(removed)} "
                          f"file(s) ({names}); compiling again", CacheWarning, stacklevel=2)
    return work(*args, **kwargs)
