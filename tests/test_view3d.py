"""The interactive 3-D view (plotly): the scene matches the robot's kinematics frame by frame,
the HTML file is self-contained, and headless Chromium renders it with no console error and
no network request."""

from __future__ import annotations

import re

import numpy as np
import pytest

go = pytest.importorskip("plotly.graph_objects", reason="plotly is not installed (extra 'viewer')")

import armlab  # noqa: E402
from armlab.kinematics import link_frames  # noqa: E402
from armlab.scenarios import load_scenario  # noqa: E402
from armlab.viz.view3d import MAX_FRAMES, view3d, write_view3d  # noqa: E402


@pytest.fixture(scope="module")
def contact_run():
    return load_scenario("a12_impedance_regulation").run(t_final=1.0)


def traces_by_name(figure):
    return {trace.name: k for k, trace in enumerate(figure.data)}


def test_a_robot_is_drawn_with_its_links_frames_and_chain():
    robot = armlab.load_robot("prp")
    q = np.array([0.1, np.pi / 3, 0.1])
    figure = view3d(robot, q)
    names = traces_by_name(figure)
    assert {"chain", "link2", "link3", "link4", "x axes", "y axes", "z axes", "frames"} <= set(names)
    assert not figure.frames and "environment" not in names
    frames = link_frames(robot, q, frame="base")
    for i, link in enumerate(robot.links):
        mesh = figure.data[names[link.name]]
        vertices = np.column_stack([mesh.x, mesh.y, mesh.z])
        # Box and cylinder vertices are symmetric about the centre of mass: their mean is it.
        expected = frames[i + 1] @ np.append(link.inertial.com, 1.0)
        np.testing.assert_allclose(vertices.mean(axis=0), expected[:3], atol=1e-12)
    labels = figure.data[names["frames"]].text
    assert labels[0] == "Σ_base" and labels[-1] == "Σ_3 = Σ_e"


def test_a_run_is_animated_frame_by_frame_with_play_pause_and_a_slider(contact_run):
    figure = view3d(contact_run)
    robot = armlab.load_robot("prp")
    count = min(MAX_FRAMES, len(contact_run))
    assert len(figure.frames) == count
    assert [b.label for b in figure.layout.updatemenus[0].buttons] == ["▶ play", "❚❚ pause"]
    steps = figure.layout.sliders[0].steps
    assert len(steps) == count and steps[-1].label == f"{contact_run.t[-1]:.2f}"
    names = traces_by_name(figure)
    assert "environment" in names  # the A11 spring's plane
    last = figure.frames[-1]
    link4 = last.traces.index(names["link4"])
    vertices = np.column_stack([last.data[link4].x, last.data[link4].y, last.data[link4].z])
    T_3 = link_frames(robot, contact_run.q[-1], frame="base")[3]
    expected = T_3 @ np.append(robot.links[2].inertial.com, 1.0)
    np.testing.assert_allclose(vertices.mean(axis=0), expected[:3], atol=1e-12)
    # The axes do not move while the motion plays.
    ranges = [figure.layout.scene[f"{axis}axis"].range for axis in "xyz"]
    assert all(r is not None and r[1] > r[0] for r in ranges)


def test_a_notebook_shows_the_view_with_plotly_inside_and_no_cdn():
    bundle = view3d(armlab.load_robot("prp"))._repr_mimebundle_()
    assert list(bundle) == ["text/html"]
    assert "Plotly.newPlot" in bundle["text/html"] and len(bundle["text/html"]) > 3_000_000
    assert not re.findall(r"<script[^>]*\bsrc=", bundle["text/html"])  # no MathJax, no plotly CDN


def test_the_html_file_carries_plotly_and_asks_for_nothing(contact_run, tmp_path):
    path = write_view3d(contact_run, tmp_path / "view.html")
    text = path.read_text(encoding="utf-8")
    assert "Plotly.newPlot" in text and len(text) > 3_000_000  # plotly.js is inside
    from test_report import _elements

    page = _elements(text)  # an HTML parser: script bodies are not markup
    assert page.urls == [] and page.images == []
    assert len(re.findall(r"<script", text)) >= 2 and not re.findall(r"<script[^>]*\bsrc=", text)


def test_the_view_renders_in_headless_chromium_offline(contact_run, tmp_path):
    from test_report import (
        BROWSER_SERVICES,
        CHROMIUM,
        WEBGL_FLAGS,
        _ConnectionRecorder,
        _hosts,
        _run_chromium,
    )
    from test_report import _console as _errors

    if CHROMIUM is None:
        pytest.skip("chromium not installed: apt-get install -y chromium to run this check")
    page = write_view3d(contact_run, tmp_path / "view.html")
    empty = tmp_path / "empty.html"
    empty.write_text("<!DOCTYPE html><html><body></body></html>", encoding="utf-8")
    gl = WEBGL_FLAGS
    shot_path = tmp_path / "view.png"
    recorder = _ConnectionRecorder()
    try:
        _run_chromium(tmp_path, empty, [*gl, "--dump-dom"], recorder.port)
        background, recorder.requests = _hosts(recorder.requests), []
        dom = _run_chromium(tmp_path, page, [*gl, "--dump-dom"], recorder.port)
        shot = _run_chromium(tmp_path, page, [*gl, "--window-size=1100,800", f"--screenshot={shot_path}"],
                             recorder.port)
        requests = list(recorder.requests)
        broken = tmp_path / "broken.html"
        broken.write_text(page.read_text(encoding="utf-8").replace(
            "</body>", '<script>throw new Error("planted")</script></body>'), encoding="utf-8")
        control = _run_chromium(tmp_path, broken, [*gl, "--dump-dom"], recorder.port)
    finally:
        recorder.close()
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert _hosts(requests) - background - BROWSER_SERVICES == set()
    assert _errors(dom.stderr) == [] and _errors(shot.stderr) == []
    assert any("Uncaught Error: planted" in line for line in _errors(control.stderr))  # the check bites
    rendered = re.sub(r"<script.*?</script>", "", dom.stdout, flags=re.DOTALL)  # the page, not plotly.js
    assert 'class="plot-container plotly"' in rendered and re.search(r'gl-container.*?<canvas', rendered)
    assert "WebGL is not supported" not in rendered
    assert "▶ play" in rendered and "slider" in rendered
    from PIL import Image

    with Image.open(shot_path) as image:
        pixels = np.asarray(image.convert("RGB"), dtype=int)
    # The links drawn by WebGL: pixels in the orange of link 2 (#f0a030, shaded).
    orange = (np.abs(pixels[..., 0] - 235) < 25) & (np.abs(pixels[..., 1] - 160) < 30) & (pixels[..., 2] < 90)
    assert orange.sum() > 200
