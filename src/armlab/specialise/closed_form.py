"""Robot-specialised dynamics: a robot's closed form, generated once, compiled and cached.

A general recursive algorithm pays for its generality at every call: it loops over joints,
multiplies by zeros and ones of the joint geometry and reads the robot's numbers from memory.
Code written out for one robot, with its numbers in the formulas, is several times faster.
This module makes it available to compiled code with the signatures of the model-and-data
kernels of ``armlab.kernels.plant``:

    inverse_dynamics(model, data, q, qd, qdd, tau_out)             τ of (D1), h_e = 0
    forward_dynamics(model, data, q, qd, tau, h_e, qdd_out) -> status   q̈ of (D1), (D5)
    kinetic_energy(model, data, q, qd) -> T                         (D6)
    mass_matrix(model, data, q, B_out) -> status                    B(q) (D2)
    checked_inverse_dynamics(model, data, q, qd, qdd, tau_out) -> status   (for calls from Python)

and to Python: ``armlab.inverse_dynamics``, ``inertia_matrix`` and ``forward_dynamics`` take
the same ``dynamics=`` choice (their default is the numeric kernels).

One generator writes such a module, for every size: ``armlab.specialise.traced``, the
numeric RNEA/CRBA kernels partially evaluated for the robot's numbers (straight-line code, the
geometry's zeros and ones folded away).  Its cost is bounded (a fraction of a second of tracing,
then numba's compile).  A second generator, the Lagrange closed form printed from
``armlab.symbolic``, was removed: on the PRP's whole A7 run it was no faster than the traced
module (7.7 against 5.0 ms a 10 s run, measured side by side), and its symbolic derivation is
not bounded (minutes for some 3-joint arms with non-round parameters).

The module is written to the cache directory (folder ``closed_form`` of :func:`cache_dir`:
``ARMLAB_CACHE_DIR``, else the user's cache folder, ``~/.cache/armlab`` on Linux) under a key
made of the robot's numbers and its generator's sources, and numba caches its compile beside
it: the generation (seconds of SymPy for a 3-joint arm, a fraction of a second of tracing for
the Puma560) and the compile (~7 s for the Puma560) happen once per robot and machine.  Every
module, new or found on disk, is checked against the compiled kernels (``armlab.kernels``) at
random states before it is used in a process (relative agreement 1e-9); one that disagrees, or
a robot whose model cannot be generated, falls back to the numeric kernels with the reason in
:func:`closed_form_status` (a simulation records it in ``result.meta["dynamics_fallback"]``).
The module's last line is the SHA-256 of the rest: a module found truncated or edited is
generated again (with a ``CacheWarning``), never imported.  The outcome is kept per process by
the robot's key, never in the robot.

The choice, ``dynamics=``:

* ``"numeric"`` — the general compiled RNEA/CRBA kernels (any robot);
* ``"closed_form"`` — the robot's generated module, made now if it is not on disk yet, or an
  error saying why it is not available;
* ``"auto"`` (the simulator's default) — the robot's generated module if it is on disk already
  (made by an earlier ``"closed_form"`` request; importing and checking it takes a fraction of
  a second), else at once the numeric kernels: the default never starts a derivation.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import sys
import tempfile
import threading
import warnings
import weakref
from pathlib import Path

import numpy as np

from armlab.errors import CacheWarning, ClosedFormUnavailable
from armlab.files import check_writable_folder, write_text
from armlab.kernels.boundary import NativeFunction
from armlab.kernels.dynamics import kernel, make_workspace, rnea_into
from armlab.kernels.plant import INVERSE_DYNAMICS, forward_dynamics_packed, kinetic_energy_packed, rnea_packed
from armlab.kernels.workspace import no_wrench_of
from armlab.model.robot import Robot

# Beyond this many joints no module is generated: generating and compiling the traced code
# grows as n³ (about 2 min and 0.5 GB at 30 joints, 15 min and 2 GB at 60), while the numeric
# kernels serve any size at once.
CLOSED_FORM_MAX_JOINTS = 24
DYNAMICS_CHOICES = ("auto", "closed_form", "numeric")
# The outcome for each robot key met in this process: its checked module, or why there is none.
_OUTCOMES: dict = {}
_LOCK = threading.Lock()
_GENERATED_LOCK = threading.Lock()
# A closed-form module's inverse dynamics as a law's compiled function, by module name.
_FUNCTIONS: dict = {}
# Each robot's key, for as long as the robot lives (a robot hashes by identity).
_KEYS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_KEYS_LOCK = threading.Lock()
_PACKAGE = Path(__file__).resolve().parents[1]            # armlab/


def choice_problem(dynamics) -> str:
    """What is wrong with a ``dynamics`` choice ('' if it is one of ``DYNAMICS_CHOICES``); each
    caller names the field in its own error class."""
    if dynamics in DYNAMICS_CHOICES:
        return ""
    return f"{dynamics!r} is not one of {', '.join(DYNAMICS_CHOICES)}"


def cache_dir() -> Path:
    """armlab's cache folder, the one place its path is decided: generated modules (and their
    numba caches) in ``closed_form``, the report's derivations in ``report``.
    ``ARMLAB_CACHE_DIR`` if set, else the platform's user cache folder of armlab
    (``platformdirs``: ``$XDG_CACHE_HOME/armlab`` or ``~/.cache/armlab`` on Linux,
    ``~/Library/Caches/armlab`` on macOS, ``%LOCALAPPDATA%\\armlab\\Cache`` on Windows)."""
    root = os.environ.get("ARMLAB_CACHE_DIR")
    if root:
        return Path(root)
    from platformdirs import user_cache_path  # here: `import armlab` loads none of it

    return user_cache_path("armlab", appauthor=False)


@functools.cache
def _sources_digest() -> bytes:
    """Hash of the sources the generated code depends on: the traced generator and the kernels
    it evaluates (read, not imported)."""
    digest = hashlib.sha256(b"traced")
    for path in (_PACKAGE / "specialise" / "traced.py", _PACKAGE / "kernels" / "dynamics.py"):
        digest.update(path.read_bytes())
    return digest.digest()


def robot_key(robot: Robot) -> str:
    """Hash of everything a robot's generated code depends on: its numbers, its file's
    expressions and the sources of its generator.  Each simulation asks for it twice (~0.1 ms
    each to compute): a robot's key is kept beside it, in a weak map, until the robot is gone
    (nothing is written into the robot)."""
    key = _KEYS.get(robot)
    if key is None:
        key = _robot_key(robot)
        with _KEYS_LOCK:
            _KEYS[robot] = key
    return key


def _robot_key(robot: Robot) -> str:
    digest = hashlib.sha256()
    for name, value in zip(robot.arrays._fields, robot.arrays, strict=True):
        digest.update(name.encode())
        digest.update(np.ascontiguousarray(value).tobytes())
    digest.update(repr(robot.spec).encode() if getattr(robot, "spec", None) is not None else b"")
    digest.update(_sources_digest())
    return digest.hexdigest()[:20]


def _module_name(key: str) -> str:
    return f"armlab_closed_form_{key}"


def _private_folder(kind: str = "closed_form") -> Path:
    """The folder of this user's in the temporary directory used when the cache folder of
    ``kind`` is not writable."""
    return Path(tempfile.gettempdir()) / f"armlab-{kind.replace('_', '-')}-{os.getuid()}"


def _is_private(folder: Path) -> bool:
    """Only this user may write into ``folder`` (code is imported from it)."""
    info = folder.stat()
    return info.st_uid == os.getuid() and not info.st_mode & 0o022


def _on_disk(key: str) -> Path | None:
    """The robot's generated module if it has been written already (nothing is created)."""
    return _on_disk_named(f"{_module_name(key)}.py")


