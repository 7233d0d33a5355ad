"""A robot file's visual meshes in the 3-D view: placed where the file places them (checked
against yourdfpy's own forward kinematics of the UR5 and of URDF boxes, cylinders and spheres,
and against MuJoCo's own geom poses of an MJCF arm), thinned to the vertex budget by vertex
clustering without losing the shape, and a missing or broken mesh file costs only its own
drawing.  Skipped, with the reason, without trimesh (or, for MJCF, mujoco)."""

from __future__ import annotations

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh", reason="meshes are read by trimesh (installed with yourdfpy)")

import armlab  # noqa: E402
from armlab.viz.meshes import MAX_VERTICES, decimate  # noqa: E402
from armlab.viz.view3d import view3d_spec  # noqa: E402


def _vertices(trace) -> np.ndarray:
    return np.column_stack([trace["x"], trace["y"], trace["z"]])


def _traces(spec) -> dict:
    return {trace["name"]: trace for trace in spec["data"]}


def test_a_mesh_within_the_budget_is_kept_and_a_finer_one_thinned_on_its_surface():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=1.0)  # 2562 vertices on |p| = 1
    vertices, faces = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    kept = decimate(vertices, faces, 5000)
    assert np.array_equal(kept[0], vertices) and np.array_equal(kept[1], faces)
    thin, triangles = decimate(vertices, faces, 300)
    assert 150 <= len(thin) <= 300
    radius = np.linalg.norm(thin, axis=1)
    assert radius.max() <= 1.0 + 1e-12 and radius.min() > 0.9  # means of points of the sphere
    assert triangles.min() >= 0 and triangles.max() < len(thin)
    assert np.all((triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2])
                  & (triangles[:, 0] != triangles[:, 2]))
    area = trimesh.Trimesh(thin, triangles, process=False).area
    assert abs(area - 4 * np.pi) < 0.15 * 4 * np.pi, area  # still a closed sphere's surface
    one, none = decimate(vertices, faces, 1)
    np.testing.assert_allclose(one, [vertices.mean(axis=0)], atol=1e-12)
    assert none.shape == (0, 3)
    with pytest.raises(ValueError, match="max_vertices"):
        decimate(vertices, faces, 0)


@pytest.fixture(scope="module")
def ur5():
    from armlab.robots import zoo

    if not zoo.installed(zoo.ZOO["ur5"]):
        pytest.skip("example-robot-data is not installed (extra 'zoo')")
    return armlab.load_robot("ur5"), zoo.zoo_path("ur5")


def test_the_ur5_meshes_sit_where_its_urdf_puts_them(ur5):
    """Every vertex of every visual mesh, at a pose q, where yourdfpy's forward kinematics of
    the same file puts it (T_root,link(q) · <origin> · diag(scale) · p)."""
    import yourdfpy

    robot, path = ur5
    q = np.array([0.3, -1.1, 1.4, -0.6, 0.9, 0.4])
    spec = view3d_spec(robot, q, max_vertices=None)
    traces = _traces(spec)
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True)
    urdf.update_cfg(dict(zip(robot.joint_names, q, strict=True)))
    checked = 0
    for link in urdf.robot.links:
        for visual in link.visuals:
            mesh = trimesh.load(yourdfpy.filename_handler_magic(visual.geometry.mesh.filename,
                                                                dir=str(path.parent)),
                                force="mesh", process=False)
            T = urdf.get_transform(frame_to=link.name, frame_from=urdf.base_link)
            T = T @ (np.eye(4) if visual.origin is None else visual.origin)
            expected = np.asarray(mesh.vertices) @ T[:3, :3].T + T[:3, 3]
            moving = {lk.name for lk in robot.links}
            name = link.name if link.name in moving else "ground parts"  # base_link: fixed
            assert traces[name]["type"] == "mesh3d"
            np.testing.assert_allclose(_vertices(traces[name]), expected, atol=1e-9, err_msg=name)
            checked += 1
    assert checked == 7  # base, shoulder, upper arm, forearm, three wrist links


