"""The report's A1–A5 derivations: the robot each assignment is derived for (A4 for the robot's
actuated variant when it has one: :func:`derivation_robots`), its symbolic results
(:func:`derivations`, ``armlab.symbolic.derive``) and their HTML as presentation MathML
(:func:`derivation_html`); and the file that keeps that HTML on disk, named by a digest of every
source it depends on (``_derivation_cache``; :mod:`armlab.viz.report` reads and writes it).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from tqdm import tqdm

from armlab.model.robot import Robot
from armlab.robots import load_robot
from armlab.viz import html


def _derivation_cache(robot: Robot) -> Path:
    """The file that keeps the HTML of ``robot``'s A1–A5 derivations: named by a hash of the
    numbers and expressions of the robots they are derived for (:func:`derivation_robots`),
    of every source the HTML depends on (the symbolic model, its rendering, this page's
    pieces) and of SymPy's version, so that any change derives anew."""
    import hashlib
    from importlib.metadata import version

    from armlab.specialise.closed_form import cache_dir, robot_key

    package = Path(__file__).resolve().parents[1]
    # SymPy's version from its metadata: importing SymPy costs seconds a cached report saves.
    digest = hashlib.sha256(version("sympy").encode())
    for subject in {id(r): r for r in derivation_robots(robot).values()}.values():
        digest.update(robot_key(subject).encode())
    for path in [*sorted((package / "symbolic").glob("*.py")), package / "viz" / "html.py", Path(__file__)]:
        digest.update(path.read_bytes())
    return cache_dir() / "report" / f"derivations_{digest.hexdigest()[:24]}.json"


DERIVATION_BUDGET = {False: 120.0, True: 30.0}
"""Seconds each of A1–A5 may take in a full (False) and in a ``--quick`` (True) report; an
assignment past it keeps what it derived and says what it skipped (``symbolic.derive``)."""


def actuated_variant(robot: Robot) -> Robot | None:
    """The bundled robot ``<name>_actuated`` when it is ``robot`` with motors and friction
    added (:func:`same_arm`: ``prp_actuated`` for ``prp``) and ``robot`` itself has neither;
    else None."""
    from armlab.model.robot import Friction, Motor
    from armlab.robots import bundled_robot_names

    name = f"{robot.name}_actuated"
    if name not in bundled_robot_names() or any(
            j.motor != Motor() or j.friction != Friction() for j in robot.joints):
        return None
    variant = load_robot(name)
    return variant if same_arm(robot, variant) else None


def same_arm(a: Robot, b: Robot) -> bool:
    """Whether ``a`` and ``b`` have the same joints (kinds, P_i, S_i, offsets), links (masses,
    centres of mass, inertia tensors), gravity, base and tool: differ at most in their motors,
    friction, limits and parameters."""
    frames = ("gravity", "base", "tool")
    if a.n != b.n or not all(np.array_equal(getattr(a, f), getattr(b, f)) for f in frames):
        return False
    for i, j in zip(a.joints, b.joints, strict=True):
        if ((i.name, i.kind, i.offset, i.dh) != (j.name, j.kind, j.offset, j.dh)
                or not (np.array_equal(i.before, j.before) and np.array_equal(i.after, j.after))):
            return False
    return all(k.inertial.mass == m.inertial.mass and np.array_equal(k.inertial.com, m.inertial.com)
               and np.array_equal(k.inertial.inertia, m.inertial.inertia)
               for k, m in zip(a.links, b.links, strict=True))


def derivation_robots(robot: Robot) -> dict[str, Robot]:
    """The robot each of A1–A5 is derived for: ``robot``, except A4 for its actuated variant
    (:func:`actuated_variant`) when it has one.  The seed's A4 asks for the Newton–Euler
    equations with the motor and friction terms,

        τ_i = zᵀ μ_i | zᵀ f_i + k_rᵢ I_mᵢ ṡ_i + F_vᵢ q̇_i + F_sᵢ sgn q̇_i                   (N1)

    (``armlab.symbolic.newton_euler``), which a robot without motors and friction reduces to
    its rigid-body part."""
    from armlab.symbolic.sections import ASSIGNMENTS as DERIVED

    robots = dict.fromkeys(DERIVED, robot)
    variant = actuated_variant(robot)
    if variant is not None:
        robots["A4"] = variant
    return robots


class Derivation(NamedTuple):
    """One assignment's symbolic results as the report shows them: the ``section``
    (``symbolic.derive``) of ``robot``, the report's robot or its actuated variant (A4), and
    the symbolic robot ``symbolic`` its expressions are written in."""

    key: str
    robot: Robot
    symbolic: object
    section: object


def derivations(robot: Robot, budget: float | None = None, only=None,
                progress: tqdm | None = None) -> list[Derivation]:
    """The report's A1–A5 (or the keys in ``only``) of ``robot``: A1 in both Σ_0 and Σ_base (as
    the seed does: its transforms, inverse kinematics and Jacobians in each), A2–A5 in Σ_0.
    One symbolic robot serves the assignments of each robot, so later ones reuse B, C, g."""
    from armlab.symbolic import symbolic_robot
    from armlab.symbolic.sections import derive

    robots = derivation_robots(robot)
    symbolic: dict[int, object] = {}
    out = []
    for key, subject in robots.items():
        if only is not None and key not in only:
            continue
        if progress is not None:
            progress.set_postfix_str(f"deriving {key}" + ("" if subject is robot else f" for {subject.name}"))
        if id(subject) not in symbolic:
            symbolic[id(subject)] = symbolic_robot(subject)
        sr = symbolic[id(subject)]
        (section,) = derive(sr, frame="base" if key == "A1" else "0", only=key, budget=budget)
        out.append(Derivation(key, subject, sr, section))
        if progress is not None:
            progress.update()
    return out


def derivation_html(derivation: Derivation, robot: Robot) -> str:
    """HTML of one derivation in the report of ``robot``: its heading (naming the robot it is
    derived for when that is not ``robot``), each result as presentation MathML, its notes."""
    from armlab.symbolic.render import to_mathml

    section, subject = derivation.section, derivation.robot
    where = "" if subject is robot else f" for {subject.name}"
    blocks = [f"<h3>Derivation{html.escape(where)}: {html.escape(section.title)}</h3>"]
    for item in section.items:
        blocks.append(html.math_block(item.label, to_mathml(item.expr)))
    blocks += [f'<p class="note">{html.escape(note)}</p>' for note in section.notes]
    return "".join(blocks)


def _symbolic_sections(robot: Robot, progress: tqdm,
                       budget: float | None = None) -> tuple[dict[int, str], bool]:
    """HTML of the A1–A5 derivations by assignment number (:func:`derivations`), and whether
    every one finished within ``budget`` seconds (``armlab.symbolic.derive``)."""
    derived = derivations(robot, budget, progress=progress)
    out = {int(d.key[1:]): derivation_html(d, robot) for d in derived}
    return out, all(d.section.complete for d in derived)
