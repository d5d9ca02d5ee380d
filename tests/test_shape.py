"""The package's shape stays readable: no import cycle, small modules and functions, few modules
at the root. Read from the source with ``ast``, nothing is imported."""

from __future__ import annotations

import ast
from pathlib import Path

import leapfrog_planner

PACKAGE = Path(leapfrog_planner.__file__).parent
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 100
MAX_ROOT_MODULES = 8
#: The layers, in the order of the data (docs/architecture.md states the same order): each
#: subpackage imports only from its own layer and the layers before it. The modules at the root
#: (errors, checks, the private helpers) come first: every layer may use them. experiments and
#: batch share a layer: each uses the other.
LAYERS = (
    ("",),  # the root modules
    ("model",),  # the symbolic model
    ("compiled",),
    ("integrate",),
    ("roots",),
    ("bvp",),
    ("planning",),
    ("viz",),
    ("experiments", "batch"),
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


def _imports(modules) -> dict[str, set[str]]:
    """Each module's imports of other modules of the package, at the top or inside functions,
    relative or absolute (the kernel templates import the package by its name). Parents are
    left out: Python imports a package before its modules anyway."""
    edges: dict[str, set[str]] = {m: set() for m in modules}
    for mod, (path, is_pkg) in modules.items():
        base = mod.split(".") if is_pkg else mod.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and (node.level or node.module in modules):
                up = base[: len(base) - (node.level - 1)] if node.level else []
                target = ".".join(up + ([node.module] if node.module else []))
                subs = [f"{target}.{a.name}" for a in node.names]
                targets = [s for s in subs if s in modules] or [target]
            else:
                continue
            for t in targets:
                if t in modules and t != mod and not mod.startswith(t + "."):
                    edges[mod].add(t)
    return edges


def _layer(module: str) -> str:
    """The subpackage a module belongs to; "" for the root modules and the package itself."""
    parts = module.split(".")[1:]
    is_subpackage = (PACKAGE / "/".join(parts[:1])).is_dir() if parts else False
    return parts[0] if is_subpackage else ""


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
