"""The progress bars (armlab.progress): tqdm redrawn in place on a terminal, a line per step in
a log, nothing when disabled; the report's steps as they reach a log."""

from __future__ import annotations

import io
import re

from armlab.progress import finish, progress_bar


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_log_gets_one_line_per_refresh_and_none_per_update():
    stream = io.StringIO()
    bar = progress_bar(5, stream=stream, unit="step")
    for name in ("a", "b", "c"):
        bar.set_postfix_str(f"running {name}")
        bar.update()
    finish(bar, "wrote it")
    text = stream.getvalue()
    assert "\r" not in text and text.endswith("\n") and "\n\n" not in text
    lines = text.splitlines()
    # The opening state, one line per step (the count before it), the final state once.
    assert len(lines) == 5, lines
    assert re.search(r"\b0/5\b", lines[0]) and "running" not in lines[0]
    for k, name in enumerate("abc"):
        assert re.search(rf"\b{k}/5\b.*running {name}\]$", lines[k + 1]), lines[k + 1]
    assert re.search(r"\b5/5\b.*wrote it\]$", lines[-1]) and lines[-1].startswith("100%")


def test_a_log_gets_update_lines_at_most_every_log_every_seconds():
    stream = io.StringIO()
    bar = progress_bar(100, stream=stream, log_every=3600.0, unit="run")
    for _ in range(99):
        bar.update()
    bar.close()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2 and "0/100" in lines[0] and "99/100" in lines[1]
    stream = io.StringIO()
    bar = progress_bar(3, stream=stream, log_every=0.0, unit="run")
    for _ in range(3):
        bar.update()
    bar.close()
    assert [re.search(r"\b(\d)/3\b", line)[1] for line in stream.getvalue().splitlines()] == list("01233")


def test_a_terminal_gets_one_line_redrawn_in_place():
    stream = Terminal()
    bar = progress_bar(2, stream=stream, unit="step")
    bar.set_postfix_str("running a")
    bar.update()
    finish(bar, "done")
    text = stream.getvalue()
    assert text.count("\n") == 1 and text.endswith("done]\n")
    assert text.count("\r") >= 3 and "running a" in text


def test_a_disabled_bar_prints_nothing_and_counts_nothing():
    stream = io.StringIO()
    bar = progress_bar(3, stream=stream, enabled=False)
    bar.set_postfix_str("running a")
    bar.update()
    finish(bar, "done")
    assert stream.getvalue() == ""


def test_the_report_writes_a_line_per_step_to_a_log(tmp_path, monkeypatch, capsys):
    """``armlab report`` with its stderr in a file: each step a line naming it, in order."""
    from armlab.viz import report
    from armlab.viz.experiments import Experiment

    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "cache"))
    # The drawings and derivations (tens of seconds) are left out; two runs that failed
    # before the report (nothing to simulate) are still steps of their own.
    monkeypatch.setattr(report, "_symbolic_sections", lambda robot, progress, budget: ({}, True))
    monkeypatch.setattr(report, "_drawings", lambda robot: "")
    planned = [Experiment(name=name, assignment=6, title=name, description="", parameters=[],
                          error="not run") for name in ("first_run", "second_run")]
    path = report.build_report("prp", tmp_path / "report", experiments=planned, animation=False,
                               views=False, jobs=1)
    text = capsys.readouterr().err
    assert "\r" not in text
    lines = text.splitlines()
    steps = ["robot drawings", "running first_run", "running second_run", f"wrote {path}"]
    assert len(lines) == len(steps) + 1, lines
    for line, step in zip(lines[1:], steps, strict=True):
        assert step in line, (line, step)
    assert lines[-1].startswith("100%")
