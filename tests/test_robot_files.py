"""Robot files: motor masses lumped by hand computation, and one test per class of malformed
input, each checking the exact one-line ``file: field: reason`` message."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.model.toml_io import load_robot_toml

BASE = """\
name = "t"

[parameters]
L = 0.5
m = 1.0

[[joints]]
name = "q1"
type = "revolute"
dh = { a = "L", alpha = 0, d = 0, theta = 0 }
limits = [-1, 1]
motor = { gear_ratio = 50, rotor_inertia = 1e-4, mass = 0.3 }

[joints.link]
mass = "m"
com = [0, 0, 0]
inertia = [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]

[[joints]]
name = "q2"
type = "prismatic"
origin = { xyz = [0, 0, 0], rpy = [0, 0, 0] }
axis = [1, 0, 0]
friction = { viscous = 0.1, coulomb = 0.2 }

[joints.link]
mass = 0.5
shape = { type = "box", size = [0.1, 0.1, 0.2] }
"""


def _write(tmp_path, text, name="robot.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _edit(old, new):
    assert BASE.count(old) == 1, old
    return BASE.replace(old, new)


def test_base_file_loads(tmp_path):
    robot = load_robot_toml(_write(tmp_path, BASE))
    assert robot.n == 2 and robot.joints[0].motor.mass == 0.3


# case: (edited file text, field, exact reason)
MALFORMED = {
    "negative mass": (_edit('mass = "m"', 'mass = "-m"'),
                      "joints[0].link.mass", "must be non-negative, got -1 kg"),
    "inertia not PSD": (_edit("[0, 0, 0.1]]", "[0, 0, -0.1]]"), "joints[0].link.inertia",
                        "inertia is not positive semi-definite (principal moments [-0.1, 0.1, 0.1])"),
    "triangle inequality": (_edit("[0, 0, 0.1]]", "[0, 0, 0.3]]"), "joints[0].link.inertia",
                            "inertia violates the triangle inequality of principal moments "
                            "(0.1 + 0.1 < 0.3)"),
    "asymmetric inertia": (_edit("[[0.1, 0, 0]", "[[0.1, 0.01, 0]"), "joints[0].link.inertia",
                           "inertia is not symmetric"),
    "inertia_origin not PSD about the COM": (
        _edit("com = [0, 0, 0]\ninertia =", "com = [0, 0, 1]\ninertia_origin ="),
        "joints[0].link.inertia_origin",
        "inertia about the centre of mass is not positive semi-definite "
        "(principal moments [-0.9, -0.9, 0.1])"),
    "unknown joint type": (_edit('type = "revolute"', 'type = "spherical"'), "joints[0].type",
                           "unknown joint type 'spherical' (use revolute or prismatic)"),
    "wrong vector length": (_edit("com = [0, 0, 0]", "com = [0, 0]"), "joints[0].link.com",
                            "expected 3 numbers, got 2"),
    "wrong matrix shape": (_edit("[0, 0, 0.1]]", "[0, 0]]"), "joints[0].link.inertia[2]",
                           "expected 3 numbers, got 2"),
    "not a number": (_edit("mass = 0.5", "mass = true"), "joints[1].link.mass",
                     "expected a number, got True"),
    "unknown field": (_edit("mass = 0.5", "mass = 0.5\ncolour = 'red'"), "joints[1].link.colour",
                      "unknown field (allowed: com, inertia, inertia_origin, mass, name, shape)"),
    "unknown top-level field": ('robot_name = "x"\n' + BASE, "robot_name",
                                "unknown field (allowed: base, description, dh_convention, gravity, "
                                "joints, name, parameters, provenance, tool)"),
    "bad expression": (_edit('a = "L"', 'a = "L +"'), "joints[0].dh.a", "cannot parse expression 'L +'"),
    "unknown parameter name": (_edit('a = "L"', 'a = "L_1"'), "joints[0].dh.a", "unknown name 'L_1'"),
    "unknown function": (_edit('a = "L"', 'a = "exp(L)"'), "joints[0].dh.a",
                         "unknown function 'exp' (allowed: cos, sin, sqrt, tan)"),
    "missing placement": (_edit("dh = { a = \"L\", alpha = 0, d = 0, theta = 0 }\n", ""), "joints[0]",
                          "needs a placement: dh = {a, alpha, d, theta} or origin/axis"),
    "missing DH entry": (_edit('dh = { a = "L", alpha = 0,', 'dh = { a = "L",'), "joints[0].dh.alpha",
                         "missing"),
    "both dh and origin": (_edit("limits = [-1, 1]", "limits = [-1, 1]\norigin = { xyz = [0, 0, 1] }"),
                           "joints[0]", "give either dh or origin/axis, not both"),
    "zero axis": (_edit("axis = [1, 0, 0]", "axis = [0, 0, 0]"), "joints[1].axis",
                  "must be a non-zero vector"),
    "reversed limits": (_edit("limits = [-1, 1]", "limits = [1, -1]"), "joints[0].limits",
                        "lower limit 1 must be below upper limit -1"),
    "unknown shape": (_edit('type = "box"', 'type = "cone"'), "joints[1].link.shape.type",
                      "unknown shape 'cone' (use box, cylinder or sphere)"),
    "non-positive box size": (_edit("size = [0.1, 0.1, 0.2]", "size = [0.1, 0, 0.2]"),
                              "joints[1].link.shape.size", "edge lengths must be positive"),
    "non-positive cylinder radius": (
        _edit('type = "box", size = [0.1, 0.1, 0.2]', 'type = "cylinder", radius = -0.1, length = 0.2'),
        "joints[1].link.shape.radius", "must be positive, got -0.1"),
    "missing shape size": (_edit('type = "box", size = [0.1, 0.1, 0.2]', 'type = "sphere"'),
                           "joints[1].link.shape.radius", "missing (a sphere needs radius)"),
    "negative motor mass": (_edit("mass = 0.3", "mass = -0.3"), "joints[0].motor.mass",
                            "must be non-negative, got -0.3 kg"),
    "zero gear ratio": (_edit("gear_ratio = 50", "gear_ratio = 0"), "joints[0].motor.gear_ratio",
                        "must be non-zero"),
    "negative friction": (_edit("viscous = 0.1", "viscous = -0.1"), "joints[1].friction.viscous",
                          "must be non-negative"),
    "duplicate joint name": (_edit('name = "q2"', 'name = "q1"'), "joints[1].name",
                             "joint name 'q1' is used twice"),
    "empty name": (_edit('name = "q2"', 'name = ""'), "joints[1].name",
                   "expected a non-empty string, got ''"),
    "no joints": ('name = "t"\n', "joints", "at least one [[joints]] entry is needed"),
    "gravity length": ("gravity = [0, -9.81]\n" + BASE, "gravity", "expected 3 numbers, got 2"),
    "base with dh and xyz": ('base = { xyz = [0, 0, 1], dh = { a = 0, alpha = 0, d = 0, theta = 0 } }\n'
                             + BASE, "base", "give either dh or xyz/rpy, not both"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_robot_file_gives_one_line_error(case, tmp_path):
    text, field, reason = MALFORMED[case]
    path = _write(tmp_path, text)
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(path)
    assert str(info.value) == f"{path}: {field}: {reason}"
    assert (info.value.file, info.value.field, info.value.reason) == (str(path), field, reason)


def test_unreadable_file(tmp_path):
    path = tmp_path / "absent.toml"
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(path)
    assert str(info.value) == f"{path}: file: cannot be read (No such file or directory)"


def test_toml_syntax_error(tmp_path):
    path = _write(tmp_path, _edit('name = "t"', 'name = "t'))
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(path)
    message = str(info.value)
    assert message.startswith(f"{path}: syntax: ") and "\n" not in message
    assert "line 1" in message


def test_unknown_robot_name():
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot("no_such_robot")
    assert str(info.value).startswith("no_such_robot: name: not a bundled robot")


# ------------------------------------------------------------------------------ motor masses
MOTOR_ARM = """\
name = "motor_arm"
[[joints]]
type = "revolute"
dh = { a = 1.0, alpha = 0, d = 0, theta = 0 }
motor = { gear_ratio = 100, rotor_inertia = 0.01, mass = 7.0 }
[joints.link]
mass = 2.0
com = [-0.3, 0, 0]
inertia = [[0.01, 0, 0], [0, 0.02, 0], [0, 0, 0.03]]
[[joints]]
type = "revolute"
dh = { a = 1.0, alpha = 0, d = 0, theta = 0 }
motor = { gear_ratio = 100, rotor_inertia = 0.01, mass = 1.0 }
[joints.link]
mass = 0.5
com = [-0.5, 0, 0]
"""


def test_motor_mass_is_lumped_into_the_preceding_link(tmp_path):
    """Hand computation (Siciliano et al. §7.2: motor i on link i−1 at joint i).

    Link 1 in J_1 (= Σ_0 turned by θ1; Σ_1 = J_1 · Tx(1)): 2 kg at x = 1 − 0.3 = 0.7.
    Motor 2: 1 kg at joint 2's origin, x = 1.  Together 3 kg at x = (1.4 + 1)/3 = 0.8;
    Steiner: I_yy = 0.02 + 2·0.1² + 1·0.2² = 0.08, I_zz = 0.03 + 0.06 = 0.09, I_xx = 0.01.
    Motor 1 (7 kg) stands on the fixed base and drops out."""
    robot = load_robot_toml(_write(tmp_path, MOTOR_ARM))
    m = robot.arrays
    np.testing.assert_allclose(m.mass, [3.0, 0.5])
    np.testing.assert_allclose(m.com[0], [0.8, 0, 0], atol=1e-15)
    np.testing.assert_allclose(m.inertia[0], np.diag([0.01, 0.08, 0.09]), atol=1e-15)
    np.testing.assert_allclose(m.com[1], [0.5, 0, 0], atol=1e-15)
    np.testing.assert_allclose(m.inertia[1], 0.0, atol=1e-15)
    np.testing.assert_allclose(m.gear_ratio, [100, 100])
    np.testing.assert_allclose(m.rotor_inertia, [0.01, 0.01])
    # The description itself keeps the link's own values.
    assert robot.links[0].inertial.mass == 2.0


def test_motor_mass_sits_on_the_joint_axis_of_an_oblique_joint(tmp_path):
    """For a URDF-style joint the motor goes to the joint's origin in J_{i−1}: check the lumped
    centre of mass against the joint origin computed from link_frames."""
    text = MOTOR_ARM.replace('dh = { a = 1.0, alpha = 0, d = 0, theta = 0 }\nmotor = { gear_ratio = 100, '
                             'rotor_inertia = 0.01, mass = 1.0 }',
                             'origin = { xyz = [0.4, 0.2, -0.1], rpy = [0.3, 0.2, 0.1] }\naxis = [0, 1, 1]\n'
                             'motor = { gear_ratio = 100, rotor_inertia = 0.01, mass = 1.0 }')
    robot = load_robot_toml(_write(tmp_path, text))
    q = np.array([0.7, -0.4])
    frames = armlab.link_frames(robot, q, frame="0")
    m = robot.arrays
    J1 = frames[1] @ np.linalg.inv(robot.joints[0].after)
    com_world = J1[:3, :3] @ m.com[0] + J1[:3, 3]
    link_com = frames[1][:3, :3] @ np.array([-0.3, 0, 0]) + frames[1][:3, 3]
    joint2_origin = frames[2][:3, 3]  # Σ_2 = J_2 · R_axisᵀ shares J_2's origin, on the axis
    np.testing.assert_allclose(com_world, (2.0 * link_com + 1.0 * joint2_origin) / 3.0, atol=1e-14)


# --------------------------------------------------------------------------- bundled robots
def test_bundled_robots_are_listed_and_load():
    names = armlab.bundled_robot_names()
    assert {"prp", "prp_actuated", "planar2r", "puma560"} <= set(names)
    for name in names:
        robot = armlab.load_robot(name)
        assert robot.name == name and robot.description


def test_prp_actuated_is_the_prp_plus_motors_and_friction():
    prp, actuated = armlab.load_robot("prp"), armlab.load_robot("prp_actuated")
    assert actuated.parameters.items() >= prp.parameters.items()
    for a, b in zip(prp.joints, actuated.joints, strict=True):
        assert (a.name, a.kind, a.offset, a.limits, a.dh) == (b.name, b.kind, b.offset, b.limits, b.dh)
        np.testing.assert_array_equal(a.before, b.before)
        np.testing.assert_array_equal(a.after, b.after)
        assert b.motor.gear_ratio != 1.0 and b.motor.rotor_inertia > 0 and b.motor.mass > 0
        assert b.friction.viscous > 0 and b.friction.coulomb > 0
    for a, b in zip(prp.links, actuated.links, strict=True):
        assert a.name == b.name and a.inertial.mass == b.inertial.mass
        np.testing.assert_array_equal(a.inertial.com, b.inertial.com)
        np.testing.assert_array_equal(a.inertial.inertia, b.inertial.inertia)
    for field in ("gravity", "base", "tool"):
        np.testing.assert_array_equal(getattr(prp, field), getattr(actuated, field))


def test_planar2r_inertia_about_joint_1_matches_siciliano():
    """Siciliano et al. (7.82) b11 without the rotor terms, at q2 = 0:
    I_l1 + m_l1 l1² + m_m2 a1² + I_l2 + m_l2 (a1 + l2)² = 10 + 12.5 + 5 + 10 + 112.5 = 150.
    Computed here from link frames and the lumped arrays (motor 2 in link 1)."""
    robot = armlab.load_robot("planar2r")
    m = robot.arrays
    frames = armlab.link_frames(robot, [0.3, 0.0], frame="0")
    total = 0.0
    for i, joint in enumerate(robot.joints):
        J = frames[i + 1] @ np.linalg.inv(joint.after)
        p_c = J[:3, :3] @ m.com[i] + J[:3, 3]
        R = J[:3, :3]
        total += (R @ m.inertia[i] @ R.T)[2, 2] + m.mass[i] * (p_c[0] ** 2 + p_c[1] ** 2)
    assert total == pytest.approx(150.0, rel=1e-12)
    np.testing.assert_allclose(m.gear_ratio ** 2 * m.rotor_inertia, [100.0, 100.0])
    np.testing.assert_allclose(robot.gravity, [0, -9.81, 0])


def test_puma560_wrist_position_matches_closed_form():
    """Standard-DH PUMA 560 wrist centre (= Σ_6 origin, d5 = d6 = 0), derived by hand:
    X = a2 c2 + a3 c23 − d4 s23,  p = (c1 X + d3 s1,  s1 X − d3 c1,  a2 s2 + a3 s23 + d4 c23);
    at q = 0 this is Corke's documented fkine(qz) = (0.4521, −0.1500, 0.4318)."""
    robot = armlab.load_robot("puma560")
    a2, a3, d3, d4 = 0.4318, 0.0203, 0.15005, 0.4318
    rng = np.random.default_rng(5)
    for q in [np.zeros(6), *rng.uniform(-1.5, 1.5, size=(4, 6))]:
        c1, s1 = np.cos(q[0]), np.sin(q[0])
        c2, s2 = np.cos(q[1]), np.sin(q[1])
        c23, s23 = np.cos(q[1] + q[2]), np.sin(q[1] + q[2])
        X = a2 * c2 + a3 * c23 - d4 * s23
        expected = [c1 * X + d3 * s1, s1 * X - d3 * c1, a2 * s2 + a3 * s23 + d4 * c23]
        np.testing.assert_allclose(armlab.forward_kinematics(robot, q)[:3, 3], expected, atol=1e-12)
    np.testing.assert_allclose(armlab.forward_kinematics(robot, np.zeros(6))[:3, 3],
                               [0.4521, -0.15005, 0.4318], atol=1e-12)


