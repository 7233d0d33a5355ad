"""What a fresh process loads: ``import armlab`` and ``armlab --help`` stay light.

Each check runs in a new interpreter (this one has long since imported everything) and reads
its ``sys.modules``: the heavy libraries are imported only by the code that uses them.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
HEAVY = ("numba", "llvmlite", "scipy", "sympy", "matplotlib", "pandas", "pyarrow", "yourdfpy")


def loaded_after(code: str) -> dict:
    """Run ``code`` in a fresh interpreter with this checkout's ``src`` first on the path; return
    ``{"heavy": [...], "armlab": [...], "out": <what code printed>}``."""
    program = (
        "import contextlib, io, json, sys\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):\n"
        "    try:\n"
        + "".join(f"        {line}\n" for line in code.splitlines())
        + "    except SystemExit:\n"
        "        pass\n"
        f"heavy = sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))\n"
        "mine = sorted(m for m in sys.modules if m.startswith('armlab'))\n"
        "print(json.dumps({'heavy': heavy, 'armlab': mine, 'out': out.getvalue()}))\n"
    )
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": path})
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_import_armlab_loads_no_heavy_library():
    loaded = loaded_after("import armlab")
    assert loaded["heavy"] == []
    assert loaded["armlab"] == ["armlab"]


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["run", "--help"], ["robots", "--help"],
                                  ["derive", "--help"], ["demo", "--help"], ["scenarios", "--help"],
                                  ["report", "--help"]])
def test_help_and_version_answer_without_the_kernels(argv):
    loaded = loaded_after(f"from armlab.cli import main\nmain({argv!r})")
    assert loaded["heavy"] == [], loaded["heavy"]
    assert not [m for m in loaded["armlab"] if m.startswith(("armlab.kernels", "armlab.dynamics"))]
    assert "armlab" in loaded["out"]
    if argv == ["--help"]:
        # Every subcommand is still listed with its help line.
        for command in ("robots", "derive", "demo", "scenarios", "run", "report"):
            assert re.search(rf"^    {command}\b", loaded["out"], re.MULTILINE), command


def test_reading_a_robot_file_loads_no_symbolic_or_plotting_library():
    loaded = loaded_after("import armlab\nrobot = armlab.load_robot('prp')\nprint(robot.n)")
    assert not {"sympy", "matplotlib", "pandas"} & set(loaded["heavy"])


def test_discovering_the_report_runs_solves_no_theory():
    """The theory's predictions are computed for the runs a report measures, not for every
    scenario it discovers: listing the PRP's runs loads none of SciPy's solvers."""
    loaded = loaded_after("import sys\nimport armlab\nfrom armlab.viz.experiments import discover\n"
                          "experiments = discover(armlab.load_robot('prp'), quick=True)\n"
                          "print(len(experiments), 'scipy.optimize' in sys.modules)")
    count, optimize = loaded["out"].split()
    assert int(count) > 20 and optimize == "False"


def test_every_public_name_resolves_to_what_it_names():
    import armlab

    assert len(set(armlab.__all__)) == len(armlab.__all__)
    for name in armlab.__all__:
        value = getattr(armlab, name)
        # A class or function keeps its own name: a wrong entry in the table would show here.
        assert value.__name__ == name
        assert name in dir(armlab)
    namespace: dict = {}
    exec("from armlab import *", namespace)
    assert set(armlab.__all__) <= set(namespace)


def test_the_public_api_covers_the_readme_entry_points():
    import armlab

    for name in ("load_robot", "Robot", "simulate", "simulate_batch", "inverse_dynamics", "inertia_matrix",
                 "forward_dynamics", "forward_kinematics", "geometric_jacobian", "load_urdf",
                 "SimulationResult", "bundled_robot_names"):
        assert name in armlab.__all__


def test_a_function_named_like_its_module_stays_the_function():
    """``armlab.inverse_kinematics`` is the function, also once its module
    ``armlab.inverse_kinematics`` has been imported by name (which makes the import system
    announce the module as an attribute of the package)."""
    loaded = loaded_after("from armlab.inverse_kinematics import UnreachableTargetError\n"
                          "import armlab\n"
                          "ik = armlab.inverse_kinematics\n"
                          "print(type(ik).__name__, ik.__name__)\n"
                          "import armlab.inverse_kinematics\n"
                          "print(type(armlab.inverse_kinematics).__name__)")
    assert loaded["out"].split() == ["function", "inverse_kinematics", "function"]


def test_an_unknown_name_is_an_attribute_error():
    import armlab

    with pytest.raises(AttributeError, match="no_such_name"):
        armlab.no_such_name  # noqa: B018
    assert not hasattr(armlab, "no_such_name")
