"""The compiled core: its cache key, found from the files that feed the generated module (never a
hand-kept list) and computed without SymPy; its kernels called through their entry points."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np

from conftest import CASES, EXTREMAL_COSTATE
from leapfrog_planner import Flow
from leapfrog_planner.compiled.cache_key import PACKAGE, cache_key, generator_sources
from leapfrog_planner.compiled.kernels import entry_point, load_kernels
from leapfrog_planner.model import builtin_source

#: Files that must feed the key whatever else does: the generator and what it pastes in, what
#: the generated code imports, and the symbolic derivation that shapes its text.
EXPECTED = {
    "compiled/codegen.py",
    "compiled/flow_template.py",
    "compiled/newton_template.py",
    "compiled/abi.py",
    "compiled/status.py",
    "compiled/linear.py",
    "model/base.py",
    "model/pmp.py",
    "model/bounds.py",
    "model/penalty.py",
}


def _names(sources) -> set[str]:
    return {p.relative_to(PACKAGE).as_posix() for p in sources}


def test_the_key_follows_the_generator_and_everything_the_generated_code_imports():
    names = _names(generator_sources())
    assert EXPECTED <= names, EXPECTED - names
    # Every package module the generated module imports, read from a generated module itself.
    generated = Path(load_kernels("unicycle").__file__).read_text()
    imported = {
        node.module
        for node in ast.walk(ast.parse(generated))
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("leapfrog_planner.")
    }
    assert imported, "the generated module imports from the package"
    for module in imported:
        assert module.split(".", 1)[1].replace(".", "/") + ".py" in names, module


def test_changing_any_file_that_feeds_the_module_changes_the_key():
    source = builtin_source("unicycle")
    sources = generator_sources()
    base = cache_key(source)
    assert base == cache_key(source, read=Path.read_text)  # the same key, recomputed
    keys = {base}
    for path in sources:

        def altered(p, path=path):
            return p.read_text() + ("\n# changed\n" if p == path else "")

        keys.add(cache_key(source, read=altered))
    assert len(keys) == len(sources) + 1  # each alteration gives a key of its own
    assert cache_key(builtin_source("car")) != base  # and so does the model


def test_a_module_newly_imported_by_a_template_joins_the_key():
    template = PACKAGE / "compiled" / "flow_template.py"
    new = PACKAGE / "integrate" / "tableaux.py"

    def read(p):
        extra = "\nfrom leapfrog_planner.integrate import tableaux\n" if p == template else ""
        return p.read_text() + extra

    assert new not in generator_sources()
    assert new in generator_sources(read)
    assert cache_key("m", read) != cache_key("m")


def test_a_warm_start_computes_the_key_and_loads_the_kernels_without_sympy():
    load_kernels("car")  # generated now if the cache is cold
    code = (
        "import sys\n"
        "from leapfrog_planner.compiled.kernels import load_kernels\n"
        "load_kernels('car')\n"
        "assert 'sympy' not in sys.modules, 'SymPy was imported'\n"
    )
    env = {**os.environ, "PYTHONPATH": str(PACKAGE.parent)}
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_a_kernel_called_through_its_entry_point_gives_the_dispatchers_bits():
    """Flow calls its integrator through the compiled entry point (no per-call typing of the
    records): the same bits as numba's dispatcher, and the same machine code for the same
    types."""
    c = CASES[4]
    flow = Flow(c.problem())
    Y0 = np.concatenate([c.start, EXTREMAL_COSTATE[4], [0.0], np.eye(6)[:, 3:].ravel()])
    args = (Y0, 0.0, 1.0, 3, flow.dynamics, flow.control, flow.dynamics.no_samples)
    kernel = flow.kernels.erk_adaptive
    direct = kernel(*args)
    entry = entry_point(kernel, args)
    assert entry is entry_point(kernel, args)
    through = entry(*args)
    np.testing.assert_array_equal(direct[0], through[0])
    assert direct[1:] == through[1:]
    r = flow(0.0, Y0[:6], 1.0, sensitivity="costate")
    np.testing.assert_array_equal(r.z, direct[0][:6])
    assert entry_point(len, ()) is len  # not a numba kernel (or the JIT disabled): itself


def test_an_entry_point_is_remembered_per_argument_types_never_across_them():
    """Entry points are kept by the fingerprint of their arguments' types: arguments of other
    types (dtype, dimensions, layout, a read-only array, another record class) get their own
    machine code, and arguments numba types otherwise than the fingerprint sees are not kept."""
    from collections import namedtuple

    @numba.njit
    def total(a, pair):
        return a.sum() + pair[0] + pair[1]

    Pair, Other = namedtuple("Pair", "x y"), namedtuple("Other", "x y")
    a = np.arange(4.0)
    readonly = a.copy()
    readonly.flags.writeable = False
    calls = [
        (a, Pair(1.0, 2.0)),
        (a, Other(1.0, 2.0)),
        (a, Pair(1, 2)),
        (np.arange(4), Pair(1.0, 2.0)),
        (a.reshape(2, 2), Pair(1.0, 2.0)),
        (a[::2], Pair(1.0, 2.0)),
        (readonly, Pair(1.0, 2.0)),
    ]
    entries = [entry_point(total, args) for args in calls]
    for args, entry in zip(calls, entries, strict=True):
        assert entry is entry_point(total, args)
        assert entry(*args) == total(*args)
        assert entry is total.overloads[tuple(numba.typeof(v) for v in args)].entry_point
    assert len({id(e) for e in entries}) == len(calls)