def test_puma560_link_side_friction_and_armature():
    """Corke's motor-side B, Tc, Jm converted: F_v = B G², F_s = |G| mean|Tc|, k_r² I_m = Jm G²."""
    m = armlab.load_robot("puma560").arrays
    G = np.array([-62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686])
    B = np.array([1.48e-3, 0.817e-3, 1.38e-3, 71.2e-6, 82.6e-6, 36.7e-6])
    Tc = np.array([[0.395, 0.435], [0.126, 0.071], [0.132, 0.105],
                   [11.2e-3, 16.9e-3], [9.26e-3, 14.5e-3], [3.96e-3, 10.5e-3]])
    Jm = np.array([200e-6] * 3 + [33e-6] * 3)
    np.testing.assert_allclose(m.viscous, B * G**2, rtol=1e-12)
    np.testing.assert_allclose(m.coulomb, np.abs(G) * Tc.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(m.gear_ratio, G)
    np.testing.assert_allclose(m.gear_ratio**2 * m.rotor_inertia, Jm * G**2, rtol=1e-12)
    np.testing.assert_allclose(m.mass, [0.0, 17.4, 4.8, 0.82, 0.34, 0.09])


# ------------------------------------------------------------------------------ command line
def _cli(capsys, *argv):
    from armlab.cli import main

    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_text_tables_align_columns_and_keep_cells_as_given():
    """The CLI's tables: a rule under the header, every column starting at one offset on each
    line, cells verbatim (numbers neither reparsed nor realigned), no trailing blanks."""
    from armlab.commands import format_table

    rows = [["d1", "0.50", "-0", "[-0.15, 0.35] m"], ["theta2", "1e-05", "", "π/2"]]
    headers = ["joint", "k_r", "I_m [kg·m²]", "limits"]
    text = format_table(headers, rows, "  ")
    lines = text.split("\n")
    assert len(lines) == 4 and all(line.startswith("  ") and line == line.rstrip() for line in lines)
    assert set(lines[1].strip()) == {"-", " "}
    starts = [k for k in range(3, len(lines[1])) if lines[1][k] == "-" and lines[1][k - 1] == " "]
    assert len(starts) == 3
    for line, cells in zip([lines[0], *lines[2:]], [headers, *rows], strict=True):
        assert line[2:].startswith(cells[0] + " ")
        for start, cell in zip(starts, cells[1:], strict=True):
            assert line[start:start + len(cell)] == cell and line[start - 1] == " ", (line, cell)
    assert format_table(["a", "b"], []).split("\n")[0].split() == ["a", "b"]


def test_cli_robots_lists_every_bundled_robot(capsys):
    code, out, err = _cli(capsys, "robots")
    assert code == 0 and not err
    for name in armlab.bundled_robot_names():
        robot = armlab.load_robot(name)
        line = next(line for line in out.splitlines() if line.startswith(name + " "))
        assert line.split()[1:3] == [str(robot.n), "".join(j.kind[0].upper() for j in robot.joints)]


@pytest.mark.parametrize("name", ["prp", "prp_actuated", "planar2r", "puma560"])
def test_cli_robots_describes_a_robot(capsys, name):
    code, out, err = _cli(capsys, "robots", name)
    assert code == 0 and not err
    robot = armlab.load_robot(name)
    for part in ("DH table", "Joints: limits, motors", "Links: mass", *robot.joint_names,
                 *[lk.name for lk in robot.links]):
        assert part in out


def test_cli_robots_describes_a_urdf_file_and_exports_urdf(capsys, tmp_path):
    path = tmp_path / "prp.urdf"
    code, out, _ = _cli(capsys, "robots", "prp", "--urdf", str(path))
    assert code == 0 and f"URDF written to {path}" in out
    code, out, err = _cli(capsys, "robots", str(path))
    assert code == 0 and not err
    assert "Joint placements" in out and "d1" in out and "theta2" in out


def test_cli_demo_prints_the_seed_dh_tables_and_forward_kinematics(capsys):
    """The seed's A1 tables (from Σ_base: base row a = 0, α = π/2, d = L0, θ = π/2) and
    T_3^0 at d1 = 0.1, θ2 = π/3, d3 = 0.1 from the seed's closed form:
    p = (s2 (L4/2 − d3), −c2 (L4/2 − d3), L2/2 + L3 + d1) = (0.0866, −0.05, 0.5)."""
    code, out, err = _cli(capsys, "demo")
    assert code == 0 and not err
    compact = [" ".join(line.split()) for line in out.splitlines()]
    assert "base → 0 0 π/2 L0 π/2" in compact
    assert "0 → 1 0 0 L2/2 + d1 0" in compact
    assert "1 → 2 0 -π/2 L3 θ2" in compact
    assert "2 → 3 0 -π d3 - L4/2 -π/2" in compact
    T0 = out.split("T_3^0")[1]
    rows = [line.strip(" []").split() for line in T0.splitlines()[1:5]]
    np.testing.assert_allclose(np.array(rows, dtype=float),
                               [[0, -0.5, 0.866, 0.0866], [0, -0.866, -0.5, -0.05], [1, 0, 0, 0.5],
                                [0, 0, 0, 1]], atol=1e-4)
    assert "T_3^base" in out


def test_cli_demo_builds_no_report_unless_asked(capsys, monkeypatch, tmp_path):
    """The demo is the A1 tables; the report is `armlab report` (or `demo --report`)."""
    import armlab.viz.report

    built = []
    monkeypatch.setattr(armlab.viz.report, "build_report",
                        lambda robot, out, **kw: built.append(out) or tmp_path / "report.html")
    code, out, _ = _cli(capsys, "demo")
    assert code == 0 and built == [] and "armlab report" in out
    code, out, _ = _cli(capsys, "demo", "--report", "--out", str(tmp_path))
    assert code == 0 and built == [str(tmp_path)]


def test_cli_demo_accepts_a_pose_and_another_robot(capsys):
    code, out, _ = _cli(capsys, "demo", "--robot", "planar2r", "--q", "pi/2, 0", "--no-report")
    assert code == 0
    T0 = out.split("T_2^0")[1]
    rows = [line.strip(" []").split() for line in T0.splitlines()[1:5]]
    # Both links along y_0: the tip at (0, a1 + a2, 0).
    np.testing.assert_allclose(np.array(rows, dtype=float)[:3, 3], [0, 2, 0], atol=1e-4)


@pytest.mark.parametrize("argv", [["robots", "no_such_robot"], ["demo", "--q", "1, 2"],
                                  ["robots", "missing.toml"]])
def test_cli_errors_are_one_line_with_exit_code_2(capsys, argv):
    code, out, err = _cli(capsys, *argv)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"armlab {argv[0]}: error: ")
    assert "Traceback" not in err


def test_console_script_runs_and_reports_errors():
    """The installed ``armlab`` entry point, in a separate process."""
    import subprocess
    import sys
    from pathlib import Path

    script = Path(sys.executable).with_name("armlab")
    command = [str(script)] if script.exists() else [sys.executable, "-m", "armlab.cli"]
    done = subprocess.run([*command, "--version"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.startswith("armlab ")
    done = subprocess.run([*command, "robots", "nope"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "nope" in done.stderr
