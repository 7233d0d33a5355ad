"""Robot drawing, animation and scope plots: what is drawn is where kinematics says it is."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import armlab
from armlab.spatial import inverse_transform
from armlab.viz import Plane, draw_robot
from armlab.viz.animation import AnimationError, animate_robot


def _drawn_triads(fig) -> dict[str, dict[str, np.ndarray]]:
    """{frame name: {axis: (2, 3) start and tip}} read back from the figure's line artists."""
    ax = fig.axes[0]
    triads: dict[str, dict[str, np.ndarray]] = {}
    for line in ax.lines:
        gid = line.get_gid() or ""
        if gid.startswith("frame:"):
            _, name, axis = gid.split(":")
            triads.setdefault(name, {})[axis] = np.array(line.get_data_3d()).T
    return triads


@pytest.mark.parametrize("frame", ["base", "0"])
def test_prp_drawn_frames_match_forward_kinematics(frame):
    """The seed's plotTransforms check: each triad starts at the frame origin of link_frames
    and its x, y, z lines point along the columns of the frame's rotation."""
    robot = armlab.load_robot("prp")
    q = np.array([0.1, np.pi / 3, 0.1])  # the seed's A1 pose
    fig = draw_robot(robot, q, frame=frame)
    length = fig.robot_artist.axis_length
    triads = _drawn_triads(fig)
    frames = armlab.link_frames(robot, q, frame=frame)
    expected = {"0": frames[0], "1": frames[1], "2": frames[2], "3=e": frames[3]}
    expected["base"] = np.eye(4) if frame == "base" else inverse_transform(robot.base)
    assert np.allclose(frames[3], frames[4])  # the PRP's tool is the identity: Σ_3 = Σ_e
    assert set(triads) == set(expected)
    for name, pose in expected.items():
        for k, axis in enumerate("xyz"):
            start, tip = triads[name][axis]
            assert np.allclose(start, pose[:3, 3], atol=1e-12), (name, axis)
            assert np.allclose((tip - start) / length, pose[:3, k], atol=1e-12), (name, axis)


def test_prp_closed_form_frames_in_base():
    """Σ_0 and Σ_e in Σ_base against the seed's A1 matrices (T_0^base and T_3^base) at the
    A1 pose, with the prp.toml lengths L0 = 0.5, L2 = 0.4, L3 = 0.2, L4 = 0.4 m."""
    robot = armlab.load_robot("prp")
    d1, th2, d3 = 0.1, np.pi / 3, 0.1
    L0, L2, L3, L4 = 0.5, 0.4, 0.2, 0.4
    fig = draw_robot(robot, [d1, th2, d3], frame="base")
    triads = _drawn_triads(fig)
    length = fig.robot_artist.axis_length
    c, s = np.cos(th2), np.sin(th2)
    T_b0 = np.array([[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, L0]], dtype=float)
    T_be = np.array([[1, 0, 0, L2 / 2 + L3 + d1],
                     [0, -c, s, s * (L4 / 2 - d3)],
                     [0, -s, -c, L0 + c * (d3 - L4 / 2)]])
    for name, T in (("0", T_b0), ("3=e", T_be)):
        for k, axis in enumerate("xyz"):
            start, tip = triads[name][axis]
            assert np.allclose(start, T[:, 3], atol=1e-12)
            assert np.allclose((tip - start) / length, T[:, k], atol=1e-12)


def test_link_solids_sit_at_their_centres_of_mass():
    """Each drawn solid is centred on its link's centre of mass, placed by forward kinematics."""
    robot = armlab.load_robot("prp")
    q = np.array([0.05, -0.7, 0.2])
    fig = draw_robot(robot, q, frame="0")
    frames = armlab.link_frames(robot, q, frame="0")
    gids = {c.get_gid() for c in fig.axes[0].collections}
    assert {f"link:{lk.name}" for lk in robot.links} <= gids
    vertices = fig.robot_artist.link_vertices
    for i, link in enumerate(robot.links):
        polygons = vertices[link.name]
        centre = (polygons.min(axis=0) + polygons.max(axis=0)) / 2.0
        com = frames[i + 1][:3, :3] @ link.inertial.com + frames[i + 1][:3, 3]
        assert np.allclose(centre, com, atol=1e-9), link.name


def test_environment_plane_is_drawn_in_the_chosen_frame():
    robot = armlab.load_robot("prp")
    plane = Plane(point=(0.0, -0.3, 0.5), normal=(0.0, 1.0, 0.0), half_size=0.2)
    for frame in ("0", "base"):
        fig = draw_robot(robot, [0.1, 0.0, 0.1], frame=frame, plane=plane)
        corners = fig.robot_artist.plane_points
        T = np.eye(4) if frame == "0" else robot.base
        point = T[:3, :3] @ np.array(plane.point) + T[:3, 3]
        normal = T[:3, :3] @ np.array(plane.normal)
        assert np.allclose(corners.mean(axis=0), point)
        assert np.allclose((corners - point) @ normal, 0.0, atol=1e-12)


