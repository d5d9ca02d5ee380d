"""The package's shape stays readable: no import cycle (between modules, nor between
subpackages), no private name taken from another module, small modules and functions, few
modules at the root. Read from the source with ``ast``, nothing is imported."""

from __future__ import annotations

import ast
from pathlib import Path

import leapfrog_planner

PACKAGE = Path(leapfrog_planner.__file__).parent
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 100
#: Stricter in planning/ (the initial paths, the Leapfrog driver, the direct method): a
#: function there reads as the step of the method it names.
MAX_PLANNING_FUNCTION_LINES = 60
MAX_ROOT_MODULES = 8
#: The planner is a short loop over its search (docs/architecture.md): the stages, the runner,
#: the answer and the report live in modules of their own.
MAX_PLANNER_LINES = 205
#: The layers, in the order of the data (docs/architecture.md states the same order): each
#: subpackage imports only from its own layer and the layers before it. The modules at the root
#: (errors, checks, the private helpers) come first: every layer may use them. experiments and
#: batch share a layer: each uses the other.
LAYERS = (
    ("",),  # the root modules
    ("world",),  # maps and the clearance against them
    ("model",),  # the symbolic model
    ("compiled",),
    ("integrate",),
    ("roots",),
    ("bvp",),
    ("planning",),
    ("viz",),
    ("batch",),
    ("experiments",),
    ("web",),
    ("cli",),
)


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package)."""
    out = {}
    for f in PACKAGE.rglob("*.py"):
        parts = list(f.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (f, is_pkg)
    return out


def _imports(modules, parents: bool = False) -> dict[str, set[str]]:
    """Each module's imports of other modules of the package, at the top or inside functions,
    relative or absolute (the kernel templates import the package by its name). Parents are left
    out (Python imports a package before its modules anyway), unless ``parents``: then a name
    taken from a parent package's ``__init__`` is an import of it."""
    edges: dict[str, set[str]] = {m: set() for m in modules}
    for mod, (path, is_pkg) in modules.items():
        base = mod.split(".") if is_pkg else mod.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and (node.level or node.module in modules):
                up = base[: len(base) - (node.level - 1)] if node.level else []
                target = ".".join(up + ([node.module] if node.module else []))
                subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in modules]
                if parents and subs and len(subs) < len(node.names):
                    subs.append(target)  # submodules and names of the package itself
                targets = subs or [target]
            else:
                continue
            for t in targets:
                if t in modules and t != mod and (parents or not mod.startswith(t + ".")):
                    edges[mod].add(t)
    return edges


def _layer(module: str) -> str:
    """The subpackage a module belongs to; "" for the root modules and the package itself."""
    parts = module.split(".")[1:]
    is_subpackage = (PACKAGE / "/".join(parts[:1])).is_dir() if parts else False
    return parts[0] if is_subpackage else ""


def _subpackage(module: str) -> str:
    """The subpackage (or root module) a module belongs to: ``leapfrog_planner.<name>``."""
    return ".".join(module.split(".")[:2])


def _cycle(edges) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(edges[u]):
            if state.get(v) == 1:
                return stack[stack.index(v) :] + [v]
            if not state.get(v) and (found := visit(v)):
                return found
        stack.pop()
        state[u] = 2
        return None

    for m in sorted(edges):
        if not state.get(m) and (found := visit(m)):
            return found
    return None


def test_no_import_cycle_even_through_imports_inside_functions():
    edges = _imports(_modules())
    assert sum(map(len, edges.values())) > 100  # the check sees the package's imports
    cycle = _cycle(edges)
    assert cycle is None, " -> ".join(cycle)


def test_subpackages_import_one_way():
    """No two subpackages import each other, directly or round a longer loop (batch uses the
    planning and the direct method; experiments use batch; cli and web use them all)."""
    edges = _imports(_modules())
    graph: dict[str, set[str]] = {_subpackage(m): set() for m in edges}
    for mod, targets in edges.items():
        for t in targets:
            if _subpackage(t) != _subpackage(mod):
                graph[_subpackage(mod)].add(_subpackage(t))
    assert "leapfrog_planner.batch" in graph["leapfrog_planner.experiments"]  # sees them
    mutual = sorted(f"{a} <-> {b}" for a in graph for b in graph[a] if a < b and a in graph[b])
    assert not mutual, mutual
    cycle = _cycle(graph)
    assert cycle is None, " -> ".join(cycle)