def _on_disk_named(name: str, kind: str = "closed_form") -> Path | None:
    """The generated file ``name`` in the cache folder of ``kind`` or this user's private one,
    if it exists."""
    path = cache_dir() / kind / name
    if path.is_file():
        return path
    private = _private_folder(kind)
    if (private / name).is_file() and _is_private(private):
        return private / name
    return None


def _writable_folder(kind: str = "closed_form") -> Path:
    """``cache_dir()/kind``, or a private folder of this user's in the temporary
    directory when that is not writable (code is imported from it: nobody else may write)."""
    folder = cache_dir() / kind
    try:
        folder.mkdir(parents=True, exist_ok=True)
        check_writable_folder(folder)          # leaves nothing behind
    except OSError as error:
        warnings.warn(f"{folder}: cache folder cannot be written ({error.strerror or error}); "
                      f"using {_private_folder(kind)}", CacheWarning, stacklevel=4)
        folder = _private_folder(kind)
        folder.mkdir(mode=0o700, exist_ok=True)
        if not _is_private(folder):
            raise ClosedFormUnavailable(f"{folder}: not a private folder of this user") from None
    return folder


def _generate(robot: Robot, key: str, path: Path) -> None:
    from armlab.specialise.traced import traced_source

    _write_source(path, traced_source(robot, key=key))