def test_animation_writes_a_gif_of_the_trajectory(tmp_path):
    from PIL import Image

    robot = armlab.load_robot("prp")
    t = np.linspace(0.0, 2.0, 201)
    q = np.column_stack((0.1 * np.sin(t), np.sin(t), 0.1 + 0.05 * t))
    path = animate_robot(robot, t, q, tmp_path / "run.gif", max_frames=6, fps=5)
    with Image.open(path) as image:
        assert image.n_frames == 6
        first = np.asarray(image.convert("RGB"))
        image.seek(5)
        last = np.asarray(image.convert("RGB"))
    assert not np.array_equal(first, last)  # the robot moved


def test_animation_rejects_bad_input(tmp_path):
    robot = armlab.load_robot("prp")
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(AnimationError, match="shape"):
        animate_robot(robot, t, np.zeros((11, 2)), tmp_path / "a.gif")
    with pytest.raises(AnimationError, match="format"):
        animate_robot(robot, t, np.zeros((11, 3)), tmp_path / "a.avi")


def test_animation_frames_are_the_frames_of_whole_draws():
    """Each GIF frame redraws only the moving scene over the still axes drawn once: the picture
    is the one a whole draw of the figure gives (links and the plane in depth order, clock)."""
    import matplotlib.pyplot as plt

    from armlab.viz.animation import _frames
    from armlab.viz.drawing import RobotArtist, set_equal_limits, style_axes

    robot = armlab.load_robot("prp")
    times = np.array([0.0, 1.0, 2.0])
    qs = np.array([[0.0, 0.0, 0.05], [0.1, 1.0, 0.1], [0.2, 2.5, 0.15]])

    def scene():
        fig = plt.figure(figsize=(3.0, 3.0), dpi=60)
        ax = fig.add_subplot(projection="3d")
        artist = RobotArtist(ax, robot, plane=Plane((0.0, -0.2, 0.4), (0.0, 1.0, 0.0)))
        set_equal_limits(ax, *artist.extent(qs))
        style_axes(ax, "base")
        ax.set_title("prp")
        return fig, ax, artist, fig.text(0.03, 0.03, "", family="monospace")

    fig, ax, artist, clock = scene()
    whole = []
    for time, q in zip(times, qs, strict=True):
        artist.update(q)
        clock.set_text(f"t = {time:6.2f} s")
        fig.canvas.draw()
        whole.append(np.array(fig.canvas.buffer_rgba())[..., :3])
    plt.close(fig)
    fig, ax, artist, clock = scene()
    try:
        frames = [np.asarray(frame.convert("RGB")) for frame in _frames(fig, ax, artist, clock, times, qs)]
    finally:
        plt.close(fig)
    assert len(frames) == 3 and not np.array_equal(frames[0], frames[2])
    for drawn, expected in zip(frames, whole, strict=True):
        np.testing.assert_array_equal(drawn, expected)


def _synthetic_result(limit=2.0):
    """A hand-made SimulationResult: first-order error decay e(t) = e0 exp(−t/T), a torque
    that saturates at ±limit, a contact force reaching f_d."""
    from armlab.simulation.results import SimulationResult

    t = np.linspace(0.0, 5.0, 5001)
    T = 0.4
    e0 = np.array([0.1, 0.5])
    q_des = np.tile([0.1, 0.5], (t.size, 1))
    q_err = e0 * np.exp(-t / T)[:, None]
    q = q_des - q_err
    tau = np.clip(np.column_stack((5.0 * np.exp(-t), -3.0 * np.exp(-2 * t))), -limit, limit)
    h_e = np.zeros((t.size, 6))
    h_e[:, 1] = -0.5 * (1.0 - np.exp(-t))
    f_d = np.tile([0.0, -0.5, 0.0], (t.size, 1))
    joints, units = ("d1", "theta2"), ("m", "rad")
    return SimulationResult(
        t=t, q=q, qd=np.zeros_like(q), qdd=np.zeros_like(q), tau=tau, z=np.zeros((t.size, 0)),
        signals={"q_des": q_des, "q_err": q_err, "h_e": h_e, "f_d": f_d},
        labels={"q": joints, "qd": joints, "qdd": joints, "tau": joints, "z": (), "q_des": joints,
                "q_err": joints, "h_e": ("fx", "fy", "fz", "mx", "my", "mz"), "f_d": ("fx", "fy", "fz")},
        units={"q": units, "qd": ("m/s", "rad/s"), "qdd": ("m/s²", "rad/s²"), "tau": ("N", "N·m"), "z": (),
               "q_des": units, "q_err": units, "h_e": ("N",) * 3 + ("N·m",) * 3, "f_d": ("N",) * 3},
        meta={"scenario": "synthetic", "torque_limit": [limit, limit]})


def test_scopes_are_chosen_from_the_signals(tmp_path):
    from PIL import Image

    from armlab.viz import plot_scopes
    from armlab.viz.scopes import scope_layout

    result = _synthetic_result()
    names = [scope.name for scope in scope_layout(result)]
    assert names == ["positions", "q_err", "torques", "forces"]
    paths = plot_scopes(result, tmp_path)
    # Named by scenario: the scopes of several runs can share a folder.
    assert [p.name for p in paths] == [f"synthetic_{n}.{f}" for n in names for f in ("png", "svg")]
    for path in paths:
        if path.suffix == ".png":
            with Image.open(path) as image:
                assert image.size[0] > 500
        else:
            assert "t [s]" in path.read_text()


