"""The documentation site builds from docs/*.md and the docstrings with warnings as errors
(what ``make docs`` runs).  Needs the extra ``docs``; skipped with a message without it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx", reason="Sphinx is not installed (extra 'docs')")
pytest.importorskip("myst_parser", reason="myst-parser is not installed (extra 'docs')")

ROOT = Path(__file__).resolve().parents[1]


def test_the_site_builds_without_a_warning(tmp_path):
    path = os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           str(ROOT / "docs"), str(tmp_path / "html")],
                          capture_output=True, text=True, timeout=900, env={**os.environ, "PYTHONPATH": path})
    assert done.returncode == 0, done.stderr[-3000:]
    pages = {p.name for p in (tmp_path / "html").rglob("*.html")}
    assert {"index.html", "notation.html", "A12-impedance.html", "python-laws.html", "control.html"} <= pages
    control = (tmp_path / "html" / "api" / "control.html").read_text(encoding="utf-8")
    assert "FunctionController" in control and "closed_loop_system" in control
