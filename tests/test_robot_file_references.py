"""What a robot file names is read only when it may be: an MJCF ``<include>``, mesh or texture
and a URDF mesh must lie under the robot file's own folder (``allow_outside`` / ``--allow-outside``
widens that) and be a regular file of bounded size — a FIFO never blocks the loader, a canary
file outside the folder never reaches the output.  MuJoCo's own warnings join armlab's one-line
error, and MJCF's ``<flag gravity="disable"/>`` gives the dynamics MuJoCo computes."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

import armlab
from armlab.cli import BAD_INPUT, OK, main

mujoco = pytest.importorskip("mujoco", reason="MJCF is read by mujoco (pip install 'armlab[mjcf]')")

CANARY = "CANARY-7f3a-TEXT"
# A tetrahedron (MuJoCo computes a mesh geom's inertia from its volume).
OBJ = """o t
v 0 0 0
v 0.1 0 0
v 0 0.1 0
v 0 0 0.1
f 1 3 2
f 1 2 4
f 1 4 3
f 2 3 4
"""
# One hinge, a body mass of its own; ASSETS and INCLUDE are filled in by each test.
MJCF = """<mujoco model="arm">
  COMPILER
  INCLUDE
  <asset>ASSETS</asset>
  <worldbody>
    <body name="link" pos="0 0 0.1">
      <joint name="hinge" axis="0 1 0"/>
      <geom type="capsule" size="0.02" fromto="0 0 0 0.3 0 0" mass="1"/>
      GEOM
    </body>
  </worldbody>