def test_torque_scope_draws_the_saturation_limits_and_force_reference():
    from armlab.viz.scopes import render_scope, scope_layout

    scopes = {s.name: s for s in scope_layout(_synthetic_result(limit=2.0))}
    fig = render_scope(scopes["torques"])
    limit_lines = [ln for ln in fig.axes[0].lines if ln.get_linestyle() == "-."]
    assert sorted(ln.get_ydata()[0] for ln in limit_lines) == [-2.0, 2.0]
    assert fig.axes[0].get_ylabel() == "τ d1 [N]" and fig.axes[1].get_ylabel() == "τ θ2 [N·m]"
    forces = scopes["forces"]
    assert [p.ylabel for p in forces.panels] == ["fx [N]", "fy [N]", "fz [N]"]  # zero moments left out
    assert [c[0] for c in forces.panels[1].curves] == ["h_e", "f_d"]


def test_kept_scope_figures_draw_what_a_fresh_figure_draws():
    """scope_png reuses one figure per panel count: every scope drawn on it, after scopes with
    other limits, legends, notes, a diagnosis and colour-cycled curves, is pixel for pixel the
    scope drawn on a fresh figure."""
    import io

    import matplotlib.pyplot as plt
    from PIL import Image

    from armlab.viz.html import figure_png
    from armlab.viz.scopes import Panel, Scope, Zoom, render_scope, scope_layout, scope_png

    result = _synthetic_result()
    t = result.t
    waves = [("a", t, np.sin(t), dict(lw=1.2)), ("b", t, np.cos(t), dict(lw=1.2))]
    cycled = Scope("signals", "other logged signals",
                   [Panel("a [m]", curves=waves), Panel("c", curves=[("c", t, 1e-17 * t, dict(lw=1.2))])])
    # A log panel, an inset and a caption, which the next scope drawn on the figure must not keep.
    special = Scope("special", "log axis, inset, caption",
                    [Panel("σ", curves=[("σ", t, np.exp(-t), dict(lw=1.2))], log=True, note="min"),
                     Panel("f [N]", curves=[("f", t, 50 * np.exp(-5 * t) - 0.5, dict(lw=1.2))], note="final",
                           note_at=-0.5, zoom=Zoom(4.0, (-0.6, -0.4), above=True))],
                    caption="A caption long enough to be wrapped onto a second line under the figure, "
                            "so that the figure grows by two lines of footnote, the panels keep their size.")
    layout = scope_layout(result)
    scopes = [*layout, cycled, special, cycled, layout[0]]  # all but "forces" have two panels
    diagnoses = ["", "diverged at t = 4.2 s", "", "", "", "diverged", "", ""]

    def pixels(data):
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))

    for scope, diagnosis in zip(scopes, diagnoses, strict=True):
        fig = render_scope(scope, title_prefix="synthetic", diagnosis=diagnosis)
        try:
            fresh = pixels(figure_png(fig, dpi=80))
        finally:
            plt.close(fig)
        kept = pixels(scope_png(scope, title_prefix="synthetic", diagnosis=diagnosis, dpi=80))
        np.testing.assert_array_equal(kept, fresh, err_msg=scope.name)


def test_decimation_keeps_the_extremes():
    from armlab.viz.scopes import decimate

    t = np.linspace(0.0, 1.0, 100_001)
    y = np.sin(40 * t)
    y[54_321] = 7.0  # one spike must survive
    td, yd = decimate(t, y, max_points=1000)
    assert td.size <= 1000 and np.all(np.diff(td) > 0)
    assert yd.max() == 7.0 and np.isclose(yd.min(), y.min())


def test_decimation_keeps_the_first_and_last_sample():
    """A trace that ends flat still reaches the run's end (its last bucket's first min and
    max are both early in the bucket), and starts at the run's start."""
    from armlab.viz.scopes import decimate

    t = np.linspace(0.0, 10.0, 10_001)
    y = np.where(t < 2.0, np.cos(t), np.cos(2.0))  # flat for the last 8 s
    y[0] = 0.5  # neither the first bucket's min nor its max
    td, yd = decimate(t, y, max_points=1000)
    assert td.size <= 1000
    assert td[0] == 0.0 and td[-1] == 10.0
    assert yd[0] == 0.5 and yd[-1] == y[-1]


def test_decimation_equals_the_bucket_by_bucket_definition():
    """Vectorised decimation vs a plain loop: the first and the last sample, and per bucket
    its first min and first max, or both ends of a bucket holding a non-finite value."""
    from armlab.viz.scopes import decimate

    rng = np.random.default_rng(5)
    for n in (1001, 4097, 33_333):
        t = np.linspace(0.0, 1.0, n)
        y = np.cumsum(rng.normal(size=n))
        y[rng.integers(0, n, 4)] = np.nan
        y[rng.integers(0, n, 2)] = -np.inf
        y[50:90] = 2.0                               # ties: the first index counts
        edges = np.linspace(0, n, 500).astype(int)  # 1000 // 2 − 1 buckets, and the two ends
        keep = {0, n - 1}
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            chunk = y[a:b]
            if np.all(np.isfinite(chunk)):
                keep.update((a + int(np.argmin(chunk)), a + int(np.argmax(chunk))))
            else:
                keep.update((a, b - 1))
        index = np.array(sorted(keep))
        td, yd = decimate(t, y, max_points=1000)
        np.testing.assert_array_equal(td, t[index])
        np.testing.assert_array_equal(yd, y[index])