def test_no_package_and_its_modules_import_each_other():
    """A package's ``__init__`` and its modules import one way too: a module that takes a name
    from its package's ``__init__`` (``from . import name``) is not imported by it."""
    cycle = _cycle(_imports(_modules(), parents=True))
    assert cycle is None, " -> ".join(cycle)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _private_uses(mod: str, path: Path, is_pkg: bool, modules) -> list[str]:
    """``from .x import _y`` (absolute or relative; a private module of the package is no name
    of another module) and ``x._y`` for a module ``x`` of the package imported as a name."""
    base = mod.split(".") if is_pkg else mod.split(".")[:-1]
    tree = ast.parse(path.read_text())
    found, aliases = [], {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                up = base[: len(base) - (node.level - 1)]
                target = ".".join(up + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != PACKAGE.name:
                continue
            for a in node.names:
                if f"{target}.{a.name}" in modules:
                    aliases[a.asname or a.name] = f"{target}.{a.name}"
                elif _private(a.name):
                    found.append(f"{mod}:{node.lineno}: from {target} import {a.name}")
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name in modules and a.asname:
                    aliases[a.asname] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            owner = aliases.get(node.value.id) if isinstance(node.value, ast.Name) else None
            if owner and f"{owner}.{node.attr}" not in modules:
                found.append(f"{mod}:{node.lineno}: {node.value.id}.{node.attr}")
    return found


def test_no_module_takes_another_modules_private_name():
    """A name that starts with ``_`` belongs to its module: another module neither imports it
    (``from .geometry import _x``) nor reads it (``geometry._x``). What modules share is public."""
    modules = _modules()
    found = {
        mod: _private_uses(mod, path, is_pkg, modules) for mod, (path, is_pkg) in modules.items()
    }
    assert not [f for fs in found.values() for f in fs]


def test_private_names_are_found():
    """The check itself, on made-up modules."""
    import tempfile

    modules = {"leapfrog_planner.a": (None, False), "leapfrog_planner.b": (None, False)}
    text = (
        "from .b import _x, y\nfrom leapfrog_planner.b import _z\nfrom . import b\n"
        "import leapfrog_planner.b as bb\nb._w\nbb._v\nb.y\nfrom os import _exit\n"
    )
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "a.py"
        path.write_text(text)
        found = _private_uses("leapfrog_planner.a", path, False, modules)
    assert [f.split(": ", 1)[1] for f in found] == [
        "from leapfrog_planner.b import _x",
        "from leapfrog_planner.b import _z",
        "b._w",
        "bb._v",
    ]


def test_modules_and_functions_are_small():
    too_long, too_big = [], []
    for mod, (path, _) in _modules().items():
        text = path.read_text()
        if text.count("\n") > MAX_MODULE_LINES:
            too_big.append(f"{mod}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    too_long.append(f"{mod}.{node.name}: {n} lines")
    assert not too_big, too_big
    assert not too_long, too_long


def test_functions_in_planning_are_smaller_still():
    too_long, seen = [], 0
    for mod, (path, _) in _modules().items():
        if _layer(mod) != "planning":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                seen += 1
                n = node.end_lineno - node.lineno + 1
                if n > MAX_PLANNING_FUNCTION_LINES:
                    too_long.append(f"{mod}.{node.name}: {n} lines")
    assert seen > 200  # the check sees planning/, its subpackages included
    assert not too_long, too_long


def test_the_planner_is_a_short_loop():
    lines = (PACKAGE / "planning" / "planner.py").read_text().count("\n")
    assert 100 < lines <= MAX_PLANNER_LINES, lines


def test_few_modules_at_the_package_root():
    root = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(root) <= MAX_ROOT_MODULES, root
    packages = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    assert {"model", "compiled", "integrate", "roots", "bvp", "planning", "cli"} <= packages


def test_each_layer_imports_only_from_the_layers_before_it():
    """symbolic model -> compiled core -> integrate -> roots -> bvp -> planning -> ...: the
    order of LAYERS, imports inside functions included."""
    rank = {name: i for i, layer in enumerate(LAYERS) for name in layer}
    modules = _modules()
    assert {_layer(m) for m in modules} == set(rank)  # every subpackage has its place
    wrong = [
        f"{mod} imports {dep}"
        for mod, deps in _imports(modules).items()
        for dep in deps
        if rank[_layer(dep)] > rank[_layer(mod)]
    ]
    assert not wrong, wrong


def test_the_layer_check_sees_absolute_imports():
    """The kernel templates import the package by name: those imports are edges too."""
    edges = _imports(_modules())
    template = "leapfrog_planner.compiled.newton_template"
    assert "leapfrog_planner.compiled.abi" in edges[template]
    assert "leapfrog_planner.model.penalty" in edges["leapfrog_planner.compiled.flow_template"]


def test_cycles_are_found():
    """The cycle check itself, on a made-up graph."""
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_old_module_paths_still_import_with_a_warning():
    import importlib
    import sys
    import warnings

    import leapfrog_planner.planning.planner as planner

    sys.modules.pop("leapfrog_planner.planner", None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = importlib.import_module("leapfrog_planner.planner")
    assert old is planner and old.plan is planner.plan
    assert any("moved to leapfrog_planner.planning.planner" in str(w.message) for w in caught)
    assert all(w.category is DeprecationWarning for w in caught)


def test_the_world_layer_needs_only_numpy_scipy_numba_pyyaml_and_pillow():
    """world/ (maps, their penalty fields, clearance) stays light: besides the root modules, the
    standard library and these five, it imports nothing (no SymPy: only the vehicle model is
    symbolic; the map's field is compiled with numba, as data)."""
    import sys

    allowed = {"numpy", "scipy", "numba", "yaml", "PIL", "leapfrog_planner"}
    found = set()
    for path in (PACKAGE / "world").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and not node.level:
                found.add(node.module.split(".")[0])
    third_party = found - set(sys.stdlib_module_names)
    assert {"numpy", "yaml"} <= third_party <= allowed, third_party


def test_the_package_ships_its_type_hints():
    """PEP 561: the ``py.typed`` marker sits in the package and its package data names it, so
    an installed wheel carries it and mypy or an editor reads the package's hints."""
    import tomllib

    assert (PACKAGE / "py.typed").is_file()
    pyproject = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    assert "py.typed" in pyproject["tool"]["setuptools"]["package-data"]["leapfrog_planner"]
