"""Every file an MJCF model names, found and checked before MuJoCo's compiler opens any of them.

MuJoCo reads the main file, then its ``<include file>`` (recursively), ``<model file>`` and every
asset: ``<mesh file>``, ``<texture file fileright … filedown>``, ``<hfield file>``,
``<skin file>``.  :func:`check_mjcf_files` reads the main file and each included one itself
(:func:`armlab.inputs.read_input_bytes`: a regular UTF-8 file of at most
:data:`~armlab.model.references.XML_LIMIT` bytes), parses it with ``expat`` (no document type
declaration, so no entity is expanded or loaded), and checks every attribute whose name starts
with ``file`` on any element against the rule of :mod:`armlab.model.references` (R1).

MuJoCo looks a name up in several places: an include relative to the including file's folder
and to the main file's, an asset under ``<compiler meshdir texturedir assetdir>`` or the model's
folder, and only by its last part with ``<compiler strippath="true">``.  Rather than mirror
which one it takes, every such candidate path is checked: each must lie under the robot file's
folder and, when it exists, be a regular file within the size limit.
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.parsers import expat

from armlab.errors import RobotFileError
from armlab.inputs import read_input_bytes
from armlab.model.references import ASSET_LIMIT, OUTSIDE_HINT, XML_LIMIT, check_reference, folder_of, is_under

MAX_FILES = 1000
"""Most MJCF files (the main one and its includes) one model may read."""

MAX_REFERENCES = 100_000
"""Most file names (assets and includes) one model may hold."""

_DIRECTORIES = ("meshdir", "texturedir", "assetdir")
_NESTED = ("include", "model")  # elements whose file is MJCF, scanned in turn


class _Scan:
    """expat handlers: collect the file attributes and compiler folders of one MJCF file."""

    def __init__(self, path: Path):
        self.path = path
        self.stack: list[str] = []
        self.references: list[tuple[str, str, str]] = []   # (field, tag, name)
        self.directories: list[str] = []
        self.strip = False

    def doctype(self, *_):
        raise RobotFileError(self.path, "xml", "a document type declaration (<!DOCTYPE>) is not "
                                               "allowed in an MJCF file (no entity is ever loaded)")

    def start(self, tag: str, attributes: dict):
        self.stack.append(tag)
        if tag == "compiler":
            self.directories += [attributes[key] for key in _DIRECTORIES if attributes.get(key)]
            self.strip = self.strip or attributes.get("strippath", "").strip().lower() == "true"
        for key, value in attributes.items():
            if key.startswith("file") and value:
                self.references.append((f"{'.'.join(self.stack[-3:])}.{key}", tag, value))
        if len(self.references) > MAX_REFERENCES:
            raise RobotFileError(self.path, "mjcf", f"names more than {MAX_REFERENCES} files")

    def end(self, _tag: str):
        self.stack.pop()


def _scan(path: Path) -> _Scan:
    data = read_input_bytes(path, RobotFileError, XML_LIMIT)
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        raise RobotFileError(path, "file", "is not UTF-8 text") from None
    scan = _Scan(path)
    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    parser.StartDoctypeDeclHandler = scan.doctype
    parser.StartElementHandler = scan.start
    parser.EndElementHandler = scan.end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as error:
        raise RobotFileError(path, "xml", f"not well-formed XML ({expat.ErrorString(error.code)}: "
                                          f"line {error.lineno}, column {error.offset})") from None
    return scan


def _candidates(name: str, bases, prefixes, strip: bool) -> list[Path]:
    """The paths MuJoCo may open for ``name``: absolute as it is, else under each prefix folder
    (absolute, or relative to a base) of each base folder, and by its last part if ``strip``."""
    names = [name] + ([os.path.basename(name)] if strip and os.path.basename(name) != name else [])
    found = []
    for text in names:
        if os.path.isabs(text):
            found.append(Path(text))
            continue
        for base in bases:
            for prefix in prefixes:
                folder = Path(prefix) if os.path.isabs(prefix) else base / prefix
                found.append(folder / text)
    return list(dict.fromkeys(found))


def check_mjcf_files(path, *, allow_outside: bool = False) -> None:
    """Check the MJCF file ``path`` and every file it names, as the module docstring says;
    raises :class:`RobotFileError` naming the file and the attribute (``mesh.file``) otherwise."""
    path = Path(path)
    folder = folder_of(path)
    main_folder = Path(os.path.abspath(path)).parent
    pending, scans, seen = [path], [], set()
    while pending:
        current = pending.pop()
        key = os.path.realpath(current)
        if key in seen:
            continue
        seen.add(key)
        if len(seen) > MAX_FILES:
            raise RobotFileError(path, "include", f"more than {MAX_FILES} MJCF files")
        scan = _scan(current)
        scans.append(scan)
        bases = list(dict.fromkeys([Path(os.path.abspath(current)).parent, main_folder]))
        for field, tag, name in scan.references:
            if tag not in _NESTED:
                continue
            for candidate in _candidates(name, bases, [""], False):
                check_reference(current, field, name, candidate, XML_LIMIT, folder, allow_outside)
                if candidate.is_file():
                    pending.append(candidate)
    # Compiler folders may be set in any of the files; each applies to the whole model.
    directories = [""] + [d for scan in scans for d in scan.directories]
    strip = any(scan.strip for scan in scans)
    for scan in scans:
        bases = list(dict.fromkeys([Path(os.path.abspath(scan.path)).parent, main_folder]))
        for directory in directories[1:]:
            target = Path(directory) if os.path.isabs(directory) else main_folder / directory
            if not allow_outside and not is_under(target, folder):
                raise RobotFileError(scan.path, "compiler", f"folder {directory!r} lies outside the "
                                     f"robot file's folder ({OUTSIDE_HINT})")
        for field, tag, name in scan.references:
            if tag in _NESTED:
                continue
            for candidate in _candidates(name, bases, directories, strip):
                check_reference(scan.path, field, name, candidate, ASSET_LIMIT, folder, allow_outside)

