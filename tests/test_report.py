"""The HTML report: built from the registry, self-contained, and rendered by headless Chromium
with no console error and no network request."""

from __future__ import annotations

import base64
import io
import re
import shutil
import socket
import threading
from html.parser import HTMLParser

import numpy as np
import pytest

from armlab.viz.report import assignment_number, build_report
from processes import run_bounded

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
CHROMIUM = next((shutil.which(n) for n in BROWSERS if shutil.which(n)), None)
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run",
                  "--disable-default-apps", "--enable-logging=stderr", "--v=0",
                  "--disable-features=OptimizationHints,OptimizationHintsFetching,"
                  "OptimizationGuideModelDownloading"]
# WebGL without a GPU (the report's 3-D views): Chromium's software renderer, and time for the
# framed view pages to load and draw before the DOM is dumped or the screenshot taken.
WEBGL_FLAGS = ["--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--virtual-time-budget=8000"]
# The browser's own services, which it may contact on any page whether or not the empty
# baseline page happened to see them (sign-in, updates, push messaging — GCM registers once
# the browser has run for a while): never a page's resources.
BROWSER_SERVICES = {"accounts.google.com", "clients2.google.com", "update.googleapis.com",
                    "optimizationguide-pa.googleapis.com", "android.clients.google.com"}


class _Elements(HTMLParser):
    """Collects sections, experiments, figures, images and MathML elements of a page."""

    def __init__(self):
        super().__init__()
        self.sections, self.experiments, self.figures, self.images, self.math = [], [], [], [], 0
        self.urls = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "section" and "data-assignment" in attrs:
            self.sections.append(attrs["data-assignment"])
        if tag == "article" and "data-experiment" in attrs:
            self.experiments.append(attrs["data-experiment"])
        if tag == "figure" and "data-figure" in attrs:
            self.figures.append(attrs["data-figure"])
        if tag == "img":
            self.images.append(attrs.get("src", ""))
        if tag == "math":
            self.math += 1
        for key in ("src", "href"):
            if key in attrs and not attrs[key].startswith(("data:", "#")):
                self.urls.append(attrs[key])


def _elements(text: str) -> _Elements:
    parser = _Elements()
    parser.feed(text)
    return parser


SAMPLED_ASSIGNMENTS = (6, 7, 8, 11)


