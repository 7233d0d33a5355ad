"""The layout's rules, checked on the source text (parsed with ``ast``, nothing imported).

* no import cycle between the modules of ``armlab``;
* the compiled kernels (``armlab/kernels``) import only numpy, numba, llvmlite, math and
  armlab's kernels, model, spatial and errors modules;
* only the command line and the plotting package import the command line and the plotting
  package (the library never needs them);
* no private numba names (options, attributes, methods) and no writes into an object's
  ``__dict__``.

Every ``import`` statement counts, also one inside a function: a deferred import is still a
dependency of the module that makes it (only ``if TYPE_CHECKING:`` blocks are left out).
"""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "armlab"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}


def parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _type_checking_block(node) -> bool:
    test = node.test if isinstance(node, ast.If) else None
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _statements(tree):
    """Every node of ``tree`` outside ``if TYPE_CHECKING:`` blocks."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if not _type_checking_block(child):
                stack.append(child)


def imports(name: str) -> list[tuple[str, int]]:
    """(imported module, line) of every import statement of module ``name``; ``from p import x``
    names the module p.x when that is a module of ``armlab``, else p; relative imports resolved."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in _statements(parse(path)):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                origin = ".".join(base + ([node.module] if node.module else []))
            else:
                origin = node.module
            for alias in node.names:
                candidate = f"{origin}.{alias.name}"
                found.append((candidate if candidate in MODULES else origin, node.lineno))
    return [(module, line) for module, line in found if module != "__future__"]


def import_graph() -> dict[str, set[str]]:
    """armlab module → the armlab modules it imports."""
    graph = defaultdict(set)
    for name in MODULES:
        for module, _ in imports(name):
            if module in MODULES and module != name:
                graph[name].add(module)
    return graph


