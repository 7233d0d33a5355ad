"""Exit codes of ``armlab`` (armlab.cli.EXIT_CODES): 0 success (also an expected divergence),
1 internal error, 2 bad input, 3 an unexpected outcome, 130 Ctrl-C; --quiet; --out checked
before a run and not created when the run never starts."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from armlab.cli import BAD_INPUT, DIVERGED, EXIT_CODES, INTERNAL_ERROR, INTERRUPTED, OK, build_parser, main
from armlab.scenarios import ScenarioFileError, load_scenario_file, scenario_path
from synthetic_results import synthetic_result


def _one_line(text: str) -> str:
    text = text.strip()
    assert "\n" not in text and "Traceback" not in text, text
    return text


def test_the_codes_are_distinct_and_documented_in_help_and_readme():
    assert {OK, INTERNAL_ERROR, BAD_INPUT, DIVERGED, INTERRUPTED} == set(EXIT_CODES)
    assert len({OK, INTERNAL_ERROR, BAD_INPUT, DIVERGED, INTERRUPTED}) == 5
    help_text = build_parser().format_help()
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    for code in EXIT_CODES:
        assert f"  {code} " in help_text
        assert f"| {code} |" in readme


def _scenario_copy(tmp_path, name, edit):
    text = scenario_path(name).read_text(encoding="utf-8")
    path = tmp_path / f"{name}_copy.toml"
    path.write_text(edit(text), encoding="utf-8")
    return path


def test_an_expected_divergence_is_success_and_an_unexpected_one_is_not(tmp_path, capsys):
    # A15 outside Image(K): the point of the experiment is that it diverges (at t ≈ 2.85 s).
    assert main(["run", "a15_parallel_outside_image", "--out", str(tmp_path / "a"), "--t-final", "4"]) == OK
    assert "(as expected)" in capsys.readouterr().err
    unexpected = _scenario_copy(tmp_path, "a15_parallel_outside_image",
                                lambda t: t.replace('expect = "diverged"', ""))
    assert main(["run", str(unexpected), "--out", str(tmp_path / "b"), "--t-final", "4"]) == DIVERGED
    # Expected to diverge, but stopped before it does: also not what the scenario says.
    short = ["run", "a15_parallel_outside_image", "--out", str(tmp_path / "c"), "--t-final", "0.5"]
    assert main(short) == DIVERGED
    assert "expects the run to end diverged" in capsys.readouterr().err


def test_expect_is_read_and_checked_like_any_field(tmp_path):
    good = _scenario_copy(tmp_path, "a6_pd_online", lambda t: 'expect = "diverged"\n' + t)
    assert load_scenario_file(good).expect == "diverged"
    bad = _scenario_copy(tmp_path, "a6_pd_online", lambda t: 'expect = "crash"\n' + t)
    with pytest.raises(ScenarioFileError, match="expect: 'crash' is not one of ok, diverged"):
        load_scenario_file(bad)


def test_bad_input_is_2_and_leaves_no_output_folder(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["run", "a6_pd_online", "--t-final", "-1", "--out", str(out)]) == BAD_INPUT
    _one_line(capsys.readouterr().err)
    assert not out.exists()
    bad = _scenario_copy(tmp_path, "a6_pd_online", lambda t: t.replace("dt = 0.001", "dt = -1"))
    assert main(["run", str(bad), "--out", str(out)]) == BAD_INPUT
    assert "simulation.dt: must be a positive time step" in capsys.readouterr().err
    assert not out.exists()
    under_a_file = tmp_path / "afile"
    under_a_file.write_text("")
    assert main(["run", "a6_pd_online", "--out", str(under_a_file / "sub")]) == BAD_INPUT
    assert "--out" in _one_line(capsys.readouterr().err)


def test_an_unexpected_exception_is_one_line_and_1_unless_debugging(monkeypatch, capsys):
    import armlab.commands.scenarios as command

    def broken(args):
        raise TypeError("something armlab did not foresee")

    monkeypatch.setattr(command, "run", broken)    # registered as the command's func
    monkeypatch.delenv("ARMLAB_DEBUG", raising=False)
    assert main(["scenarios"]) == INTERNAL_ERROR
    line = _one_line(capsys.readouterr().err)
    assert "internal error: TypeError: something armlab did not foresee" in line and "--debug" in line
    assert main(["--debug", "scenarios"]) == INTERNAL_ERROR
    assert "Traceback" in capsys.readouterr().err


def test_ctrl_c_outside_a_run_is_130(monkeypatch, capsys):
    import armlab.commands.scenarios as command

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(command, "run", interrupted)
    assert main(["scenarios"]) == INTERRUPTED
    assert _one_line(capsys.readouterr().err) == "armlab scenarios: interrupted"


def test_quiet_silences_progress_and_warnings(monkeypatch, tmp_path, capsys):
    import armlab.commands.run as command

    def fake_run(name, **kwargs):
        warnings.warn("a warning a user would see", UserWarning, stacklevel=1)
        if kwargs["progress"] is not None:
            print("running ...", file=kwargs["progress"])
        result = synthetic_result(1)
        result.meta["expect"] = "ok"
        return result, []

    monkeypatch.setattr(command, "run_scenario", fake_run)
    for quiet in (False, True):
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            assert main(["run", "a6_pd_online", "--out", str(tmp_path)] + ["--quiet"] * quiet) == OK
        err = capsys.readouterr().err
        # Shown as one line naming the command, not where in the source it was raised.
        assert ("armlab run: warning: a warning a user would see\n" in err) is not quiet
        assert ("running" in err) is not quiet


def test_a_start_outside_the_joint_limits_is_refused_before_the_run(tmp_path, capsys):
    bad = _scenario_copy(tmp_path, "a6_pd_online", lambda t: t.replace("q0 = [0, 0, 0]", "q0 = [5, 0, 0]"))
    assert "q0 = [5, 0, 0]" in bad.read_text()
    out = tmp_path / "out"
    assert main(["run", str(bad), "--out", str(out)]) == BAD_INPUT
    assert _one_line(capsys.readouterr().err.split("\n", 1)[1]).endswith(
        "simulation.q0: joint d1 = 5 is outside its limits [-0.15, 0.35]")
    assert not out.exists()
