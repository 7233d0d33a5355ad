"""The report's interactive 3-D views: one page per run in ``view3d/``, framed by a report that
still runs no script, plotly.js written once, every page asking for its two local scripts
only; headless Chromium draws a framed view (screenshot), plays it to its last frame at the
kinematics' pose, and reports no console error and no request; without plotly the report
says in one line that the views are left out."""

from __future__ import annotations

import base64
import json
import re
import sys

import numpy as np
import pytest

pytest.importorskip("plotly", reason="plotly is not installed (extra 'viewer')")

import armlab  # noqa: E402
from armlab.viz.report import build_report  # noqa: E402

RUNS = ("a6_pd_online", "a12_impedance_regulation")  # free motion; a contact with its plane
REPORT_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; frame-src 'self'"
VIEW_POLICY = "default-src 'none'; script-src 'self'; style-src 'unsafe-inline'; img-src data:"
SCRIPT = re.compile(r"<script\b([^>]*)>(.*?)</script>", re.S)


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    """A quick PRP report of two short runs, with their views."""
    from armlab.viz.experiments import discover

    out = tmp_path_factory.mktemp("report")
    experiments = [e for e in discover(armlab.load_robot("prp"), quick=True) if e.name in RUNS]
    path = build_report("prp", out, quick=True, show_progress=False, experiments=experiments, animation=False)
    return path, {e.name: e for e in experiments}


def _figure(page: str) -> dict:
    (block,) = [body for attrs, body in SCRIPT.findall(page) if 'type="application/json"' in attrs]
    return json.loads(block)


def _array(value) -> np.ndarray:
    """A plotly.js typed array ({"dtype", "bdata"}) or a plain list as a NumPy array."""
    if isinstance(value, dict):
        return np.frombuffer(base64.b64decode(value["bdata"]), dtype="<" + value["dtype"])
    return np.asarray(value, dtype=float)


def test_each_run_has_a_framed_page_and_the_report_runs_no_script(views):
    path, runs = views
    text = path.read_text(encoding="utf-8")
    assert "<script" not in text
    assert f'<meta http-equiv="Content-Security-Policy" content="{REPORT_POLICY}">' in text
    for name in runs:
        assert re.search(rf'<figure class="view3d" id="view-{name}" data-view3d="{name}">'
                         rf'<iframe loading="lazy" src="view3d/{name}.html"', text), name
    folder = path.parent / "view3d"
    from plotly.offline import get_plotlyjs

    (script,) = folder.glob("plotly-*.min.js")  # once for the whole report
    assert script.read_text(encoding="utf-8") == get_plotlyjs()
    assert sorted(p.name for p in folder.glob("*.html")) == sorted(f"{name}.html" for name in runs)
    for name in runs:
        page = (folder / f"{name}.html").read_text(encoding="utf-8")
        assert f'<meta http-equiv="Content-Security-Policy" content="{VIEW_POLICY}">' in page
        scripts = SCRIPT.findall(page)
        assert [re.search(r'src="([^"]+)"', a).group(1) for a, _ in scripts if "src=" in a] == \
            [script.name, "view3d.js"]
        assert [a for a, body in scripts if body.strip()] == [' type="application/json" id="figure"']
        assert "http:" not in page and "https:" not in page
        assert len(page) < 600_000, (name, len(page))  # float32 typed arrays, 60 frames


def test_a_page_holds_the_run_resampled_with_the_poses_of_the_kinematics(views):
    path, runs = views
    for name, exp in runs.items():
        figure = _figure((path.parent / "view3d" / f"{name}.html").read_text(encoding="utf-8"))
        count = min(60, len(exp.result))
        assert len(figure["frames"]) == count
        assert len(figure["layout"]["sliders"][0]["steps"]) == count
        names = [trace["name"] for trace in figure["data"]]
        assert ("environment" in names) == (exp.plane is not None)
        # The last frame is the run's last sample: the chain ends at Σ_e.
        chain = figure["frames"][-1]["data"][names.index("chain")]
        points = np.column_stack([_array(chain[axis]) for axis in "xyz"])
        T_base_e = armlab.forward_kinematics(exp.robot, exp.result.q[-1], frame="base")
        np.testing.assert_allclose(points[-1], T_base_e[:3, 3], atol=1e-6)  # float32: 0.1 µm