def test_metrics_against_the_closed_form_first_order_decay():
    """e(t) = e0 exp(−t/T) leaves the 2 % band for good at T ln 50; f_e reaches f_d."""
    from armlab.metrics import settling_time
    from armlab.viz.metrics import measure

    result = _synthetic_result()
    T = 0.4
    expected = T * np.log(50.0)
    assert abs(settling_time(result.t, result.signals["q_err"][:, 0]) - expected) <= 1e-3
    rows = {(m.quantity, m.component): m.value for m in measure(result)}
    assert abs(rows[("settling time (2 % band about the final value) of q_err", "θ2")] - expected) <= 1e-3
    assert abs(rows[("steady-state q_err (mean, last 5 %)", "d1")]) < 0.1 * np.exp(-4.75 / T)
    assert rows[("peak |τ|", "d1")] == 2.0
    assert 0.0 < rows[("time at the torque limit", "d1")] < 100.0
    assert abs(rows[("final force error f_d − h_e", "fy")]) < 0.5 * np.exp(-4.7)
    assert settling_time(result.t, np.cos(result.t)) is None  # never settles


def test_environment_planes_of_the_seed_environments():
    """A11's spring K = diag(0, 1e4, 0, 10, 0, 0) is stiff along y_0 only: its plane is normal
    to y_0 through the rest position; a wall is drawn as itself; free space has no plane."""
    from armlab.simulation.environment import FreeSpace, PlanarWall, Spring
    from armlab.viz.experiments import environment_plane

    spring = Spring(stiffness=np.diag([0, 1e4, 0, 10, 0, 0]), rest_position=np.array([0.0, -0.1, 0.5]))
    plane = environment_plane(spring)
    assert np.allclose(plane.point, [0.0, -0.1, 0.5])
    assert np.allclose(np.abs(plane.normal), [0.0, 1.0, 0.0])
    wall = PlanarWall(point=np.array([0.0, -0.2, 0.0]), normal=np.array([0.0, 2.0, 0.0]), stiffness=1e3)
    assert np.allclose(environment_plane(wall).normal, [0.0, 1.0, 0.0])
    assert environment_plane(FreeSpace()) is None
    assert environment_plane(None) is None


def _task_result(controller: dict, *, t_final=6.0, sigma_min=0.2, transient=0.0):
    """A hand-made task-space run: p settling on p_des, a pose x in metres and radians, the
    Jacobian's singular values (the smallest falling to ``sigma_min``), a contact force with a
    transient of ``transient`` [N] that settles on f_d = −0.5 N along y, the force integral as
    controller state, the compliant frame p_t of admittance control, and the controller
    description ``controller`` (its ``type`` and ``frame`` choose the figures' wording)."""
    from armlab.simulation.results import SimulationResult

    t = np.linspace(0.0, t_final, int(1000 * t_final) + 1)
    decay = np.exp(-t / 0.3)[:, None]
    p_des = np.tile([0.0, -0.2, 0.4], (t.size, 1))
    p = p_des - 0.1 * decay
    x = np.hstack([p, np.tile([1.5, -1.5, 0.0], (t.size, 1))])
    sv = np.column_stack([np.ones(t.size), np.ones(t.size), sigma_min + (0.2 - sigma_min) * decay[:, 0]])
    h_e = np.zeros((t.size, 6))
    h_e[:, 1] = transient * t * np.exp(1.0 - t / 0.3) / 0.3 - 0.5 * (1.0 - decay[:, 0])
    f_des = np.tile([0.0, -0.5, 0.0], (t.size, 1))
    z = np.cumsum(f_des - h_e[:, :3], axis=0) * 1e-3
    joints, xyz, pose = ("d1", "theta2", "d3"), ("x", "y", "z"), ("x", "y", "z", "phi1", "phi2", "phi3")
    pose_units = ("m",) * 3 + ("rad",) * 3
    signals = {"x_err": x - np.hstack([p_des, x[:, 3:]]), "x": x, "p": p, "p_des": p_des, "jacobian_sv": sv,
               "p_t": p + 0.01 * decay, "h_e": h_e, "f_des": f_des}
    labels = {"q": joints, "qd": joints, "qdd": joints, "tau": joints, "z": ("int_fx", "int_fy", "int_fz"),
              "x_err": pose, "x": pose, "p": xyz, "p_des": xyz, "jacobian_sv": ("sigma1", "sigma2", "sigma3"),
              "p_t": xyz, "h_e": ("fx", "fy", "fz", "mx", "my", "mz"), "f_des": xyz}
    units = {"q": ("m", "rad", "m"), "qd": ("m/s", "rad/s", "m/s"), "qdd": ("m/s²", "rad/s²", "m/s²"),
             "tau": ("N", "N·m", "N"), "z": ("N·s",) * 3, "x_err": pose_units, "x": pose_units,
             "p": ("m",) * 3, "p_des": ("m",) * 3, "jacobian_sv": ("",) * 3, "p_t": ("m",) * 3,
             "h_e": ("N",) * 3 + ("N·m",) * 3, "f_des": ("N",) * 3}
    if controller.get("type") != "AdmittanceControl":  # the compliant frame is the admittance's
        del signals["p_t"], labels["p_t"], units["p_t"]
    q = np.zeros((t.size, 3))
    tau = np.column_stack([np.zeros(t.size), 1.3 * decay[:, 0], 2.0 + 0 * t])
    return SimulationResult(t=t, q=q, qd=q, qdd=q, tau=tau, z=z, signals=signals, labels=labels, units=units,
                            meta={"scenario": "task", "controller": controller, "torque_limit": 20.0})