def cycles(graph) -> list[list[str]]:
    """One cycle per strongly connected component of more than one module (Tarjan), each
    written as a shortest path from its first module back to it."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(component)

    for v in sorted(MODULES):
        if v not in index:
            visit(v)
    found = []
    for component in components:
        start = min(component)
        # Breadth-first within the component: the shortest way from start back to start.
        paths = {w: [start, w] for w in graph[start] if w in component}
        frontier = list(paths)
        while start not in paths:
            next_frontier = []
            for v in frontier:
                for w in sorted(graph[v]):
                    if w in component and w not in paths:
                        paths[w] = paths[v] + [w]
                        next_frontier.append(w)
            frontier = next_frontier
        found.append(paths[start])
    return sorted(found)


def test_the_cycle_finder_finds_a_cycle_and_no_false_one():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    global MODULES
    saved, MODULES = MODULES, dict.fromkeys("abcd")
    try:
        assert cycles(graph) == [["a", "b", "c", "a"]]
        assert cycles({"a": {"b"}, "b": set(), "c": {"a"}}) == []
    finally:
        MODULES = saved


def test_no_import_cycle():
    found = cycles(import_graph())
    assert not found, "import cycles:\n" + "\n".join(" → ".join(cycle) for cycle in found)


# ``typing`` (NamedTuple layouts) is part of the language rather than a dependency.
KERNEL_MAY_IMPORT = ("numpy", "numba", "llvmlite", "math", "typing", "armlab.kernels", "armlab.model",
                     "armlab.spatial", "armlab.errors")


def _within(module: str, prefixes) -> bool:
    return any(module == p or module.startswith(p + ".") for p in prefixes)


def test_kernels_import_only_numerics_model_and_spatial():
    wrong = [f"{MODULES[name].relative_to(SRC)}:{line}: {module}"
             for name in MODULES if _within(name, ["armlab.kernels"])
             for module, line in imports(name) if not _within(module, KERNEL_MAY_IMPORT)]
    assert not wrong, "kernels import beyond numpy/numba/model/spatial:\n" + "\n".join(wrong)


FRONT_END = ("armlab.viz", "armlab.commands", "armlab.cli", "armlab.__main__")
# The notebook display is an edge too: a result shown in a notebook draws its scope, through
# the one plotting module written for it, reached from ``SimulationResult._repr_html_`` only.
DISPLAY_HOOKS = {("armlab.simulation.results", "armlab.viz.notebook")}


def test_the_library_never_imports_the_command_line_or_plotting():
    wrong = [f"{MODULES[name].relative_to(SRC)}:{line}: {module}"
             for name in MODULES if not _within(name, FRONT_END)
             for module, line in imports(name)
             if _within(module, FRONT_END) and (name, module) not in DISPLAY_HOOKS]
    assert not wrong, "library modules importing viz/commands/cli:\n" + "\n".join(wrong)


PRIVATE_NUMBA = {"_nrt", "_can_compile", "_get_arg_packer", "_get_return_status", "disable_compile",
                 "entry_point"}


PRIVATE_IN_TEXT = re.compile(r"\b(" + "|".join(sorted(PRIVATE_NUMBA)) + r")\b")


def _docstrings(tree) -> set[int]:
    """ids of the docstring nodes of ``tree`` (prose, not code)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def private_numba_uses(tree) -> list[tuple[int, str]]:
    """(line, name) of each private numba name: a keyword argument (``_nrt=False``), an
    attribute (``dispatcher._can_compile``, ``.entry_point``), a bare name, or inside a string
    other than a docstring (``getattr(d, "_can_compile")``, ``{"_nrt": False}``, the source
    of a generated module)."""
    found = []
    prose = _docstrings(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg in PRIVATE_NUMBA:
            found.append((node.value.lineno, node.arg))
        elif isinstance(node, ast.Attribute) and node.attr in PRIVATE_NUMBA:
            found.append((node.lineno, node.attr))
        elif isinstance(node, ast.Name) and node.id in PRIVATE_NUMBA:
            found.append((node.lineno, node.id))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in prose:
            found += [(node.lineno, f"{name!r} in a string") for name in PRIVATE_IN_TEXT.findall(node.value)]
    return found


def test_the_private_name_finder_sees_each_form():
    tree = ast.parse('"""A module that once used _nrt (prose is not code)."""\n'
                     "f = njit(_nrt=False)\nd._can_compile = False\ncode = r.entry_point\n"
                     "getattr(d, '_get_arg_packer')\nopts = {'_nrt': False}\n"
                     "source = '@njit(cache=True, _nrt=False)'\nok = njit(cache=True)\n")
    assert sorted(line for line, _ in private_numba_uses(tree)) == [2, 3, 4, 5, 6, 7]


def test_no_private_numba_names():
    wrong = [f"{path.relative_to(SRC)}:{line}: {name}"
             for path in MODULES.values() for line, name in sorted(private_numba_uses(parse(path)))]
    assert not wrong, "private numba names:\n" + "\n".join(wrong)


MUTATORS = {"setdefault", "update", "pop", "popitem", "clear", "__setitem__", "__delitem__"}


def _is_dict_of_object(node) -> bool:
    """``x.__dict__`` or ``vars(x)``."""
    return (isinstance(node, ast.Attribute) and node.attr == "__dict__") or (
        isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "vars"
        and node.args)


def dict_writes(tree) -> list[int]:
    """Lines that write into an object's ``__dict__``: ``x.__dict__[k] = v`` (also augmented or
    deleted), ``x.__dict__.setdefault(...)`` and the like, the same through ``vars(x)``."""
    found = []
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, (ast.AugAssign, ast.AnnAssign)):
            targets = [node.target]
        elif isinstance(node, ast.Delete):
            targets = node.targets
        found += [node.lineno for t in targets
                  if isinstance(t, ast.Subscript) and _is_dict_of_object(t.value)]
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in MUTATORS
                and _is_dict_of_object(node.func.value)):
            found.append(node.lineno)
    return sorted(found)


def test_the_dict_write_finder_sees_each_form():
    tree = ast.parse("robot.__dict__['x'] = 1\nrobot.__dict__.setdefault('y', 2)\nvars(robot)['z'] = 3\n"
                     "vars(robot).update(a=1)\ndel robot.__dict__['x']\nvalue = robot.__dict__['x']\n"
                     "names = dict(vars(robot))\n")
    assert dict_writes(tree) == [1, 2, 3, 4, 5]


def test_no_writes_into_an_objects_dict():
    wrong = [f"{path.relative_to(SRC)}:{line}"
             for path in MODULES.values() for line in dict_writes(parse(path))]
    assert not wrong, "writes into __dict__:\n" + "\n".join(wrong)


BOUNDARY = PACKAGE / "kernels" / "boundary.py"
NUMBA_INSIDES = re.compile(r"numba\.core|numba\.np\.|call_conv|fndesc|overloads\[|get_pointer_to_function"
                           r"|inttoptr|ptrtoint")


def test_numbas_insides_are_named_in_the_boundary_file_alone():
    # Addresses, calling conventions and numba's internal modules: one file knows them.
    offenders = sorted(f"{path.relative_to(SRC)}:{number}"
                       for path in PACKAGE.rglob("*.py") if path != BOUNDARY
                       for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                       if NUMBA_INSIDES.search(line))
    assert not offenders, offenders
    assert NUMBA_INSIDES.search(BOUNDARY.read_text(encoding="utf-8"))   # the check sees them there