def test_without_plotly_the_report_has_no_views_and_says_so(tmp_path, monkeypatch):
    from armlab.viz.experiments import experiment_from_scenario

    for module in [m for m in sys.modules if m == "plotly" or m.startswith("plotly.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "plotly", None)  # import plotly raises ImportError
    path = build_report("prp", tmp_path, quick=True, show_progress=False, animation=False,
                        experiments=[experiment_from_scenario("a6_pd_online", 0.2)])
    text = path.read_text(encoding="utf-8")
    lines = [line for line in re.findall(r"<p>([^<]*)</p>", text) if "3-D views" in line]
    assert lines == ["The interactive 3-D views are left out: plotly is not installed "
                     "(pip install &#x27;armlab[viewer]&#x27;)."]
    assert "<iframe" not in text and "frame-src" not in text
    assert not (tmp_path / "view3d").exists()
    assert 'data-experiment="a6_pd_online"' in text  # the run itself is there


# A probe for the page's DOM: plays the view to its last frame and writes the chain's points
# as drawn (plotly's full data, decoded from the typed arrays) into a <pre>.
PROBE = """\
"use strict";
(function () {
  var view = document.getElementById("view");
  function say(text) {
    var out = document.createElement("pre"); out.id = "probe"; out.textContent = text;
    document.body.appendChild(out);
  }
  function attempt(tries) {
    if (!view.hasAttribute("data-drawn")) {
      if (tries > 0) { setTimeout(function () { attempt(tries - 1); }, 100); } else { say("not drawn"); }
      return;
    }
    Plotly.animate(view, ["LAST"], {frame: {duration: 0, redraw: true}, transition: {duration: 0},
                                    mode: "immediate"}).then(function () {
      var chain = view._fullData[0];
      say(JSON.stringify({x: Array.from(chain.x), y: Array.from(chain.y), z: Array.from(chain.z),
                          title: view.layout.title.text}));
    });
  }
  attempt(100);
})();
"""


def test_the_framed_view_renders_and_plays_in_headless_chromium_offline(views, tmp_path):
    """The report's element of a run's view, alone in a page with the report's head (policy,
    style): Chromium draws the view in its frame (link 2's orange on screen) with no console
    error and no request; the view played to its last frame puts Σ_e where the kinematics
    does.  Controls show the checks bite: an error thrown inside a framed page is seen, a
    script or frame from a network is blocked by the policies and reported."""
    from test_report import (
        BROWSER_SERVICES,
        CHROMIUM,
        WEBGL_FLAGS,
        _ConnectionRecorder,
        _console,
        _hosts,
        _run_chromium,
    )

    if CHROMIUM is None:
        pytest.skip("chromium not installed: apt-get install -y chromium (or .ci/run) to run this check")
    path, runs = views
    name = "a12_impedance_regulation"
    text = path.read_text(encoding="utf-8")
    element = re.search(rf'<figure class="view3d"[^>]*data-view3d="{name}">.*?</figure>', text, re.S).group(0)
    folder = path.parent

    def page(file: str, body: str):
        target = folder / file
        target.write_text(re.sub(r"<main>.*</main>", lambda _: f"<main>{body}</main>", text, flags=re.S),
                          encoding="utf-8")
        return target

    framed = page("framed.html", element)
    blank = page("blank.html", re.sub(r'<iframe loading="lazy" src="[^"]*"', '<iframe src="about:blank"',
                                      element))
    view = (folder / "view3d" / f"{name}.html").read_text(encoding="utf-8")
    last = str(len(_figure(view)["frames"]) - 1)
    (folder / "view3d" / "probe.js").write_text(PROBE.replace("LAST", last), encoding="utf-8")
    probed = folder / "view3d" / "probed.html"
    probed.write_text(view.replace("</body>", '<script src="probe.js"></script></body>'), encoding="utf-8")
    (folder / "view3d" / "planted.js").write_text('throw new Error("planted");', encoding="utf-8")
    (folder / "view3d" / "planted.html").write_text(view.replace(
        "</body>", '<script src="planted.js"></script><script src="http://example.invalid/x.js"></script>'
                   "</body>"), encoding="utf-8")
    controls = page("controls.html", '<iframe src="view3d/planted.html"></iframe>'
                                     '<iframe src="http://example.invalid/frame.html"></iframe>')
    empty = page("empty.html", "")
    shot_path, blank_path = tmp_path / "framed.png", tmp_path / "blank.png"
    recorder = _ConnectionRecorder()
    try:
        _run_chromium(tmp_path, empty, [*WEBGL_FLAGS, "--dump-dom"], recorder.port)
        background, recorder.requests = _hosts(recorder.requests), []
        shot = _run_chromium(tmp_path, framed, [*WEBGL_FLAGS, "--window-size=1100,1000",
                                                f"--screenshot={shot_path}"], recorder.port)
        played = _run_chromium(tmp_path, probed, [*WEBGL_FLAGS, "--dump-dom"], recorder.port)
        _run_chromium(tmp_path, blank, ["--window-size=1100,1000", f"--screenshot={blank_path}"],
                      recorder.port)
        requests, recorder.requests = list(recorder.requests), []
        control = _run_chromium(tmp_path, controls, [*WEBGL_FLAGS, "--dump-dom"], recorder.port)
        control_requests = list(recorder.requests)
    finally:
        recorder.close()
    assert shot.returncode == 0 and played.returncode == 0, shot.stderr[-2000:]
    assert _console(shot.stderr) == [] and _console(played.stderr) == []
    assert _hosts(requests) - background - BROWSER_SERVICES == set()
    # The controls: the planted error is seen, the network script and frame are refused by the
    # policies (and reported), and nothing reached the network.
    seen = _console(control.stderr)
    assert any("Uncaught Error: planted" in line for line in seen)
    assert any("example.invalid/x.js" in line and "Content Security Policy" in line for line in seen)
    assert any("Framing 'http://example.invalid/'" in line and "frame-src 'self'" in line for line in seen)
    assert "example.invalid" not in _hosts(control_requests)

    from PIL import Image

    def ink(png) -> tuple[np.ndarray, float]:
        """The pixels of a screenshot and the share of them that is neither the report's page
        colour nor white."""
        with Image.open(png) as image:
            pixels = np.asarray(image.convert("RGB"), dtype=int)
        inked = (np.any(np.abs(pixels - [0xfb, 0xfc, 0xfd]) > 12, axis=2)
                 & np.any(np.abs(pixels - 255) > 12, axis=2))
        return pixels, float(inked.mean())

    pixels, drawn_ink = ink(shot_path)
    _, blank_ink = ink(blank_path)  # the same page with an empty frame: header, caption, border
    assert drawn_ink > 1.8 * blank_ink, (drawn_ink, blank_ink)
    orange = (np.abs(pixels[..., 0] - 235) < 25) & (np.abs(pixels[..., 1] - 160) < 30) & (pixels[..., 2] < 90)
    assert orange.sum() > 200, orange.sum()  # link 2 (#f0a030, shaded) drawn by WebGL in the frame

    probe = re.search(r'<pre id="probe">(.*?)</pre>', played.stdout, re.S)
    assert probe is not None, played.stdout[-2000:]
    drawn = json.loads(probe.group(1).replace("&quot;", '"'))
    exp = runs[name]
    T_base_e = armlab.forward_kinematics(exp.robot, exp.result.q[-1], frame="base")
    np.testing.assert_allclose([drawn[axis][-1] for axis in "xyz"], T_base_e[:3, 3], atol=1e-6)
    assert drawn["title"].startswith(f"prp: t = {exp.result.t[-1]:.2f} s")