def test_every_panel_spans_the_run_and_traces_reach_its_end():
    """The time axis is [t[0], t[-1]] on every panel, and every trace reaches t[-1] although
    the runs end flat (decimation keeps the last sample)."""
    from armlab.viz.scopes import render_scope, scope_layout

    for result in (_synthetic_result(), _task_result({"type": "OperationalPD", "frame": "base"})):
        for scope in scope_layout(result):
            fig = render_scope(scope)
            for ax in fig.axes[:len(scope.panels)]:
                assert ax.get_xlim() == (result.t[0], result.t[-1]), scope.name
                for line in ax.lines:
                    if len(line.get_xdata()) > 2:  # a trace, not an axhline
                        assert line.get_xdata()[-1] == result.t[-1], scope.name
            plt.close(fig)


def test_titles_name_only_what_is_drawn():
    from armlab.viz.scopes import scope_layout

    result = _synthetic_result()
    assert scope_layout(result)[0].title == "joint positions q and references q_des"
    task = {s.name: s for s in scope_layout(_task_result({"type": "OperationalPD", "frame": "base"}))}
    assert task["positions"].title == "joint positions q"  # task-space runs log no q_des
    assert task["x_err"].title == "errors x_err (desired − actual, components in Σ_0)"
    assert [c[0] for c in task["p"].panels[1].curves] == ["actual", "desired"]


def test_force_control_draws_no_position_reference_and_admittance_its_compliant_frame():
    """Pure force control's p_des is an internal x_d = 0: not drawn (nor listed elsewhere);
    admittance control adds the compliant frame p_t and names the error Σ_t relative to Σ_e."""
    from armlab.viz.scopes import scope_layout

    force = {s.name: s for s in scope_layout(_task_result({"type": "ForceControl"}))}
    assert [c[0] for c in force["p"].panels[1].curves] == ["actual"]
    assert "no position reference" in force["p"].title
    assert all(c[0] != "p_des" for p in force["signals"].panels for c in p.curves)
    parallel = {s.name: s for s in scope_layout(_task_result({"type": "ParallelForcePosition"}))}
    assert [c[0] for c in parallel["p"].panels[1].curves] == ["actual", "desired"]
    admittance = _task_result({"type": "AdmittanceControl", "frame": "desired"})
    admittance = {s.name: s for s in scope_layout(admittance)}
    assert [c[0] for c in admittance["p"].panels[0].curves] == ["actual", "desired", "compliant p_t"]
    assert admittance["p"].panels[0].curves[2][3]["ls"] == ":"
    assert "Σ_t relative to Σ_e: compliant − actual" in admittance["x_err"].title


def test_other_signals_one_panel_per_unit_and_the_state_by_its_component_names():
    from armlab.viz.scopes import scope_layout

    signals = {s.name: s for s in scope_layout(_task_result({"type": "ForceControl"}))}["signals"]
    ylabels = [p.ylabel for p in signals.panels]
    assert ylabels == ["x (x, y, z) [m]", "x (φ1, φ2, φ3) [rad]", "controller state [N·s]"]
    assert [c[0] for c in signals.panels[1].curves] == ["φ1", "φ2", "φ3"]
    assert [c[0] for c in signals.panels[2].curves] == ["∫fx", "∫fy", "∫fz"]
    # Traces of one panel differ in dash and width, so one drawn over an equal one shows.
    styles = [(c[3]["ls"], c[3]["lw"]) for c in signals.panels[0].curves]
    assert len(set(styles)) == 3


def test_torque_limit_far_outside_the_data_is_said_not_drawn():
    from armlab.viz.scopes import scope_layout

    torques = {s.name: s for s in scope_layout(_task_result({"type": "ForceControl"}))}["torques"]
    for panel in torques.panels:  # |τ| ≤ 2 against ±20: every limit off-scale
        assert panel.hlines == [] and "±20 N·m limit" in panel.note or "±20 N limit" in panel.note
    saturated = {s.name: s for s in scope_layout(_synthetic_result(limit=2.0))}["torques"]
    assert all(len(panel.hlines) == 2 for panel in saturated.panels)


