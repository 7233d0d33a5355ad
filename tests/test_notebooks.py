"""The example notebooks (``examples/*.ipynb``) execute without error, and the HTML that
nbconvert writes of them shows robots, controllers, results and derivations as tables,
figures and formulas — never as object dumps.

Needs the extra ``notebooks`` (nbclient, nbformat, ipykernel, nbconvert); skipped with a
message without it.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="nbformat is not installed (extra 'notebooks')")
nbclient = pytest.importorskip("nbclient", reason="nbclient is not installed (extra 'notebooks')")
pytest.importorskip("ipykernel", reason="ipykernel is not installed (extra 'notebooks')")
nbconvert = pytest.importorskip("nbconvert", reason="nbconvert is not installed (extra 'notebooks')")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.ipynb"))


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    """Every example notebook, executed once in a fresh kernel that imports this checkout."""
    path = os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])
    saved = {name: os.environ.get(name) for name in ("PYTHONPATH", "MPLBACKEND")}
    os.environ["PYTHONPATH"] = path  # the kernel inherits the environment
    # A notebook's own backend (inline), not the file backend ``armlab.cli.main`` sets for the
    # commands an earlier test of this process ran: with it no figure would be displayed.
    os.environ.pop("MPLBACKEND", None)
    done = {}
    try:
        for notebook in EXAMPLES:
            nb = nbformat.read(notebook, as_version=4)
            where = tmp_path_factory.mktemp(notebook.stem)
            client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                             resources={"metadata": {"path": str(where)}})
            client.execute()
            done[notebook.name] = nb
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    return done


def html_of(nb) -> str:
    body, _ = nbconvert.HTMLExporter().from_notebook_node(nb)
    return body


def outputs(nb):
    return [output for cell in nb.cells if cell.cell_type == "code" for output in cell.get("outputs", [])]


def test_there_are_the_examples_the_docs_promise():
    names = [path.name for path in EXAMPLES]
    assert names == ["01-derivations-A1-A5.ipynb", "02-joint-control-A6-A8.ipynb",
                     "03-interaction-A9-A15.ipynb", "04-your-own-robot.ipynb", "05-sweep.ipynb"]
    for path in EXAMPLES:  # committed without outputs: what runs in CI is what is read
        assert all(not cell.get("outputs") for cell in nbformat.read(path, as_version=4).cells
                   if cell.cell_type == "code")


@pytest.mark.parametrize("name", [path.name for path in EXAMPLES])
def test_every_cell_runs_without_error(executed, name):
    nb = executed[name]
    errors = [output for output in outputs(nb) if output.output_type == "error"]
    assert errors == []
    stderr = [output.text for output in outputs(nb)
              if output.output_type == "stream" and output.name == "stderr"]
    assert not any("Traceback" in text or "Error" in text for text in stderr), stderr
    page = html_of(nb)
    assert "object at 0x" not in page
    assert not re.search(r"&lt;armlab\.[\w.]+ object", page)


def rich(nb, mime: str) -> int:
    return sum(1 for output in outputs(nb) if mime in output.get("data", {}))


def test_the_derivations_show_as_formulas_and_the_robot_as_a_table(executed):
    nb = executed["01-derivations-A1-A5.ipynb"]
    page = html_of(nb)
    assert rich(nb, "text/html") >= 6  # the robot and the five sections
    assert page.count("<math") > 80
    assert "<td>theta2</td><td>revolute</td>" in page
    assert "A3 — Lagrangian" in page


def test_controllers_and_results_show_as_tables_and_scopes(executed):
    nb = executed["02-joint-control-A6-A8.ipynb"]
    page = html_of(nb)
    assert "τ = ĝ(q_g) + K_P (q_des − q) − K_D q̇" in page
    scopes = re.findall(r'<img alt="[^"]*" src="data:image/png;base64,', page)
    assert len(scopes) >= 5  # A6, A7, A8, the trapezoid and the Python law
    assert page.count("<td>status</td><td>ok</td>") >= 5
    plain = [output.get("data", {}).get("text/plain", "") for output in outputs(nb)]
    # The characteristic polynomial of the linearised A7 loop: (s² + 10 s + 25)³.
    assert "[1.0, 30.0, 375.0, 2500.0, 9375.0, 18750.0, 15625.0]" in plain


@pytest.mark.parametrize("name", ["03-interaction-A9-A15.ipynb", "04-your-own-robot.ipynb"])
def test_the_3d_view_is_in_the_page_and_needs_no_network(executed, name):
    nb = executed[name]
    page = html_of(nb)
    assert "Plotly.newPlot" in page
    # The outputs carry plotly.js (nbconvert's own page template loads require.js and MathJax
    # from a CDN: not ours).
    produced = "".join(output.get("data", {}).get("text/html", "") for output in outputs(nb))
    assert len(produced) > 3_000_000
    assert not re.search(r"""<script[^>]*src=["']https?://""", produced)
    assert page.count("<td>status</td><td>ok</td>") >= 1


def test_the_sweep_shows_its_table_and_plots(executed):
    """The A11 stiffness sweep: one row per run with its status and metrics, the runs past
    1.62·10⁶ N/m diverged, the others at the equilibrium of the controller's spring K_P = 20 N/m
    in series with the wall's K, x_d − x_r = 0.1 m apart (a11_compliance.toml):
    f = K_P K/(K_P + K)(x_d − x_r), ‖x_d − x_e‖ = K/(K_P + K)(x_d − x_r); and the figures."""
    nb = executed["05-sweep.ipynb"]
    (table,) = [output["data"]["text/html"] for output in outputs(nb)
                if "text/html" in output.get("data", {}) and "<table" in output["data"]["text/html"]]
    headers = re.findall(r"<th>([^<]+)</th>", table)
    assert headers[:6] == ["environment.stiffness[2]", "status", "contact_force", "position_error",
                           "settling_time", "divergence_time"]
    rows = re.findall(r"<tr>\s*<th>\d+</th>(.*?)</tr>", table, re.S)
    cells = [re.findall(r"<td>([^<]*)</td>", row) for row in rows]
    assert len(cells) == 29
    status = {float(row[0]): row[1] for row in cells}
    assert {k for k, s in status.items() if s == "diverged"} == {k for k in status if k > 1.62e6}
    for row in cells:
        if row[1] == "ok":
            k = float(row[0])
            assert abs(float(row[2]) - 20 * k / (20 + k) * 0.1) < 1e-3, row  # table rounded to 1e-4
            assert abs(float(row[3]) - k / (20 + k) * 0.1) < 1e-3, row
    assert rich(nb, "image/png") >= 2  # the notebook's figure and the sweep file's picture