def _write_source(path: Path, source: str) -> None:
    """Write a generated module: atomically (parallel processes may generate the same one),
    its last line the digest of the rest, checked before every import (:func:`_intact`)."""
    body = source if source.endswith("\n") else source + "\n"
    write_text(path, body + _digest_line(body))


_DIGEST = "# armlab-source-sha256: "


def _digest_line(body: str) -> str:
    return f"{_DIGEST}{hashlib.sha256(body.encode('utf-8')).hexdigest()}\n"


def _intact(path: Path) -> bool:
    """Whether the module at ``path`` is complete and unchanged since it was generated: its
    last line is the SHA-256 of everything before it (a truncated or damaged file is not)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    head, _, last = text[:-1].rpartition("\n")
    body = head + "\n"
    return text.endswith("\n") and text == body + _digest_line(body) and last.startswith(_DIGEST)


def _import(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def generated_module(name: str, source: str, kind: str):
    """The generated module ``name`` holding ``source`` (its numba caches beside it), imported
    from the cache folder of ``kind`` (``cache_dir() / kind``); written there first, atomically
    and with its digest line, when it is missing or damaged.  ``name`` must say what ``source``
    depends on (a hash of it): a module on disk under that name is taken as it is.  For other
    generated code than a robot's (the law entries of ``armlab.control.entry``)."""
    if name in sys.modules:
        return sys.modules[name]
    with _GENERATED_LOCK:
        if name in sys.modules:
            return sys.modules[name]
        path = _on_disk_named(f"{name}.py", kind)
        if path is None or not _intact(path):
            path = _writable_folder(kind) / f"{name}.py"
            _write_source(path, source)
        return _import(path, name)


def _verify(robot: Robot, module) -> str:
    """'' if the module's dynamics agree with the compiled RNEA (``armlab.kernels``) at random
    states, else why not.

    Only the RNEA is needed: the inverse dynamics are compared directly, the forward dynamics
    by putting q̈ back into the RNEA (τ = ID(q, q̇, q̈, h_e)), the kinetic energy as
    ½ q̇ᵀ (B q̇) with B q̇ = ID(q, 0, q̇) without gravity, B column by column."""
    n = robot.n
    m, ws = robot.arrays, make_workspace(n)
    no_wrench, zero = np.zeros(6), np.zeros(n)

    def rnea(q, qd, qdd, gravity_scale=1.0, h_e=no_wrench):
        tau = np.zeros(n)
        rnea_into(m, ws, q, qd, qdd, gravity_scale, h_e, tau)
        return tau

    rng = np.random.default_rng(20261122)
    model, data = robot.packed, np.zeros(0)  # ignored by the generated code
    lo = np.where(np.isfinite(robot.arrays.q_min), robot.arrays.q_min, -np.pi)
    hi = np.where(np.isfinite(robot.arrays.q_max), robot.arrays.q_max, np.pi)
    for trial in range(4):
        q = rng.uniform(lo, hi)
        qd, qdd, tau = rng.normal(size=(3, n))
        if trial == 3:
            qd[:] = 0.0  # Coulomb friction's sgn(0) = 0 branch
        h_e = rng.normal(size=6)
        got = np.zeros(n)
        expected = rnea(q, qd, qdd)
        module.inverse_dynamics(model, data, q, qd, qdd, got)
        if not np.allclose(got, expected, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(expected).max())):
            return f"inverse dynamics differ from the numeric kernels at q = {q.tolist()}"
        if module.forward_dynamics(model, data, q, qd, tau, h_e, got) == 0:
            back = rnea(q, qd, got, h_e=h_e)
            if not np.allclose(back, tau, rtol=1e-8, atol=1e-8 * max(1.0, np.abs(back).max())):
                return f"forward dynamics disagree with the numeric RNEA at q = {q.tolist()}"
        energy = 0.5 * float(qd @ rnea(q, zero, qd, gravity_scale=0.0))
        if not np.isclose(module.kinetic_energy(model, data, q, qd), energy, rtol=1e-9, atol=1e-12):
            return f"kinetic energy differs from the numeric kernels at q = {q.tolist()}"
        # Column j of B is the RNEA at q̇ = 0, q̈ = e_j without gravity.
        columns = np.column_stack([rnea(q, zero, e, gravity_scale=0.0) for e in np.eye(n)])
        B = np.zeros((n, n))
        if (module.mass_matrix(model, data, q, B) != 0
                or not np.allclose(B, columns, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(columns).max()))):
            return f"inertia matrix differs from the numeric kernels at q = {q.tolist()}"
        direct, checked = np.zeros(n), np.zeros(n)
        module.inverse_dynamics(model, data, q, qd, qdd, direct)
        if (module.checked_inverse_dynamics(model, data, q, qd, qdd, checked) != 0
                or not np.array_equal(checked, direct)):
            return "the checked inverse dynamics differ from the module's inverse dynamics"
    return ""


