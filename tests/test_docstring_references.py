"""Every Sphinx-style cross-reference to armlab in armlab's source names something that
exists (``JointInverseDynamics`` cited a function of ``armlab.theory`` that was never there)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import armlab

REFERENCE = re.compile(r":(?:func|class|meth|data|mod|attr|exc):`~?(armlab\.[\w.]+)`")


def _resolve(dotted: str) -> bool:
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for name in parts[k:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


def test_every_cross_reference_resolves():
    missing = []
    for info in pkgutil.walk_packages(armlab.__path__, "armlab."):
        if info.name.endswith("__main__"):
            continue  # running it is the command line
        try:
            module = importlib.import_module(info.name)
        except ImportError:
            continue  # an optional extra that is not installed
        for dotted in sorted(set(REFERENCE.findall(inspect.getsource(module)))):
            if not _resolve(dotted):
                missing.append(f"{info.name}: {dotted}")
    assert not missing
