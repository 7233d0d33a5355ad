"""Test configuration shared by the whole suite.

``tests/`` is on ``sys.path`` (pytest's default import mode for a test folder without
``__init__.py``), so helpers such as ``pinocchio_model`` are imported by name.
Hypothesis runs without its per-example deadline: the first call of a numba kernel compiles
(or loads from cache) and would exceed it for reasons that have nothing to do with the code
under test.
"""

from hypothesis import settings

settings.register_profile("armlab", deadline=None)
settings.load_profile("armlab")