def test_singular_values_near_the_warning_threshold_on_a_log_axis():
    from armlab.viz.scopes import render_scope, scope_layout

    near = {s.name: s for s in scope_layout(_task_result({"type": "OperationalPD", "task": [0, 1, 2]},
                                                          sigma_min=0.01))}["singular_values"]
    panel = near.panels[0]
    assert panel.log and panel.hlines[0][0] == 0.02  # the task controllers' default threshold
    assert "min σ_min = 0.01" in panel.note
    fig = render_scope(near)
    assert fig.axes[0].get_yscale() == "log"
    plt.close(fig)
    far = {s.name: s for s in scope_layout(_task_result({"type": "OperationalPD"}))}["singular_values"]
    assert not far.panels[0].log and far.panels[0].hlines == []


def test_force_panel_gets_an_inset_around_f_d_when_a_transient_sets_the_scale():
    from armlab.viz.scopes import render_scope, scope_layout

    forces = {s.name: s for s in scope_layout(_task_result({"type": "ParallelForcePosition"},
                                                           transient=70.0))}["forces"]
    fy = forces.panels[1]
    assert fy.zoom is not None and fy.zoom.ylim[0] < -0.5 < fy.zoom.ylim[1]
    assert fy.zoom.start == pytest.approx(4.5, abs=1e-3) and fy.zoom.above
    fig = render_scope(forces)
    (inset,) = fig.axes[1].child_axes
    assert inset.get_xlim() == (fy.zoom.start, 6.0)
    plt.close(fig)
    calm = {s.name: s for s in scope_layout(_task_result({"type": "ParallelForcePosition"}))}["forces"]
    assert calm.panels[1].zoom is None


def test_legends_and_notes_sit_right_of_the_panels():
    """Nothing is drawn over a trace: every legend and note lies right of its panel."""
    from armlab.viz.scopes import render_scope, scope_layout

    result = _task_result({"type": "AdmittanceControl", "frame": "desired"}, transient=70.0)
    for scope in scope_layout(result):
        fig = render_scope(scope)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes[:len(scope.panels)]:
            right = ax.get_window_extent(renderer).x1
            boxes = [t.get_window_extent(renderer) for t in ax.texts]
            if ax.get_legend() is not None:
                boxes.append(ax.get_legend().get_window_extent(renderer))
            assert all(box.x0 > right for box in boxes), scope.name
            assert all(box.x1 <= fig.bbox.x1 for box in boxes), scope.name
        plt.close(fig)


def test_lyapunov_function_of_a_slotine_li_run_is_drawn_and_never_increases():
    """The A8 figure of V = ½ I σ² + ½ π̃ᵀ Γ⁻¹ π̃ (C6) from σ, π̂, the true π and Γ."""
    from armlab.scenarios import load_scenario
    from armlab.viz.layout import scope_layout
    from armlab.viz.theory import lyapunov_function

    result = load_scenario("a8_case1_sine").run(t_final=3.0)
    scopes = {s.name: s for s in scope_layout(result)}
    sigma_panel, V_panel = scopes["lyapunov"].panels
    assert [c[0] for c in sigma_panel.curves] == ["σ"]
    assert [c[0] for c in V_panel.curves][0] == "V" and V_panel.note.startswith("V never increases")
    true = np.array([0.1, 0.05, -0.981])
    sigma = result.signals["sigma"][:, 0]
    expected = 0.5 * true[0] * sigma**2 + 0.5 * np.sum((result.z - true) ** 2 / 0.5, axis=1)
    np.testing.assert_allclose(lyapunov_function(result)["V"], expected, rtol=1e-12)
    assert np.diff(expected).max() < 1e-9 * expected[0]
    assert "signals" not in scopes  # σ has its figure; Y is in the estimates
    mismatch = scopes["estimates"].panels[-1]
    assert mismatch.note.startswith("RMS, last 0.3 s")
    assert scopes["estimates"].caption == ""  # the switches' spikes are the square wave's
    square = {s.name: s for s in scope_layout(load_scenario("a8_case2_square").run(t_final=3.0))}
    assert "jumps at every switch" in square["estimates"].caption
    assert lyapunov_function(_synthetic_result()) is None


def test_frame_labels_are_over_the_links_and_apart():
    """Labels of the A1 drawings are drawn over the link solids and do not overlap each other
    on the screen (Σ_2 and Σ_3 of the PRP have close origins)."""
    from matplotlib.transforms import Bbox
    from mpl_toolkits.mplot3d import proj3d

    from armlab.viz.drawing import LABEL_ZORDER

    robot = armlab.load_robot("prp")
    for q in ([0.1, np.pi / 3, 0.1], [0.0, 0.0, 0.0]):
        for frame in ("base", "0"):
            fig = draw_robot(robot, q, frame=frame)
            fig.canvas.draw()
            renderer = fig.canvas.get_renderer()
            labels = list(fig.robot_artist.labels.values())
            assert all(label.get_zorder() == LABEL_ZORDER for label in labels)
            assert all(c.get_zorder() < LABEL_ZORDER for c in fig.axes[0].collections)
            boxes = []
            for label in labels:
                # Text3D measures its size, not its place: the centre is the projected position.
                size = label.get_window_extent(renderer)
                x, y, _ = proj3d.proj_transform(*label.get_position_3d(), fig.axes[0].get_proj())
                cx, cy = fig.axes[0].transData.transform((x, y))
                width, height = size.width, size.height
                boxes.append(Bbox.from_bounds(cx - width / 2, cy - height / 2, width, height))
            plt.close(fig)
            for i, a in enumerate(boxes):
                for b in boxes[i + 1:]:
                    assert not a.overlaps(b), (q, frame)


