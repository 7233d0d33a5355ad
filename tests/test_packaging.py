"""What a user meets before any robotics: the licence, type information, ``python -m armlab``,
and a library that leaves matplotlib's backend to the user."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


def run_python(*args: str) -> subprocess.CompletedProcess:
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    env = {key: value for key, value in os.environ.items() if key != "MPLBACKEND"}
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=300,
                          env={**env, "PYTHONPATH": path})


def test_the_licence_file_is_the_mit_licence_pyproject_declares():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["license"] == "MIT"
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License")
    assert "the armlab developers" in text


def test_the_package_is_marked_typed_and_ships_the_marker():
    assert (SRC / "armlab" / "py.typed").is_file()
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "py.typed" in meta["tool"]["setuptools"]["package-data"]["armlab"]


def test_python_dash_m_armlab_is_the_command_line():
    done = run_python("-m", "armlab", "--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("armlab ")
    done = run_python("-m", "armlab")
    assert done.returncode == 2
    assert "usage: armlab" in done.stderr


def test_importing_the_pictures_leaves_matplotlibs_backend_alone():
    # A backend the library would never pick: any module switching to Agg shows up.
    code = ("import matplotlib\nmatplotlib.use('svg')\n"
            "import armlab.viz, armlab.viz.report, armlab.viz.animation, armlab.viz.scopes\n"
            "import armlab.viz.drawing\n"
            "import matplotlib.pyplot as plt\nprint(matplotlib.get_backend())")
    done = run_python("-c", code)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "svg"