</mujoco>
"""


def _mjcf(folder, *, include="", assets="", geom="", compiler="", name="arm.xml"):
    path = folder / name
    path.write_text(MJCF.replace("INCLUDE", include).replace("ASSETS", assets).replace("GEOM", geom)
                    .replace("COMPILER", compiler))
    return path


@pytest.fixture
def place(tmp_path):
    """(robot folder, a canary file beside it, outside it)."""
    robot = tmp_path / "robot"
    robot.mkdir()
    canary = tmp_path / "canary.xml"
    canary.write_text(f"<mujoco><!-- {CANARY} --></mujoco>\n{CANARY}\n")
    (tmp_path / "outside.obj").write_text(OBJ)
    return robot, canary


def _load_in_thread(load, fifo):
    """Run ``load()`` with a 30 s allowance; a loader blocked on ``fifo`` is released (a writer
    opens and closes it) and the test fails instead of hanging."""
    outcome = {}

    def target():
        try:
            outcome["value"] = load()
        except BaseException as error:  # noqa: BLE001 — handed to the test
            outcome["error"] = error

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(30)
    if thread.is_alive():
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(10)
        pytest.fail(f"the loader blocked on the FIFO {fifo}")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


OUTSIDE_MJCF = {
    "include ..": dict(include='<include file="../canary.xml"/>'),
    "include absolute": dict(include='<include file="CANARY"/>'),
    "mesh ..": dict(assets='<mesh name="m" file="../outside.obj"/>', geom='<geom type="mesh" mesh="m"/>'),
    "mesh absolute": dict(assets='<mesh name="m" file="OUTSIDE"/>', geom='<geom type="mesh" mesh="m"/>'),
    "texture ..": dict(assets='<texture name="t" type="2d" file="../canary.xml"/>'),
    "meshdir ..": dict(compiler='<compiler meshdir=".."/>',
                       assets='<mesh name="m" file="outside.obj"/>', geom='<geom type="mesh" mesh="m"/>'),
}


@pytest.mark.parametrize("case", sorted(OUTSIDE_MJCF))
def test_mjcf_references_outside_the_folder_are_refused_before_mujoco_reads_them(place, case, capfd):
    robot, canary = place
    texts = {k: v.replace("CANARY", str(canary)).replace("OUTSIDE", str(canary.parent / "outside.obj"))
             for k, v in OUTSIDE_MJCF[case].items()}
    path = _mjcf(robot, **texts)
    with pytest.raises(armlab.RobotFileError) as caught:
        armlab.load_robot(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: ") and "outside the robot file's folder" in message, message
    assert "\n" not in message and CANARY not in message
    assert main(["robots", str(path)]) == BAD_INPUT
    out, err = capfd.readouterr()
    assert CANARY not in out + err and len(err.strip().splitlines()) == 1, err


def test_a_symbolic_link_out_of_the_folder_is_outside(place):
    robot, canary = place
    os.symlink(canary.parent / "outside.obj", robot / "inside.obj")
    path = _mjcf(robot, assets='<mesh name="m" file="inside.obj"/>', geom='<geom type="mesh" mesh="m"/>')
    with pytest.raises(armlab.RobotFileError, match="'inside.obj' lies outside the robot file's folder"):
        armlab.load_robot(path)


def test_allow_outside_reads_them_and_files_inside_are_read_by_default(place, capfd):
    robot, _ = place
    mesh = dict(assets='<mesh name="m" file="../outside.obj"/>', geom='<geom type="mesh" mesh="m"/>')
    path = _mjcf(robot, **mesh)
    loaded = armlab.load_robot(path, allow_outside=True)
    assert loaded.n == 1 and any(v.vertices is not None and len(v.vertices) >= 4 for v in loaded.visuals)
    assert main(["robots", str(path), "--allow-outside"]) == OK
    capfd.readouterr()
    (robot / "meshes").mkdir()
    (robot / "meshes" / "part.obj").write_text(OBJ)
    (robot / "parts.xml").write_text('<mujoco><asset><mesh name="m" file="part.obj"/></asset></mujoco>')
    inside = _mjcf(robot, compiler='<compiler meshdir="meshes"/>', include='<include file="parts.xml"/>',
                   geom='<geom type="mesh" mesh="m"/>', name="inside.xml")
    assert armlab.load_robot(inside).n == 1


@pytest.mark.parametrize("kind", ["include", "mesh", "texture"])
def test_a_fifo_named_by_an_mjcf_file_is_refused_without_blocking(tmp_path, kind):
    fifo = tmp_path / f"trap.{ {'include': 'xml', 'mesh': 'obj', 'texture': 'png'}[kind] }"
    os.mkfifo(fifo)
    texts = {"include": dict(include=f'<include file="{fifo.name}"/>'),
             "mesh": dict(assets=f'<mesh name="m" file="{fifo.name}"/>', geom='<geom type="mesh" mesh="m"/>'),
             "texture": dict(assets=f'<texture name="t" type="2d" file="{fifo.name}"/>')}[kind]
    path = _mjcf(tmp_path, **texts)
    with pytest.raises(armlab.RobotFileError, match=rf"'{fifo.name}' is a FIFO \(named pipe\), not"):
        _load_in_thread(lambda: armlab.load_robot(path), fifo)


def test_an_mjcf_file_of_invalid_utf8_is_bad_input(tmp_path, capfd):
    path = tmp_path / "bad.xml"
    path.write_bytes(b'<mujoco model="\xff\xfe"><worldbody><body name="b"><joint name="j"/>'
                     b'<geom type="sphere" size="0.1"/></body></worldbody></mujoco>')
    with pytest.raises(armlab.RobotFileError, match="file: is not UTF-8 text"):
        armlab.load_robot(path)
    assert main(["robots", str(path)]) == BAD_INPUT
    assert "internal error" not in capfd.readouterr().err


def test_mujocos_warnings_join_the_one_line_and_a_nan_is_refused(tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)   # MuJoCo's default handler would append to ./MUJOCO_LOG.TXT
    failing = _mjcf(tmp_path, geom='<geom type="sphere" size="nan" mass="1"/>', name="failing.xml")
    assert main(["robots", str(failing)]) == BAD_INPUT
    out, err = capfd.readouterr()
    assert "WARNING" not in out + err.replace("MuJoCo warned", "") and len(err.strip().splitlines()) == 1
    assert "MuJoCo warned: XML contains a 'NaN'" in err, err
    # A NaN where MuJoCo compiles the model anyway (an unused attribute): still refused.
    compiling = _mjcf(tmp_path, geom='<geom type="sphere" size="0.05" rgba="nan 0 0 1"/>', name="nan.xml")
    with pytest.raises(armlab.RobotFileError, match="MuJoCo warned: XML contains a 'NaN'"):
        armlab.load_robot(compiling)
    out, err = capfd.readouterr()
    assert "WARNING" not in out + err and not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_disabled_gravity_gives_mujocos_bias_forces(tmp_path):
    """With ``<flag gravity="disable"/>`` MuJoCo's qfrc_bias at rest is 0; armlab's g(q) too."""
    path = _mjcf(tmp_path, compiler='<option><flag gravity="disable"/></option>')
    robot = armlab.load_robot(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[:] = [0.7]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(armlab.gravity_torque(robot, np.array([0.7])), d.qfrc_bias, atol=1e-12)
    assert np.abs(armlab.gravity_torque(armlab.load_robot(_mjcf(tmp_path, name="g.xml")),
                                        np.array([0.7]))).max() > 1.0   # gravity on: 1 kg, 0.15 m
    np.testing.assert_array_equal(robot.gravity, np.zeros(3))


def test_the_one_longest_chain_needs_no_tip(tmp_path):
    finger = ('<body name="finger" pos="0 0.05 0"><joint name="f" axis="0 0 1"/>'
              '<geom type="sphere" size="0.01" mass="0.1"/></body>'
              '<body name="fore" pos="0.3 0 0"><joint name="elbow" axis="0 1 0"/>'
              '<geom type="sphere" size="0.02" mass="0.5"/><body name="hand" pos="0.1 0 0">'
              '<joint name="wrist" axis="0 1 0"/><geom type="sphere" size="0.02" mass="0.2"/></body></body>')
    robot = armlab.load_robot(_mjcf(tmp_path, geom=finger))
    assert list(robot.joint_names) == ["hinge", "elbow", "wrist"] and robot.tip == "hand"
    assert any("f = 0" in note for note in robot.notes)
    twins = finger.replace('name="finger"', 'name="twin"').replace('name="f"', 'name="g"') \
        .replace('pos="0 0.05 0"', 'pos="0 -0.05 0"')
    with pytest.raises(armlab.RobotFileError, match="pass tip="):
        armlab.load_robot(_mjcf(tmp_path, geom=finger.split("<body name=\"fore\"")[0]
                                + twins.split("<body name=\"fore\"")[0], name="twins.xml"))


# ------------------------------------------------------------------------------------- URDF
URDF = """<robot name="u">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="MESH"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