def test_animation_window_and_plane_follow_the_motion():
    """The animation covers the motion (not a long rest after it), and the environment plane
    is drawn large enough for the end effector's path along it."""
    from armlab.viz.animation import motion_window
    from armlab.viz.drawing import plane_axes, plane_covering

    t = np.linspace(0.0, 6.0, 6001)
    q = np.column_stack([np.clip(t, 0.0, 1.0), np.zeros_like(t), np.zeros_like(t)])
    assert motion_window(t, q) == pytest.approx(1.5, abs=0.01)  # done at 1 s, + 0.5 s at rest
    assert motion_window(t, np.column_stack([t, t, t])) == 6.0  # moves to the end
    plane = Plane((0.0, -0.2, 0.5), (0.0, 1.0, 0.0), half_size=0.25)
    path = np.column_stack([np.zeros(50), np.full(50, -0.2), np.linspace(0.5, -0.4, 50)])
    drawn = plane_covering(plane, path)
    u, v = plane_axes(drawn)
    offsets = path - np.asarray(drawn.point)
    assert np.abs(offsets @ u).max() <= drawn.half_size and np.abs(offsets @ v).max() <= drawn.half_size
    assert np.allclose(np.asarray(drawn.point)[1], -0.2)  # the same surface
    assert plane_covering(plane, path[:3]) is plane  # already large enough


def test_linear_response_matches_closed_forms():
    """(L) of armlab.viz.theory against solutions by hand: critically damped from an initial
    error, and a constant force from rest, e = (F/K)(1 − (1 + ω t) e^{−ω t})."""
    from armlab.viz.theory import linear_response

    t = np.linspace(0.0, 2.0, 2001)
    w = 5.0
    free = linear_response(np.eye(1), [[2 * w]], [[w * w]], t, [0.1], [0.3])
    np.testing.assert_allclose(free[:, 0], (0.1 + (0.3 + w * 0.1) * t) * np.exp(-w * t), atol=1e-12)
    M = np.diag([2.0, 1.0])
    force = np.tile([3.0, -1.0], (t.size, 1))
    forced = linear_response(M, M * 2 * w, M * w * w, t, [0.0, 0.0], [0.0, 0.0], force)
    shape = 1.0 - (1.0 + w * t) * np.exp(-w * t)
    np.testing.assert_allclose(forced, np.column_stack((3.0 / 50.0 * shape, -1.0 / 25.0 * shape)), atol=1e-12)
    assert linear_response(np.eye(1), [[1.0]], [[1.0]], np.array([0.0, 0.1, 0.3]), [1.0], [0.0]) is None


def test_computed_torque_errors_are_drawn_with_the_designed_response():
    """A run of the inverse-dynamics law gets q̃̈ + K_D q̃̇ + K_P q̃ = 0 from its own q̃(0),
    q̃̇(0) on its error panels; a PD run does not."""
    from dataclasses import replace

    from armlab.viz.scopes import scope_layout

    result = _synthetic_result()
    w = 4.0
    t = result.t
    e0, v0 = np.array([0.1, 0.5]), np.array([0.0, -1.0])
    q_err = (e0 + (v0 + w * e0) * t[:, None]) * np.exp(-w * t)[:, None]
    signals = {**result.signals, "q_err": q_err, "qd_err": np.gradient(q_err, t, axis=0)}
    signals["qd_err"][0] = v0
    labels = {**result.labels, "qd_err": result.labels["q_err"]}
    units = {**result.units, "qd_err": ("m/s", "rad/s")}
    controller = {"type": "JointInverseDynamics", "kp": np.diag([w * w] * 2).tolist(), "kd": [2 * w, 2 * w]}
    designed = replace(result, signals=signals, labels=labels, units=units,
                       meta={**result.meta, "controller": controller})
    scope = next(s for s in scope_layout(designed) if s.name == "q_err")
    for k, panel in enumerate(scope.panels):
        (curve,) = [c for c in panel.curves if c[0] == "designed"]
        np.testing.assert_allclose(curve[2], q_err[:, k], atol=1e-9)
    assert "designed" in scope.caption
    pd = replace(designed, meta={**designed.meta, "controller": {**controller, "type": "JointPDGravity"}})
    scope = next(s for s in scope_layout(pd) if s.name == "q_err")
    assert all(c[0] != "designed" for p in scope.panels for c in p.curves)


def _same_scope(a, b) -> bool:
    """Whether two scopes draw the same: title, caption, and every panel's labels, notes,
    lines and curves (their data compared value by value)."""
    if (a.name, a.title, a.caption, len(a.panels)) != (b.name, b.title, b.caption, len(b.panels)):
        return False
    for p, q in zip(a.panels, b.panels, strict=True):
        if (p.ylabel, p.note, p.note_at, p.log, p.zoom, p.hlines) != (q.ylabel, q.note, q.note_at, q.log,
                                                                     q.zoom, q.hlines):
            return False
        if len(p.curves) != len(q.curves):
            return False
        for (label, t, y, style), (label2, t2, y2, style2) in zip(p.curves, q.curves, strict=True):
            if (label, style) != (label2, style2) or not (np.array_equal(t, t2) and np.array_equal(y, y2)):
                return False
    return True


