"""A robot file's visual meshes in the 3-D view: placed where the file places them (checked
against yourdfpy's own forward kinematics of the UR5), thinned to the vertex budget by
vertex clustering without losing the shape, and a missing or broken mesh file costs only its
own drawing."""

from __future__ import annotations

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

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
