"""The exception tree (armlab.errors): one place, each class also the matching builtin."""

import ast
import inspect
from pathlib import Path

import pytest

import armlab.errors as errors

SRC = Path(__file__).resolve().parents[1] / "src" / "armlab"


def test_every_exception_class_is_defined_in_errors_py():
    elsewhere = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "errors.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and any(
                    getattr(base, "id", getattr(base, "attr", "")).endswith(("Error", "Exception"))
                    for base in node.bases):
                elsewhere.append(f"{path.relative_to(SRC)}:{node.lineno} {node.name}")
    # traced.py's TracedBranch is internal control flow of the tracer, never raised to a user.
    assert elsewhere == ["specialise/traced.py:" + str(_traced_branch_line()) + " TracedBranch"]


def _traced_branch_line():
    tree = ast.parse((SRC / "specialise" / "traced.py").read_text(encoding="utf-8"))
    return next(node.lineno for node in ast.walk(tree)
                if isinstance(node, ast.ClassDef) and node.name == "TracedBranch")


@pytest.mark.parametrize("name", [name for name, value in vars(errors).items()
                                  if inspect.isclass(value) and issubclass(value, errors.ArmlabError)])
def test_each_error_is_an_armlab_error_and_bad_values_are_value_errors(name):
    cls = getattr(errors, name)
    assert issubclass(cls, errors.ArmlabError)
    if issubclass(cls, errors.InputError):
        assert issubclass(cls, ValueError) and not issubclass(cls, TypeError)
    if issubclass(cls, errors.ProtocolError):
        assert issubclass(cls, TypeError)


def test_file_errors_are_one_line_naming_file_and_field():
    error = errors.RobotFileError("arm.toml", "joint.2.mass", "must be ≥ 0, got -1")
    assert str(error) == "arm.toml: joint.2.mass: must be ≥ 0, got -1"
    assert (error.file, error.field) == ("arm.toml", "joint.2.mass")
    assert isinstance(errors.ScenarioFileError("a", "b", "c"), ValueError)


def test_errors_with_their_own_fields_cross_process_boundaries():
    """The report runs experiments in worker processes: their errors come back pickled."""
    import pickle

    import numpy as np

    from armlab.errors import RobotFileError, ScenarioFileError, SimulationDiverged, UnreachableTargetError

    for error in (RobotFileError("r.toml", "mass", "is negative"), ScenarioFileError("s.toml", "dt", "zero")):
        again = pickle.loads(pickle.dumps(error))
        assert type(again) is type(error) and str(again) == str(error) and again.field == error.field
    error = UnreachableTargetError("out of reach", reason="distance", best_q=[0.1, 0.2], position_error=0.3)
    again = pickle.loads(pickle.dumps(error))
    assert again.reason == "distance" and np.array_equal(again.best_q, [0.1, 0.2])
    assert again.position_error == 0.3
    again = pickle.loads(pickle.dumps(SimulationDiverged("diverged at t = 1 s", result=[1, 2])))
    assert str(again) == "diverged at t = 1 s" and again.result == [1, 2]