def test_the_ur5_view_keeps_its_vertex_budget_and_its_shape(ur5):
    robot, _ = ur5
    q = np.zeros(robot.n)
    full, thin = _traces(view3d_spec(robot, q, max_vertices=None)), _traces(view3d_spec(robot, q))
    meshes = [name for name, trace in thin.items() if trace["type"] == "mesh3d"]
    assert sorted(meshes) == sorted([link.name for link in robot.links] + ["ground parts"])
    assert sum(len(thin[name]["x"]) for name in meshes) <= MAX_VERTICES
    assert sum(len(full[name]["x"]) for name in meshes) > 20 * MAX_VERTICES  # 66 000 in the files
    for name in meshes:
        a, b = _vertices(full[name]), _vertices(thin[name])
        # The box of each part stays within 1 cm of the file's (links are 0.1 to 0.5 m long).
        np.testing.assert_allclose(b.min(axis=0), a.min(axis=0), atol=0.01, err_msg=name)
        np.testing.assert_allclose(b.max(axis=0), a.max(axis=0), atol=0.01, err_msg=name)


URDF = """<?xml version="1.0"?>
<robot name="three">
  <link name="base"/>
  {links}
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""
LINK = """<link name="{name}"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.1"/>
      <geometry><mesh filename="{mesh}" scale="2 2 2"/></geometry></visual></link>"""


def test_a_missing_or_broken_mesh_file_costs_only_its_own_drawing(tmp_path):
    from armlab.model.urdf_io import load_urdf

    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(tmp_path / "box.stl")
    (tmp_path / "broken.stl").write_bytes(b"not a mesh")
    links = "\n  ".join(LINK.format(name=name, mesh=mesh)
                        for name, mesh in (("a", "box.stl"), ("b", "broken.stl"), ("c", "missing.stl")))
    path = tmp_path / "three.urdf"
    path.write_text(URDF.format(links=links), encoding="utf-8")
    robot = load_urdf(path)
    assert [v.part for v in robot.visuals] == ["a", "b"]
    assert any("mesh files not found" in note and "c: missing.stl" in note for note in robot.notes)
    q = np.array([0.7, 0.3, -0.2])
    with pytest.warns(UserWarning, match=r"broken\.stl: mesh: cannot be read"):
        traces = _traces(view3d_spec(robot, q))
    assert traces["b"]["type"] == traces["c"]["type"] == "scatter3d"  # no shape: a segment
    box = _vertices(traces["a"])
    T_base_1 = armlab.link_frames(robot, q, frame="base")[1]
    # The box (0.1 m, scaled by 2) centred 0.1 m up the z axis of link a's frame.
    np.testing.assert_allclose(box.mean(axis=0), T_base_1[:3, 3] + 0.1 * T_base_1[:3, 2], atol=1e-12)
    local = (box - T_base_1[:3, 3]) @ T_base_1[:3, :3]
    np.testing.assert_allclose(local.max(axis=0) - local.min(axis=0), [0.2, 0.2, 0.2], atol=1e-12)


def _on_box(local, half):
    """Each vertex (rows of ``local``, in the box's frame) on the surface of the box of half
    sides ``half``, and the vertices spanning the whole box."""
    ratio = np.max(np.abs(local) / half, axis=1)
    np.testing.assert_allclose(ratio, 1.0, atol=1e-9)
    np.testing.assert_allclose(local.min(axis=0), -half, atol=1e-9)
    np.testing.assert_allclose(local.max(axis=0), half, atol=1e-9)


PRIMITIVES = """<?xml version="1.0"?>
<robot name="shapes">
  <link name="base"/>
  <link name="a"><visual><origin xyz="0.05 -0.02 0.1" rpy="0.3 -0.2 0.5"/>
    <geometry><box size="0.1 0.06 0.2"/></geometry></visual></link>
  <link name="b"><visual><origin xyz="0 0.03 0.1" rpy="1.2 0.1 -0.4"/>
    <geometry><cylinder radius="0.04" length="0.25"/></geometry></visual></link>
  <link name="c"><visual><origin xyz="0.1 0 0"/><geometry><sphere radius="0.05"/></geometry></visual>
    <visual><geometry><sphere radius="0"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 0 0.1" rpy="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.2" rpy="0.2 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j3" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0 0 0.25"/>
    <axis xyz="0.6 0 0.8"/><limit lower="-0.1" upper="0.1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_urdf_boxes_cylinders_and_spheres_are_drawn_on_their_shapes_where_the_file_puts_them(tmp_path):
    """Every vertex of a <box>, <cylinder> or <sphere> visual on that shape's surface, the shape
    placed by yourdfpy's forward kinematics of the same file (T_root,link(q) · <origin>); a
    sphere of radius 0 is left out and named in the notes."""
    import yourdfpy

    from armlab.model.urdf_io import load_urdf

    path = tmp_path / "shapes.urdf"
    path.write_text(PRIMITIVES, encoding="utf-8")
    robot = load_urdf(path)
    assert [v.part for v in robot.visuals] == ["a", "b", "c"]
    assert any("size not positive" in note and "c: sphere" in note for note in robot.notes)
    q = np.array([0.7, -0.4, 0.06])
    traces = _traces(view3d_spec(robot, q, max_vertices=None))
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True)
    urdf.update_cfg(dict(zip(robot.joint_names, q, strict=True)))
    for link in urdf.robot.links[1:]:
        T = urdf.get_transform(frame_to=link.name, frame_from=urdf.base_link) @ link.visuals[0].origin
        assert traces[link.name]["type"] == "mesh3d"
        local = (_vertices(traces[link.name]) - T[:3, 3]) @ T[:3, :3]   # in the shape's frame
        geometry = link.visuals[0].geometry
        if geometry.box is not None:
            _on_box(local, np.asarray(geometry.box.size) / 2)
        elif geometry.cylinder is not None:
            r, half = geometry.cylinder.radius, geometry.cylinder.length / 2
            radial, z = np.linalg.norm(local[:, :2], axis=1), local[:, 2]
            assert np.all(radial <= r + 1e-9) and np.all(np.abs(z) <= half + 1e-9)
            assert np.all(np.isclose(radial, r, atol=1e-9) | np.isclose(np.abs(z), half, atol=1e-9))
            np.testing.assert_allclose([radial.max(), z.min(), z.max()], [r, -half, half], atol=1e-9)
        else:
            r = geometry.sphere.radius
            np.testing.assert_allclose(np.linalg.norm(local, axis=1), r, atol=1e-9)
            np.testing.assert_allclose(local.min(axis=0), -r, atol=1e-9)
            np.testing.assert_allclose(local.max(axis=0), r, atol=1e-9)