def _load(robot: Robot, key: str, path: Path):
    """The module at ``path`` imported and checked (its numba cache lies beside it), or
    :class:`ClosedFormUnavailable`; either outcome is kept for ``key``.  A module that is not
    intact on disk (truncated, edited: :func:`_intact`) is generated again first, with a
    :class:`CacheWarning`, never imported."""
    if not _intact(path):
        warnings.warn(f"{path}: generated module damaged or incomplete; generating it again",
                      CacheWarning, stacklevel=3)
        try:
            path.unlink(missing_ok=True)
            _generate(robot, key, path)
        except Exception as error:  # as for a first generation: say why, fall back
            first_line = (str(error).strip().splitlines() or [""])[0]
            _OUTCOMES[key] = reason = (f"no closed form for robot {robot.name!r}: "
                                       f"{type(error).__name__}: {first_line}")
            raise ClosedFormUnavailable(reason) from None
    try:
        module = _import(path, _module_name(key))
        reason = _verify(robot, module)
    except Exception as error:  # a module that cannot be imported or checked: say so, fall back
        first_line = (str(error).strip().splitlines() or [""])[0]
        reason = f"no closed form for robot {robot.name!r}: {type(error).__name__}: {first_line}"
    if reason:
        _OUTCOMES[key] = reason
        # Gone from disk, so that "auto" does not import and check it again in every process.
        path.unlink(missing_ok=True)
        raise ClosedFormUnavailable(reason)
    _OUTCOMES[key] = module
    return module


def closed_form_module(robot: Robot):
    """The verified, compiled closed-form module of ``robot`` (generated now if it is not on
    disk), or :class:`ClosedFormUnavailable` with the reason.  The outcome is kept for this
    process under the robot's key (:func:`robot_key`), not in the robot."""
    key = robot_key(robot)
    known = _OUTCOMES.get(key)
    if known is None:
        with _LOCK:                         # one generation per robot at a time in a process
            known = _OUTCOMES.get(key)
            if known is None:
                try:
                    path = _on_disk(key)
                    if path is None and robot.n > CLOSED_FORM_MAX_JOINTS:
                        minutes = 2.0 * (robot.n / 30) ** 3
                        raise ClosedFormUnavailable(
                            f"{robot.n} joints, more than the {CLOSED_FORM_MAX_JOINTS} a generated module "
                            f"is made for (it would take about {minutes:.0f} min to generate and compile); "
                            "the numeric kernels (dynamics=\"numeric\") serve any size")
                    if path is None:
                        path = _writable_folder() / f"{_module_name(key)}.py"
                        _generate(robot, key, path)
                except Exception as error:
                    first_line = (str(error).strip().splitlines() or [""])[0]
                    known = _OUTCOMES[key] = (f"no closed form for robot {robot.name!r}: "
                                              f"{type(error).__name__}: {first_line}")
                else:
                    return _load(robot, key, path)
    if isinstance(known, str):
        raise ClosedFormUnavailable(known)
    return known