@pytest.fixture
def package(tmp_path):
    """A description package: pkg/urdf/arm.urdf with meshes in pkg/meshes, a canary mesh
    beside the package."""
    urdf = tmp_path / "pkg" / "urdf"
    urdf.mkdir(parents=True)
    (tmp_path / "pkg" / "meshes").mkdir()
    (tmp_path / "pkg" / "meshes" / "part.obj").write_text(OBJ)
    (tmp_path / "canary.obj").write_text(OBJ.replace("o t", f"o {CANARY}"))
    return urdf


def _urdf(folder, mesh):
    path = folder / "arm.urdf"
    path.write_text(URDF.replace("MESH", mesh))
    return path


@pytest.mark.parametrize("form", ["package://pkg/meshes/part.obj", "file://ABS", "ABS", "../../canary.obj"])
def test_urdf_meshes_outside_the_folder_are_not_read_unless_allowed(package, form):
    mesh = form.replace("ABS", str(package.parent.parent / "canary.obj"))
    path = _urdf(package, mesh)
    robot = armlab.load_urdf(path)
    assert not robot.visuals
    assert any("outside the robot file's folder" in note and mesh in note for note in robot.notes)
    widened = armlab.load_urdf(path, allow_outside=True)
    assert len(widened.visuals) == 1 and os.path.isfile(widened.visuals[0].mesh)
    assert not str(widened.visuals[0].mesh).startswith(str(package))


def test_urdf_meshes_inside_the_folder_are_read(package):
    (package / "meshes").mkdir()
    (package / "meshes" / "part.obj").write_text(OBJ)
    robot = armlab.load_urdf(_urdf(package, "meshes/part.obj"))
    assert len(robot.visuals) == 1 and robot.visuals[0].mesh == str(package / "meshes" / "part.obj")


def test_a_fifo_urdf_mesh_is_left_out_without_blocking(package):
    (package / "meshes").mkdir()
    fifo = package / "meshes" / "trap.obj"
    os.mkfifo(fifo)
    robot = _load_in_thread(lambda: armlab.load_urdf(_urdf(package, "meshes/trap.obj")), fifo)
    assert not robot.visuals and any("FIFO" in note for note in robot.notes)
    from armlab.viz.meshes import body_meshes

    assert _load_in_thread(lambda: body_meshes(robot), fifo) == {}


# ---------------------------------------------------------------------- scenarios and sweeps
def _scenario(folder, plant, name="scenario.toml"):
    from armlab.scenarios import scenario_path

    text = scenario_path("a6_pd_online").read_text(encoding="utf-8")
    path = folder / name
    path.write_text(text.replace('plant = "prp"', f"plant = {plant!r}"), encoding="utf-8")
    return path