def test_main_scopes_are_the_layouts_figures_of_what_the_controller_is_for(monkeypatch):
    """The figures of a quick report: the tracking of the space the controller works in and the
    contact wrench, drawn exactly as in the whole layout, built without the others (a
    computed-torque run's designed error is never computed)."""
    from dataclasses import replace

    import armlab.viz.layout as layout

    joint = _synthetic_result()  # joint-space tracking and a contact force
    task = _task_result({"type": "OperationalPD", "frame": "base"})
    for result, names in ((joint, ["positions", "forces"]), (task, ["p", "forces"])):
        main = layout.main_scopes(result)
        assert [s.name for s in main] == names
        whole = {s.name: s for s in layout.scope_layout(result)}
        assert all(_same_scope(scope, whole[scope.name]) for scope in main)
        assert not _same_scope(whole["positions"], whole["forces"])  # the comparison can fail
    controller = {"type": "JointInverseDynamics", "kp": [16.0, 16.0], "kd": [8.0, 8.0]}
    designed = replace(joint, signals={**joint.signals, "qd_err": np.zeros_like(joint.q)},
                       labels={**joint.labels, "qd_err": joint.labels["q_err"]},
                       units={**joint.units, "qd_err": ("m/s", "rad/s")},
                       meta={**joint.meta, "controller": controller})

    def no_response(*args, **kwargs):
        raise AssertionError("the designed response was computed")

    from armlab.viz import theory

    monkeypatch.setattr(theory, "linear_response", no_response)
    with pytest.raises(AssertionError, match="designed response"):
        layout.scope_layout(designed)
    assert [s.name for s in layout.main_scopes(designed)] == ["positions", "forces"]


def test_position_scope_marks_the_spring_rest_position():
    from dataclasses import replace

    from armlab.viz.scopes import scope_layout

    result = _synthetic_result()
    t = result.t
    p = np.tile([0.0, -0.1, 0.4], (t.size, 1))
    signals = {**result.signals, "p": p, "p_des": p}
    labels = {**result.labels, "p": ("x", "y", "z"), "p_des": ("x", "y", "z")}
    units = {**result.units, "p": ("m",) * 3, "p_des": ("m",) * 3}
    environment = {"type": "Spring", "rest_position": [0.0, -0.2, 0.5]}
    spring = replace(result, signals=signals, labels=labels, units=units,
                     meta={**result.meta, "environment": environment})
    scope = next(s for s in scope_layout(spring) if s.name == "p")
    assert [[v for v, style in panel.hlines if "Σ_r" in style.get("label", "")] for panel in scope.panels] \
        == [[0.0], [-0.2], [0.5]]
    free = replace(spring, meta={**spring.meta, "environment": None})
    scope = next(s for s in scope_layout(free) if s.name == "p")
    assert all(not panel.hlines for panel in scope.panels)


def test_comparison_caption_measures_overshoot_and_the_state_saturation_leaves():
    """Overshoot relative to the initial error; after the torque leaves its limit at t_s the
    critically damped loop crosses zero iff q̃̇ + ω_n q̃ and q̃ differ in sign (by hand here:
    q̃ = e0 e^{−t/T} gives q̃̇ + ω_n q̃ = q̃ (ω_n − 1/T))."""
    from dataclasses import replace

    from armlab.viz.comparisons import Comparison, comparison_scope, overshoot

    assert overshoot(np.array([1.0, 0.5, -0.2, 0.1, 0.0])) == pytest.approx(20.0)
    assert overshoot(np.array([-0.5, 0.1, 0.0])) == pytest.approx(20.0)
    assert overshoot(np.array([0.0, 0.3])) == 0.0
    result = _synthetic_result(limit=2.0)    # τ_1 = 5 e^{−t} clipped at 2 until t = ln 2.5
    T = 0.4
    signals = {**result.signals, "qd_err": -result.signals["q_err"] / T}
    labels = {**result.labels, "qd_err": result.labels["q_err"]}
    units = {**result.units, "qd_err": ("m/s", "rad/s")}
    comparison = Comparison(7, "c", "title", ("a", "b"), ("free", "clipped"), window=0.3, torques=True)
    for kp, crosses in ((100.0, False), (1.0, True)):     # ω_n = 10 or 1 against 1/T = 2.5
        run = replace(result, signals=signals, labels=labels, units=units,
                      meta={**result.meta, "controller": {"type": "JointInverseDynamics", "kp": [kp, kp],
                                                           "kd": [1.0, 1.0]}})
        scope = comparison_scope(comparison, run, run)
        assert "d1 is at the limit for 917 ms" in scope.caption
        assert ("carries it past zero" in scope.caption) is crosses
        assert ("cannot carry it past zero" in scope.caption) is not crosses
        assert all(curve[1][-1] <= 0.3 for panel in scope.panels for curve in panel.curves)
        assert [p.ylabel for p in scope.panels][-2:] == ["τ d1 [N]", "τ θ2 [N·m]"]  # both clip