def cached_module(robot: Robot):
    """``robot``'s checked module if one exists already (in this process or on disk), else
    None; never generates one.  What ``dynamics="auto"`` uses."""
    key = robot_key(robot)
    known = _OUTCOMES.get(key)
    if known is None:
        path = _on_disk(key)
        if path is None:
            return None
        with _LOCK:
            known = _OUTCOMES.get(key)
            if known is None:
                try:
                    return _load(robot, key, path)
                except ClosedFormUnavailable:
                    return None
    return None if isinstance(known, str) else known


def closed_form_status(robot: Robot) -> str:
    """Why ``robot`` has no usable closed form ('' if it has one or was never asked)."""
    known = _OUTCOMES.get(robot_key(robot))
    return known if isinstance(known, str) else ""


def chosen_module(robot: Robot, dynamics: str, field: str = "dynamics"):
    """The generated module ``dynamics`` chooses for ``robot``, or None for the numeric kernels
    (``ClosedFormUnavailable`` for an unknown choice, or for "closed_form" without one)."""
    problem = choice_problem(dynamics)
    if problem:
        raise ClosedFormUnavailable(f"{field}: {problem}")
    if dynamics == "numeric":
        return None
    if dynamics == "auto":
        return cached_module(robot)
    return closed_form_module(robot)


def plant_kernels(robot: Robot, dynamics: str = "auto", field: str = "dynamics"):
    """(kind, forward_dynamics, kinetic_energy) of ``robot`` for the simulation loop: kind is
    "closed_form" or "numeric", the kernels have the signatures of
    ``armlab.kernels.plant.forward_dynamics_packed`` and ``kinetic_energy_packed``."""
    module = chosen_module(robot, dynamics, field)
    if module is None:
        return "numeric", forward_dynamics_packed, kinetic_energy_packed
    return "closed_form", module.forward_dynamics, module.kinetic_energy


@kernel
def _numeric_inverse_dynamics(model, data, q, qd, qdd, tau_out):
    """τ of (D1) with h_e = 0 by the plant's own RNEA (``rnea_packed``)."""
    rnea_packed(model, data, q, qd, qdd, 1.0, no_wrench_of(data, int(model[0])), tau_out)


@functools.cache
def numeric_inverse_dynamics():
    """The RNEA's τ of (D1) with h_e = 0 as a compiled function of ``INVERSE_DYNAMICS``
    (compiled, or loaded from numba's cache, on first use).  It calls the plant's own
    ``rnea_packed`` with the workspace's zero wrench (skipped at run time), so a numeric run
    compiles one RNEA for plant and controller (a wrench-free RNEA would be a second, ~4 s
    with empty caches), as ``armlab.inverse_dynamics`` does."""
    return NativeFunction(_numeric_inverse_dynamics, INVERSE_DYNAMICS)


def inverse_dynamics_function(robot: Robot, dynamics: str = "auto", field: str = "dynamics"):
    """``robot``'s inverse dynamics as the compiled function a law holds, of the signature
    ``armlab.kernels.plant.INVERSE_DYNAMICS``: its closed form's or the RNEA's kernel as a
    :class:`~armlab.kernels.boundary.NativeFunction`, which the loop calls in numba's own
    convention (a ``cfunc``'s C wrapper cost the Puma560's 10 s computed-torque run 1.5 ms of
    17.5).

    A law calls it by its field's name (``params.inverse_dynamics(model, data, q, qd, y, tau)``)
    and compiles once for every robot and both kinds: all share one numba type, where a
    compiled dispatcher in the params would make the law compile per robot and never load from
    numba's disk cache (measured: a cache miss on every run of a fresh process)."""
    module = chosen_module(robot, dynamics, field)
    if module is None:
        return numeric_inverse_dynamics()
    with _GENERATED_LOCK:
        function = _FUNCTIONS.get(module.__name__)
        if function is None:
            function = _FUNCTIONS[module.__name__] = NativeFunction(module.inverse_dynamics, INVERSE_DYNAMICS)
    return function