def test_a_scenario_names_robot_files_under_its_folder_unless_allowed(tmp_path, capfd):
    """The decision for files that name files: a scenario's robot file, like a robot file's
    mesh, lies under the naming file's folder; a file named on the command line may lie
    anywhere, and --allow-outside extends that to what it names."""
    from armlab.robots import bundled_robot_path
    from armlab.scenarios import ScenarioFileError, load_scenario_file

    elsewhere, folder = tmp_path / "elsewhere", tmp_path / "experiment"
    elsewhere.mkdir()
    folder.mkdir()
    robot = elsewhere / "arm.toml"
    robot.write_text(bundled_robot_path("prp").read_text(encoding="utf-8"), encoding="utf-8")
    (folder / "arm.toml").write_text(robot.read_text(encoding="utf-8"), encoding="utf-8")
    assert load_scenario_file(_scenario(folder, "arm.toml", "inside.toml")).plant.n == 3
    for plant in ("../elsewhere/arm.toml", str(robot)):
        path = _scenario(folder, plant)
        with pytest.raises(ScenarioFileError, match="plant: the robot file .* lies outside the scenario"):
            load_scenario_file(path)
        assert main(["run", str(path), "--t-final", "0.01", "--out", str(tmp_path / "runs")]) == BAD_INPUT
        assert len(capfd.readouterr().err.strip().splitlines()) == 1
        assert load_scenario_file(path, allow_outside=True).plant.n == 3
    assert main(["run", str(path), "--t-final", "0.01", "--out", str(tmp_path / "runs"), "--quiet",
                 "--allow-outside"]) == OK
    # The controller's own model is a robot file like the plant.
    model = _scenario(folder, "arm.toml", "model.toml")
    model.write_text(model.read_text(encoding="utf-8").replace(
        "[controller]", f"[controller]\nmodel = {str(robot)!r}"), encoding="utf-8")
    with pytest.raises(ScenarioFileError, match="controller.model: the robot file"):
        load_scenario_file(model)


def test_a_sweep_names_scenario_files_under_its_folder_unless_allowed(tmp_path, capfd):
    from armlab.errors import SweepFileError
    from armlab.sweep import load_sweep_file

    (tmp_path / "experiment").mkdir()
    scenario = _scenario(tmp_path, "prp")
    sweep = tmp_path / "experiment" / "sweep.toml"
    sweep.write_text('scenario = "../scenario.toml"\n[grid]\n"controller.kp" = { values = [1, 2] }\n',
                     encoding="utf-8")
    with pytest.raises(SweepFileError, match="scenario: the scenario file '../scenario.toml' lies outside"):
        load_sweep_file(sweep)
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "out"), "--quiet"]) == BAD_INPUT
    assert "outside the sweep file's folder" in capfd.readouterr().err
    assert load_sweep_file(sweep, allow_outside=True).n_runs == 2
    assert os.path.samefile(load_sweep_file(sweep, allow_outside=True).scenario_file, scenario)


@pytest.mark.parametrize("change, field, reason", [
    ('<body name="link" pos="1e200 0 0.1">', r"body\[link\]\.pos", "1e\\+200 is beyond ±1e\\+12"),
    ('<body name="link" pos="inf 0 0.1">', r"body\[link\]\.pos", "is not finite"),
    ('mass="1e300"', r"body\[link\]\.mass", "1e\\+300 is beyond"),
    ('<joint name="hinge" axis="0 1 0" damping="1e20"/>', r"joint\[hinge\]\.damping", "1e\\+20 is beyond"),
])
def test_nonsense_values_of_an_mjcf_file_are_refused_where_read(tmp_path, change, field, reason):
    """MuJoCo compiles them; a TOML or URDF file with the same values is refused (1e12 at most)."""
    text = MJCF.replace("INCLUDE", "").replace("ASSETS", "").replace("GEOM", "").replace("COMPILER", "")
    original = {"mass": 'mass="1"', "<body": '<body name="link" pos="0 0 0.1">',
                "<joint": '<joint name="hinge" axis="0 1 0"/>'}
    key = next(k for k in original if change.startswith(k))
    path = tmp_path / "arm.xml"
    path.write_text(text.replace(original[key], change))
    with pytest.raises(armlab.RobotFileError, match=rf"arm\.xml: {field}: {reason}"):
        armlab.load_robot(path)