def _one_per_assignment(experiments):
    """The first experiment of a few assignments — joint space, adaptive and interaction: every
    compiled control loop costs tens of seconds to build, and the scenario tests build them all."""
    chosen = {}
    for exp in experiments:
        if exp.assignment in SAMPLED_ASSIGNMENTS:
            chosen.setdefault(exp.assignment, exp)
    return list(chosen.values())


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A quick report of the PRP: every derivation, short runs of one scenario of A6, A7, A8 and
    A11 (`armlab report` runs them all; the registry test below checks they are all found)."""
    import armlab
    from armlab.viz.experiments import discover

    out = tmp_path_factory.mktemp("report")
    experiments = _one_per_assignment(discover(armlab.load_robot("prp"), quick=True))
    path = build_report("prp", out, quick=True, show_progress=False, experiments=experiments)
    return path, [e.name for e in experiments]


def test_every_registered_scenario_of_the_robot_is_discovered():
    import armlab
    import armlab.scenarios as registry
    from armlab.viz.experiments import discover

    experiments = discover(armlab.load_robot("prp"), quick=True)
    expected = [s.name for s in registry.list_scenarios() if s.plant.name in ("prp", "link1")
                or s.plant.name.startswith("prp_")]
    assert sorted(e.name for e in experiments) == sorted(expected)
    for exp in experiments:
        assert f"A{exp.assignment}" in exp.title or exp.assignment == assignment_number(exp.name)
        assert exp.t_final is None or exp.t_final <= 2.0


def test_assignment_numbers_are_read_from_names():
    assert assignment_number("a07_step_mismatch") == 7
    assert assignment_number("A14: force control") == 14
    assert assignment_number("assignment 3") == 3
    assert assignment_number("a16") is None
    assert assignment_number("planar") is None


def test_report_is_self_contained_and_complete(report):
    report, scenarios = report
    text = report.read_text(encoding="utf-8")
    page = _elements(text)
    # Every image is a data: URI, every link an anchor; the only other addresses are the
    # runs' 3-D view pages next to the report (tests/test_report_views.py checks them).
    assert page.urls == [f"view3d/{name}.html" for name in page.experiments]
    assert {"A1", "A2", "A3", "A4", "A5"} <= set(page.sections)
    assert {f"A{assignment_number(n)}" for n in scenarios} <= set(page.sections)
    assert page.math > 50  # the derivations are there as MathML
    assert {"fig-robot-pose-base", "fig-robot-pose-0", "fig-animation"} <= set(page.figures)
    assert sorted(page.experiments) == sorted(scenarios)
    for name in scenarios:
        number = assignment_number(name)
        assert f"A{number}" in page.sections if number else "other" in page.sections
        assert any(f.startswith(f"fig-{name}-") for f in page.figures), name
        assert f"fig-{name}-loop" in page.figures, name  # its block diagram
    from PIL import Image

    for src in page.images:
        kind, payload = src.split(",", 1)
        assert kind in ("data:image/png;base64", "data:image/gif;base64")
        with Image.open(io.BytesIO(base64.b64decode(payload))) as image:
            image.verify()


def test_quick_report_draws_the_main_scopes_of_each_run_alone(report):
    """--quick draws what each controller is for and nothing else: the joint tracking of the
    joint-space laws (A6, A7), with the parameter estimates of the adaptive one (A8), the
    task-space tracking and the contact wrench of compliance control (A11)."""
    path, scenarios = report
    figures = _elements(path.read_text(encoding="utf-8")).figures
    drawn = {name: [f.removeprefix(f"fig-{name}-") for f in figures if f.startswith(f"fig-{name}-")]
             for name in scenarios}
    # Each after its closed loop's block diagram.
    assert drawn == {"a6_pd_online": ["loop", "positions"], "a7_id_via_points": ["loop", "positions"],
                     "a8_case1_sine": ["loop", "positions", "estimates"],
                     "a11_compliance": ["loop", "p", "forces"]}


class _ConnectionRecorder:
    """A local proxy that accepts and records every connection the browser tries to make."""

    def __init__(self):
        self.server = socket.socket()
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(16)
        self.server.settimeout(0.2)
        self.port = self.server.getsockname()[1]
        self.requests: list[str] = []
        self.running = True
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while self.running:
            try:
                conn, _ = self.server.accept()
            except OSError:
                continue
            with conn:
                conn.settimeout(1.0)
                try:
                    line = conn.recv(200).decode("latin-1").split("\r\n")[0]
                    # A socket closed before its first byte asked for nothing (Chromium
                    # opens spare connections to its proxy and drops them at exit).
                    if line:
                        self.requests.append(line)
                except OSError:
                    self.requests.append("<connection>")

    def close(self):
        self.running = False
        self.thread.join(timeout=2)
        self.server.close()


def _run_chromium(tmp_path, page, extra, proxy_port):
    profile = tmp_path / f"profile-{len(list(tmp_path.iterdir()))}"
    command = [CHROMIUM, *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
               f"--proxy-server=http://127.0.0.1:{proxy_port}", "--proxy-bypass-list=<-loopback>",
               *extra, page.as_uri()]
    return run_bounded(command, timeout=120)


def _hosts(requests: list[str]) -> set[str]:
    """Host names of proxied request lines ("CONNECT h:443 …", "GET http://h/… …")."""
    hosts = set()
    for line in requests:
        parts = line.split()
        target = parts[1] if len(parts) > 1 else line
        hosts.add(re.sub(r"^[a-z]+://", "", target).split("/")[0].split(":")[0])
    return hosts


# Advisories Chromium itself writes to the console while WebGL runs on its software renderer
# (a canvas read back often, the driver stalling on ReadPixels): not messages of the page.
BROWSER_NOTES = ("Canvas2D: Multiple readback operations using getImageData",
                 "GL Driver Message (OpenGL, Performance")


def _console(log: str) -> list[str]:
    """The console messages, errors and failed loads of a Chromium log, but for
    :data:`BROWSER_NOTES`."""
    return [line for line in log.splitlines() if re.search(r"CONSOLE|Uncaught|Failed to load", line)
            and not any(note in line for note in BROWSER_NOTES)]


def test_report_renders_in_headless_chromium(report, tmp_path):
    """No console error, no request of the page's own, every section and figure rendered.

    The browser contacts its own services (component updater, sign-in) even with background
    networking disabled; those hosts are measured on an empty page and allowed, any other
    request fails the test.  A page with an external image shows that both checks bite."""
    if CHROMIUM is None:
        pytest.skip("chromium not installed: apt-get install -y chromium (or .ci/run) to run this check")
    report, _ = report
    from armlab.viz.html import document

    empty = tmp_path / "empty.html"
    empty.write_text(document("empty", [], [], ""), encoding="utf-8")
    leaky = tmp_path / "leaky.html"
    leaky.write_text(document("leaky", [], [], '<img alt="x" src="http://example.invalid/x.png">'),
                     encoding="utf-8")
    recorder = _ConnectionRecorder()
    try:
        baseline = _run_chromium(tmp_path, empty, ["--dump-dom"], recorder.port)
        background, recorder.requests = _hosts(recorder.requests), []
        dom = _run_chromium(tmp_path, report, [*WEBGL_FLAGS, "--dump-dom"], recorder.port)
        shot_path = tmp_path / "report.png"
        shot = _run_chromium(tmp_path, report, [*WEBGL_FLAGS, "--window-size=1280,1600",
                                                f"--screenshot={shot_path}"], recorder.port)
        requests, recorder.requests = list(recorder.requests), []
        control = _run_chromium(tmp_path, leaky, ["--dump-dom"], recorder.port)
    finally:
        recorder.close()
    assert baseline.returncode == 0 and dom.returncode == 0, dom.stderr[-2000:]
    assert _hosts(requests) - background - BROWSER_SERVICES == set()
    assert _console(dom.stderr) == [] and _console(shot.stderr) == []
    assert any("example.invalid" in line for line in _console(control.stderr))  # the check can fail

    rendered, source = _elements(dom.stdout), _elements(report.read_text(encoding="utf-8"))
    assert rendered.sections == source.sections and "A1" in rendered.sections
    assert rendered.experiments == source.experiments
    assert rendered.figures == source.figures and len(rendered.figures) >= 3
    assert rendered.math == source.math
    # The formulas as the browser holds them: dotted rates, Greek letters, true minus signs.
    formulas = "".join(re.findall(r"<math.*?</math>", dom.stdout, re.S))
    assert "<mover" in formulas and "\u0307" not in formulas
    assert "varphi" not in formulas and "vartheta" not in formulas and "\u03d1" in formulas
    assert "<mo>-</mo>" not in formulas and "<mo>\u2212</mo>" in formulas
    from PIL import Image

    with Image.open(shot_path) as image:
        pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.shape == (1600, 1280)
    assert pixels.std() > 10.0  # the page drew text and figures, not a blank viewport


def test_animation_subject_is_chosen_early_only_when_no_pending_run_can_change_it():
    """The report draws its GIF while runs are still going once the choice is final: the run
    of the report's robot with a plane that moved most, and no unfinished run of the robot
    with a plane left."""
    from types import SimpleNamespace

    import armlab
    from armlab.viz.drawing import Plane
    from armlab.viz.report import Experiment, animation_subject

    prp, link1 = armlab.load_robot("prp"), armlab.load_robot("link1")
    wall = Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))

    def run(name, robot, travel, plane=None, status="ok", done=True):
        exp = Experiment(name=name, assignment=11, title=name, description="", parameters=[],
                         robot=robot, plane=plane)
        if done:
            q = np.zeros((2, robot.n))
            q[1, 0] = travel
            exp.result = SimpleNamespace(t=np.array([0.0, 1.0]), q=q, status=status)
        return exp

    small, big = run("small", prp, 0.1, wall), run("big", prp, 0.3, wall)
    free = run("free", prp, 5.0)  # moves most, but has no plane
    other = run("other", link1, 9.0, wall)  # another robot
    assert animation_subject([small, big, free, other], "prp", final=False) is big
    pending = run("pending", prp, 0.0, wall, done=False)
    assert animation_subject([small, big, pending], "prp", final=False) is None
    assert animation_subject([small, big, pending], "prp") is big
    pending_free = run("pending_free", prp, 0.0, done=False)
    assert animation_subject([small, pending_free], "prp", final=False) is small
    diverged = run("diverged", prp, 0.9, wall, status="diverged")
    assert animation_subject([diverged, free], "prp", final=False) is None  # not a final choice yet
    assert animation_subject([diverged, free], "prp") is free
    assert animation_subject([], "prp") is None
    # A run that took a joint past its limits (into its stop) is not animated: the arm would
    # slide through its end stop instead of showing its course.
    past = run("past_its_stop", prp, 0.8, wall)
    past.result.meta = {"joint_limits": {"mode": "warn", "crossed": {"d3": {"t": 0.5}}}}
    assert animation_subject([small, big, past], "prp") is big
    assert animation_subject([past], "prp") is past  # the only run there is


def _ink_runs(pixels: np.ndarray) -> int:
    """Runs of consecutive rows that hold ink (dark pixels) in a grey image."""
    inked = (pixels < 128).any(axis=1).astype(int)
    return int(np.sum(np.diff(np.concatenate([[0], inked])) == 1))


FIREFOX = next((shutil.which(n) for n in ("firefox-esr", "firefox") if shutil.which(n)), None)


def _screenshot(browser: str, tmp_path, page, width: int, height: int):
    """A headless screenshot of ``page`` by ``browser`` ("chromium" or "firefox"), or a skip."""
    shot_path = tmp_path / f"{browser}.png"
    if browser == "chromium":
        if CHROMIUM is None:
            pytest.skip("chromium not installed: apt-get install -y chromium (or .ci/run) to run this check")
        recorder = _ConnectionRecorder()
        try:
            shot = _run_chromium(tmp_path, page, [f"--window-size={width},{height}",
                                                  f"--screenshot={shot_path}"], recorder.port)
        finally:
            recorder.close()
    else:
        if FIREFOX is None:
            pytest.skip("firefox not installed: apt-get install -y firefox-esr to run this check")
        profile = tmp_path / "firefox-profile"
        profile.mkdir()
        shot = run_bounded([FIREFOX, "--headless", "--profile", str(profile),
                            f"--window-size={width},{height}", "--screenshot", str(shot_path),
                            page.as_uri()], timeout=180)
    assert shot.returncode == 0 and shot_path.exists(), shot.stderr[-2000:]
    from PIL import Image

    with Image.open(shot_path) as image:
        return np.asarray(image.convert("L"), dtype=float)


@pytest.mark.parametrize("browser", ["chromium", "firefox"])
def test_time_derivatives_render_with_a_separate_dot(browser, tmp_path):
    """θ̇, ḋ and θ̈ as the report prints them, drawn by the browser with the report's style:
    dots above the letter with background between them (a dot fused into the letter, or none,
    gives one run of inked rows, as the plain θ of the control does)."""
    import sympy as sp

    from armlab.symbolic import to_mathml
    from armlab.viz.html import document

    names = ("thetadot", "ddot", "thetaddot", "theta")
    boxes = "".join(f'<div style="position:absolute;left:20px;top:{20 + 160 * k}px">'
                    f'<math style="font-size:80px">{to_mathml(sp.Symbol(name))}</math></div>'
                    for k, name in enumerate(names))
    page = tmp_path / "dots.html"
    page.write_text(document("dots", [], [], '<div style="position:fixed;inset:0;background:#fff;'
                                             f'z-index:9">{boxes}</div>'), encoding="utf-8")
    pixels = _screenshot(browser, tmp_path, page, 300, 680)
    runs = [_ink_runs(pixels[10 + 160 * k: 170 + 160 * k]) for k in range(len(names))]
    assert runs == [2, 2, 2, 1], dict(zip(names, runs))


def test_experiments_come_in_the_seeds_order():
    """Option 1 before option 3 (A6), free motion before contact (A15): an explicit order,
    which alphabetical order would break."""
    import armlab
    from armlab.viz.experiments import discover

    names = [e.name for e in discover(armlab.load_robot("prp"), quick=True)]
    assert names.index("a6_pd_online") < names.index("a6_pd_none") < names.index("a6_pd_desired")
    assert names.index("a15_parallel_free") < names.index("a15_parallel_contact")
    assert sorted(names) != names
    numbers = [assignment_number(n) for n in names]
    assert numbers == sorted(numbers)


def test_seed_notes_are_read_from_the_docs_pages(tmp_path):
    """Each section's notes come from its page's section about the seed, rendered as HTML
    (lists, code, emphasis, tables; prose escaped), read at build time: a changed page shows."""
    from armlab.viz.notes import DOCS, markdown_html, seed_notes

    page = (tmp_path / "A7-x.md")
    page.write_text("# A7\n\nintro\n\n## Results\n\nnot this\n\n## Notes on the seed\n\n"
                    "* one `τ < 1` **two**\n  continued\n\n      code line\n* three\n\n"
                    "| a | b |\n|---|---|\n| 1 | *x* |\n\n## Any robot\n\nnot this either\n",
                    encoding="utf-8")
    ((heading, text),) = seed_notes(7, tmp_path)
    assert heading == "Notes on the seed" and "not this" not in text
    rendered = markdown_html(text)
    assert rendered.startswith("<ul><li><p>one <code>τ &lt; 1</code> <strong>two</strong> continued")
    assert "<pre>code line</pre>" in rendered and "<li>three</li>" in rendered
    assert "<td><em>x</em></td>" in rendered
    assert seed_notes(9, tmp_path) == []
    # The shipped pages: every assignment A1–A15 has its note.
    assert all(seed_notes(n, DOCS) for n in range(1, 16))


def test_report_shows_each_sections_seed_note_and_the_metric_definitions(report):
    report, scenarios = report
    text = report.read_text(encoding="utf-8")
    import html as html_module

    from armlab.viz.notes import DOCS, seed_notes

    sections = dict(re.findall(r'data-assignment="([^"]+)">(.*?)</section>', text, re.S))
    for number in (1, 2, 3, 4, 5, *{assignment_number(n) for n in scenarios}):
        body = sections[f"A{number}"]
        assert '<aside class="seed-note">' in body, number
        # A sentence of the page's own note, as the reader sees it in the section.
        first = seed_notes(number, DOCS)[0][1]
        words = re.sub(r"[`*]", "", first.split("\n")[0].lstrip("* ")).split()[:6]
        assert html_module.escape(" ".join(words), quote=False) in re.sub(r"<[^>]+>", "", body), number
    assert "steady state" in sections["metrics"] and "settling time" in sections["metrics"]
    assert "oscillation" in sections["metrics"] and "band around the final value" in sections["metrics"]


def test_derivations_are_kept_on_disk_keyed_by_robot_and_sources(tmp_path, monkeypatch):
    """The A1–A5 HTML is derived once per robot and code version; a damaged file is derived
    anew (and replaced whole), another robot gets its own file."""
    import armlab
    from armlab.progress import progress_bar
    from armlab.viz import report as report_module

    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
    calls = []

    def derive(robot, progress, budget):
        calls.append(robot.name)
        return {1: f"<p>{robot.name}</p>", 2: "<p>two</p>"}, True

    monkeypatch.setattr(report_module, "_symbolic_sections", derive)
    prp, planar = armlab.load_robot("prp"), armlab.load_robot("planar2r")
    quiet = progress_bar(1, enabled=False)
    first = report_module._cached_symbolic_sections(prp, quiet)
    assert report_module._cached_symbolic_sections(prp, quiet) == first == {1: "<p>prp</p>", 2: "<p>two</p>"}
    assert calls == ["prp"]
    path = report_module._derivation_cache(prp)
    assert path.is_relative_to(tmp_path) and path != report_module._derivation_cache(planar)
    path.write_text('{"1": "<p>half', encoding="utf-8")
    assert report_module._cached_symbolic_sections(prp, quiet) == first and calls == ["prp", "prp"]
    assert report_module._cached_symbolic_sections(planar, quiet) == {1: "<p>planar2r</p>", 2: "<p>two</p>"}
    assert not list(path.parent.glob("*.tmp"))


def test_quick_report_runs_the_first_scenario_of_each_assignment():
    import armlab
    from armlab.viz.experiments import discover
    from armlab.viz.report import first_of_each_assignment

    every = discover(armlab.load_robot("prp"), quick=True)
    chosen = first_of_each_assignment(every)
    assert [e.assignment for e in chosen] == sorted({e.assignment for e in every})
    assert chosen[0].name == "a6_pd_online" and all(e.t_final <= 2.0 for e in chosen if e.t_final)


def test_a_report_worker_leaves_when_its_parent_is_killed(tmp_path):
    """kill -9 of the report leaves no worker running on (they would run for minutes)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    # The worker is busy (as a report's are, for minutes) when its parent dies.
    script = ("import os, threading, time\n"
              "from multiprocessing import get_context\n"
              "from concurrent.futures import ProcessPoolExecutor\n"
              "from armlab.viz import report_runs\n"
              "pool = ProcessPoolExecutor(1, mp_context=get_context('spawn'),\n"
              "                           initializer=report_runs._init_worker, initargs=((), os.getpid()))\n"
              "print(pool.submit(os.getpid).result(), flush=True)\n"
              "pool.submit(time.sleep, 120)\n"
              "threading.Event().wait()\n")
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    import select

    # The parent prints its worker's pid within seconds; never wait on it without an end.
    if not select.select([parent.stdout], [], [], 300)[0]:
        parent.kill()
        raise AssertionError("the report's pool started no worker within 300 s")
    worker = int(parent.stdout.readline())
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    for _ in range(100):
        try:
            os.kill(worker, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    os.kill(worker, signal.SIGKILL)
    raise AssertionError("the worker outlived its killed parent by 10 s")


def test_every_equation_tag_an_experiment_names_is_defined_in_it(report):
    """Each article and seed note carries a legend of the tags (C2, E3, T1, H3 …) its text names."""
    from armlab.viz.tags import notation_tags, theory_tags

    defined = set(notation_tags()) | set(theory_tags())
    text = report[0].read_text(encoding="utf-8")
    blocks = re.findall(r"<article .*?</article>|<aside .*?</aside>", text, flags=re.S)
    assert blocks
    checked = 0
    for block in blocks:
        legend = re.search(r'<div class="note tags">(.*?)</div>', block, flags=re.S)
        body = re.sub(r'<div class="note tags">.*?</div>|<[^>]+>|data:[^"]+', " ", block, flags=re.S)
        named = {tag for tag in re.findall(r"(?<![\w^_])([CKDRSTEH]\d{1,2})(?!\w)", body) if tag in defined}
        given = set(re.findall(r"<li><b>(\w+)</b>", legend.group(1))) if legend else set()
        assert named <= given, (block[:120], named - given)
        checked += bool(named)
    assert checked >= 3


def test_a_pooled_run_brings_back_everything_evaluate_fills_in_and_its_theory_tags():
    """`armlab report` evaluates the scenarios in worker processes and copies the results onto
    the planned experiments: every field that evaluate() fills in comes back, the theory's
    predictions too, and an article's (H3) is defined from armlab.theory beside the notation
    table's task-space tags (T1–T4) its loop diagram names."""
    import copy
    import dataclasses

    from tqdm import tqdm

    from armlab.viz.experiments import experiment_from_scenario
    from armlab.viz.report import _experiment_html
    from armlab.viz.report_runs import evaluate, run_all, take_back

    planned = experiment_from_scenario("a11_compliance", 2.0)
    done = evaluate(copy.copy(planned))
    assert any("(H3)" in p.quantity for p in done.predicted)
    target = copy.copy(planned)
    take_back(target, done)
    for f in dataclasses.fields(target):
        if f.name not in ("runner", "predictor"):
            assert getattr(target, f.name) is getattr(done, f.name), f.name

    run_all([planned], tqdm(disable=True), 2, lambda: None)     # through a worker process
    assert [p.quantity for p in planned.predicted] == [p.quantity for p in done.predicted]
    legend = re.search(r'<div class="note tags">(.*?)</div>', _experiment_html(planned), flags=re.S).group(1)
    assert "<li><b>H3</b> (armlab.theory): Compliance control" in legend
    assert "<li><b>T1</b> (docs/notation.md): x̃ = −[R_aᵀ(o_e − o_a)" in legend
    sources = dict(re.findall(r"<li><b>(\w+)</b> \(([^)]+)\)", legend))
    assert {tag for tag, source in sources.items() if source == "armlab.theory"} == {"H3"}