MJCF = """<mujoco model="meshy">
  <compiler angle="radian" inertiafromgeom="false"/>
  <asset>
    <mesh name="part" file="part.stl"/>
    <mesh name="stretched" file="part.stl" scale="0.5 2 1.5"/>
  </asset>
  <default>
    <default class="visual"><geom contype="0" conaffinity="0" group="2"/></default>
    <default class="collision"><geom group="3"/></default>
  </default>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <geom name="pedestal" type="box" size="0.1 0.1 0.05" pos="0 0 -0.05"/>
    <body name="upper" pos="0.1 0.2 0.3" quat="0.9 0.1 0.3 -0.2">
      <joint name="shoulder" axis="0.2 1 0.1" pos="0.01 0.02 -0.03" ref="0.2"/>
      <inertial pos="0.2 0 0" mass="2" diaginertia="0.01 0.05 0.04"/>
      <geom class="visual" type="mesh" mesh="part" pos="0.1 0.02 -0.01" euler="0.3 -0.5 1.1"/>
      <geom class="visual" type="box" size="0.03 0.02 0.05" pos="0.2 0 0" euler="0.1 0.2 0.3"/>
      <geom class="collision" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
      <body name="fore" pos="0.4 0 0">
        <joint name="elbow" axis="0 0 1" pos="0.02 0 0"/>
        <joint name="twist" axis="1 0 0.3" ref="-0.4"/>
        <inertial pos="0.15 0 0.02" mass="1.2" diaginertia="0.01 0.02 0.025"/>
        <geom class="visual" type="mesh" mesh="stretched" pos="0.05 0 0" quat="0.7 0.1 -0.6 0.2"/>
        <geom class="visual" type="capsule" size="0.02 0.05" pos="0.2 0 0.05" euler="0.4 1.0 0"/>
        <geom class="visual" type="cylinder" fromto="0.1 0.1 0 0.2 0.15 0.05" size="0.015"/>
        <geom class="visual" type="ellipsoid" size="0.03 0.02 0.01" pos="0.25 -0.05 0"/>
        <geom class="visual" type="sphere" size="0.025" pos="0.3 0 0"/>
        <body name="tool" pos="0.3 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _on_geom(mujoco, kind, local, size):
    """Which points ``local`` (in the geom's frame) lie on the surface of the MuJoCo primitive
    of ``size`` (box: half sides; sphere: radius; capsule, cylinder: radius, half length;
    ellipsoid: semi-axes), and the extent (half width along x, y, z) of that shape."""
    G, tol = mujoco.mjtGeom, 1e-9
    r, radial, z = size[0], np.linalg.norm(local[:, :2], axis=1), local[:, 2]
    if kind == G.mjGEOM_BOX:
        return np.abs(np.max(np.abs(local) / size, axis=1) - 1) < tol, size
    if kind == G.mjGEOM_SPHERE:
        return np.abs(np.linalg.norm(local, axis=1) - r) < tol, np.full(3, r)
    if kind == G.mjGEOM_ELLIPSOID:
        return np.abs(np.sum((local / size) ** 2, axis=1) - 1) < tol, size
    half = size[1]
    if kind == G.mjGEOM_CAPSULE:   # points at distance r from the axis segment |z| <= half
        axis_point = np.column_stack([np.zeros((len(z), 2)), np.clip(z, -half, half)])
        return np.abs(np.linalg.norm(local - axis_point, axis=1) - r) < tol, np.array([r, r, half + r])
    assert kind == G.mjGEOM_CYLINDER
    side = (np.abs(radial - r) < tol) & (np.abs(z) <= half + tol)
    cap = (np.abs(np.abs(z) - half) < tol) & (radial <= r + tol)
    return side | cap, np.array([r, r, half])


def test_mjcf_meshes_and_primitives_are_drawn_where_mujoco_puts_its_geoms(tmp_path):
    """Every drawn vertex of an MJCF arm's visible geoms (two meshes of one STL file, one of them
    scaled; a box, capsule, cylinder, ellipsoid, sphere; a box on the world body) where MuJoCo's
    own ``mj_kinematics`` puts the geom at a random q (``geom_xpos``, ``geom_xmat``) to 1e-9 —
    on the primitive's surface, spanning all of it; the meshes also where the file puts the
    STL's points (body pose · geom pos/euler · scale, to MuJoCo's float32 vertices); the
    group-3 collision capsule and the plane are not drawn."""
    mujoco = pytest.importorskip("mujoco", reason="MJCF is read by mujoco (pip install 'armlab[mjcf]')")
    from armlab.model.mjcf_io import load_mjcf

    rng = np.random.default_rng(7)
    # An off-centre, turned box of unequal sides: MuJoCo recentres and turns it (the mesh frame).
    part = trimesh.creation.box(extents=(0.12, 0.05, 0.03))
    turn = trimesh.transformations.random_rotation_matrix(rng.random(3))
    turn[:3, 3] = (0.3, -0.1, 0.05)
    part.apply_transform(turn)
    part.export(tmp_path / "part.stl")
    path = tmp_path / "arm.xml"
    path.write_text(MJCF, encoding="utf-8")
    robot = load_mjcf(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert np.linalg.norm(m.mesh_pos[0]) > 0.1 and abs(m.mesh_quat[0][0]) < 0.999  # a real mesh frame
    q = rng.uniform(-2.0, 2.0, robot.n)
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    traces = _traces(view3d_spec(robot, q, max_vertices=None))
    assert traces["ground parts"]["type"] == traces["upper"]["type"] == traces["fore"]["type"] == "mesh3d"

    def geom(g):
        return d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3)

    def nearest(points, drawn):
        return np.min(np.linalg.norm(points[:, None, :] - drawn[None, :, :], axis=2), axis=1)

    geoms_of = {"upper": [], "fore": [], "ground parts": []}
    for g in range(m.ngeom):
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])) or "ground parts"
        body = "ground parts" if body == "world" else body
        if m.geom_group[g] <= 2 and m.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE:
            geoms_of[body].append(g)
    assert [len(v) for v in geoms_of.values()] == [2, 5, 1]
    for name, geoms in geoms_of.items():
        drawn = _vertices(traces[name])
        claimed = np.zeros(len(drawn), dtype=bool)
        for g in geoms:
            x, R = geom(g)
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                mesh = int(m.geom_dataid[g])
                start, count = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
                expected = np.asarray(m.mesh_vert[start:start + count], dtype=float) @ R.T + x
                distance = nearest(expected, drawn)
                assert distance.max() < 1e-9, (name, distance.max())
                claimed |= nearest(drawn, expected) < 1e-9
            else:  # a primitive: the drawn points on its surface span it all
                local = (drawn - x) @ R
                on, extent = _on_geom(mujoco, m.geom_type[g], local, m.geom_size[g])
                assert on.sum() >= 8, (name, g)
                np.testing.assert_allclose(local[on].min(axis=0), -extent, atol=1e-9, err_msg=f"{name} {g}")
                np.testing.assert_allclose(local[on].max(axis=0), extent, atol=1e-9, err_msg=f"{name} {g}")
                claimed |= on
        assert claimed.all(), name  # nothing drawn that is not one of these geoms

    # The file's own numbers: the STL's points, scaled, at the geom's pos/euler in its body.
    def placed(body, pos, R_geom, scale):
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
        R_body = d.xmat[b].reshape(3, 3)
        local = (np.asarray(part.vertices) * scale) @ R_geom.T + pos
        return local @ R_body.T + d.xpos[b]

    def euler_xyz(a, b, c):   # MJCF's default eulerseq "xyz": rotations about the moving axes
        return (trimesh.transformations.euler_matrix(a, b, c, axes="rxyz"))[:3, :3]

    def quat(*wxyz):
        return trimesh.transformations.quaternion_matrix(np.array(wxyz) / np.linalg.norm(wxyz))[:3, :3]

    upper = placed("upper", [0.1, 0.02, -0.01], euler_xyz(0.3, -0.5, 1.1), 1.0)
    fore = placed("fore", [0.05, 0.0, 0.0], quat(0.7, 0.1, -0.6, 0.2), [0.5, 2.0, 1.5])
    assert nearest(upper, _vertices(traces["upper"])).max() < 1e-6
    assert nearest(fore, _vertices(traces["fore"])).max() < 1e-6


def test_a_visual_holds_a_file_or_triangles_and_refuses_bad_ones():
    from armlab.model.robot import Visual

    box = trimesh.creation.box()
    visual = Visual(body=1, pose=np.eye(4), vertices=box.vertices, faces=box.faces, part="a")
    assert not visual.vertices.flags.writeable and not visual.faces.flags.writeable
    with pytest.raises(ValueError, match="one of the two"):
        Visual(body=1, pose=np.eye(4), mesh="a.stl", vertices=box.vertices, faces=box.faces)
    with pytest.raises(ValueError, match="one of the two"):
        Visual(body=1, pose=np.eye(4))
    with pytest.raises(ValueError, match="go together"):
        Visual(body=1, pose=np.eye(4), vertices=box.vertices)
    with pytest.raises(ValueError, match="indices of its 8 vertices"):
        Visual(body=1, pose=np.eye(4), vertices=box.vertices, faces=box.faces + 1)
    with pytest.raises(ValueError, match="finite"):
        Visual(body=1, pose=np.eye(4), vertices=np.full((3, 3), np.nan), faces=[[0, 1, 2]])
