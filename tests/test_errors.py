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
