"""Print a vehicle model's canonical system as numba code (SymPy is needed only here).

The derived canonical system is printed as plain Python (with common subexpressions shared) and
followed by the kernel templates (``flow_template.py``, ``newton_template.py``, which import what
they use from the package); :mod:`.kernels` writes it to the disk cache and loads it.
Obstacles, end states and parameters are arguments, never constants of the code.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..model import get_model
from ..model.base import VehicleModel
from ..model.bounds import boundable
from .status import kernel_constants

CODEGEN_VERSION = "1"
#: The compiled integrator and shooting loops, appended to each model's generated code.
TEMPLATES = (
    Path(__file__).with_name("flow_template.py"),
    Path(__file__).with_name("newton_template.py"),
)


class _Printer(PythonCodePrinter):
    """Python code for numba: float literals, small integer powers as products (much faster)."""

    def _print_Rational(self, expr):
        return f"({float(expr.p)!r} / {float(expr.q)!r})"

    def _print_Integer(self, expr):
        return f"{float(expr)!r}"

    def _print_Pow(self, expr, rational=False):
        base, ex = expr.as_base_exp()
        if ex.is_Integer and 1 <= abs(int(ex)) <= 4:
            b = self.parenthesize(base, 100)
            prod = "*".join([b] * abs(int(ex)))
            return f"({prod})" if ex > 0 else f"(1.0 / ({prod}))"
        if ex.is_Integer:
            return f"{self.parenthesize(base, 100)}**{int(ex)}"
        return super()._print_Pow(expr, rational=rational)


def _cse_block(exprs, names, pad):
    """Lines reading the used inputs and computing shared subexpressions; and the reduced exprs.

    With ``names.controls`` (see :class:`_Names`), the controls ``u0``... and their slopes
    ``g0``... are computed in the block too: the law's subexpressions first, then the
    saturation, then what depends on the controls (one CSE over all, so the trigonometry the
    law and the equations share is computed once)."""
    pr = _Printer()
    law = names.controls.law if names.controls else ()
    subs, reduced = sp.cse(
        [sp.sympify(e).xreplace(names) for e in (*law, *exprs)],
        symbols=sp.numbered_symbols("c"),
        optimizations="basic",
    )
    law_code, reduced = reduced[: len(law)], reduced[len(law) :]
    late = {sp.Symbol(n) for n in names.controls.outputs} if names.controls else set()
    early, after = [], []
    for sym, value in subs:  # in dependency order: what needs a control, after the controls
        if value.free_symbols & late:
            late.add(sym)
            after.append((sym, value))
        else:
            early.append((sym, value))
    used = set().union(
        *(e.free_symbols for e in (*law_code, *reduced)), *(v.free_symbols for _, v in subs)
    )
    lines = [f"{pad}{n} = {src}" for n, src in names.values_source if sp.Symbol(n) in used]
    lines += [f"{pad}{s} = {pr.doprint(v)}" for s, v in early]
    if names.controls:
        lines += [f"{pad}{line}" for line in names.controls.lines(pr.doprint(c) for c in law_code)]
    lines += [f"{pad}{s} = {pr.doprint(v)}" for s, v in after]
    return lines, [pr.doprint(e) for e in reduced]


def _function(name, args, exprs, targets, names, first=()):
    """Source of one njit function assigning ``exprs`` to ``targets`` (format strings)."""
    body, code = _cse_block(exprs, names, "    ")
    lines = [
        '@njit(cache=True, error_model="numpy")',
        f"def {name}({', '.join(args)}):",
        *(f"    {line}" for line in first),
    ]
    lines += body + [f"    {t.format(expr=c)}" for t, c in zip(targets, code, strict=True)]
    return "\n".join(lines)


@dataclass(frozen=True)
class _Saturation:
    """How a block computes the controls: the law without bounds, then
    :func:`..model.bounds.saturate` with the parameters of each control's bounds."""

    law: tuple[sp.Expr, ...]
    calls: tuple[tuple[int, ...], ...]  # per control: indices in p of lo, hi, switch, width

    @classmethod
    def of(cls, sysm) -> _Saturation:
        m = sysm.model
        index = {s: i for i, s in enumerate(m.parameters)}
        calls = tuple(
            tuple(index[s] for s in (lo, hi, on, m.smoothing)) for _, lo, hi, on in m.control_bounds
        )
        return cls(sysm.control_law, calls)

    @property
    def outputs(self) -> list[str]:
        return [f"{v}{i}" for i in range(len(self.law)) for v in "ug"]

    def lines(self, law_code) -> list[str]:
        return [
            f"u{i}, g{i} = saturate({code}, {', '.join(f'p[{j}]' for j in call)})"
            for i, (code, call) in enumerate(zip(law_code, self.calls, strict=True))
        ]


class _Names(dict):
    """Maps model symbols to code names, remembering how each name is read from the arrays.
    With ``controls`` (a :class:`_Saturation`), the model's controls and slopes (``controls``
    and ``slopes``, symbols) are computed in the block instead."""

    def __init__(self, z_syms, p_syms, u_syms=(), controls=None, symbols=((), ())):
        super().__init__()
        self.values_source = []
        self.controls = controls
        for i, s in enumerate(z_syms):
            self._add(s, f"z{i}", f"z[{i}]")
        for i, s in enumerate(p_syms):
            self._add(s, f"p{i}", f"p[{i}]")
        for i, s in enumerate(u_syms):
            self._add(s, f"u{i}", f"u[{i}]")
        for prefix, syms in zip("ug", symbols, strict=True):
            self.update({s: sp.Symbol(f"{prefix}{i}") for i, s in enumerate(syms)})

    def _add(self, sym, name, source):
        self[sym] = sp.Symbol(name)
        self.values_source.append((name, source))


def _header(model: VehicleModel) -> str:
    """The module's imports, constants and the model's metadata (so a warm start needs no
    SymPy)."""
    nx, nz = model.nx, 2 * model.nx
    return "\n".join(
        [
            f"# Generated by leapfrog_planner.compiled.codegen (version {CODEGEN_VERSION}) for"
            f" model {model.name!r}. Do not edit.",
            "import math\n",
            "import numpy as np",
            "from numba import njit\n",
            "from leapfrog_planner.model.bounds import saturate\n",
            *kernel_constants(),
            f"NX = {nx}",
            f"NZ = {nz}",
            f"NU = {model.nu}",
            "# Model metadata, so that a warm start never needs SymPy.",
            f"MODEL_NAME = {model.name!r}",
            f"STATE_NAMES = {tuple(str(x) for x in model.states)!r}",
            f"CONTROL_NAMES = {tuple(model.control_names)!r}",
            f"PARAMETER_NAMES = {tuple(model.parameter_names)!r}",
            f"PARAMETER_DEFAULTS = {tuple(float(d) for d in model.defaults)!r}",
            f"PARAMETER_POSITIVE = {tuple(bool(p.is_positive) for p in model.parameters)!r}",
            f"PARAMETER_NONNEGATIVE = {tuple(bool(p.is_nonnegative) for p in model.parameters)!r}",
            f"DESCRIPTION = {model.description!r}",
            f"PLANNING_AID = {model.aid.as_tuple() if model.aid else None!r}",
            "# No fast math: it measured no faster here, and without it the flow gives the same",
            "# bits whether called from Python or inlined into the compiled shooting loop (fast",
            "# math lets LLVM reassociate differently in each context). Finiteness is still",
            "# tested on the bits, so that turning it on cannot fold NaN checks away.",
            "FASTMATH = False",
            "# Inline the hot kernels into the integrator loops (numba IR inlining).",
            'INLINE = "always"',
        ]
    )


def model_source(model: VehicleModel) -> str:
    """The model part of the generated module (the template is appended to it)."""
    from ..model.pmp import derive

    sysm = derive(boundable(get_model(model)))
    model = sysm.model
    nx, nz = model.nx, 2 * model.nx
    z = sysm.z
    # The canonical system at the controls u*(z), computed in each function that needs them.
    names = _Names(
        z, model.parameters, controls=_Saturation.of(sysm), symbols=(model.controls, sysm.slopes)
    )
    names_u = _Names(z, model.parameters, model.controls)  # functions taking u as an argument

    rhs = sysm.rhs()
    jac = sysm.jacobian()
    nonzero = [(i, j) for i in range(nz) for j in range(nz) if jac[i, j] != 0]
    # d(H)/du with u free: the penalty does not depend on u, so the model part is all of it.
    dHdu = [sp.diff(sysm.hamiltonian.subs(sysm.penalty, 0), u) for u in model.controls]

    header = _header(model)
    # Linearisation data for the affine costate guess: f, df/dx, df/du and d2L/du2 at (x, u).
    xu_names = _Names(model.states, model.parameters, model.controls)
    xu_names.values_source = [(n, src.replace("z[", "x[")) for n, src in xu_names.values_source]
    fx = sp.Matrix(model.dynamics).jacobian(sp.Matrix(model.states))
    fu = sp.Matrix(model.dynamics).jacobian(sp.Matrix(model.controls))
    Luu = sp.hessian(model.running_cost, model.controls)
    nu = model.nu
    lin_exprs = [*model.dynamics, *fx, *fu, *Luu]
    lin_targets = (
        [f"f[{i}] = {{expr}}" for i in range(nx)]
        + [f"A[{i}, {j}] = {{expr}}" for i in range(nx) for j in range(nx)]
        + [f"B[{i}, {j}] = {{expr}}" for i in range(nx) for j in range(nu)]
        + [f"R[{i}, {j}] = {{expr}}" for i in range(nu) for j in range(nu)]
    )

    parts = [
        header,
        _function(
            "canonical_jac",
            ["z", "p", "J"],
            [jac[i, j] for i, j in nonzero],
            [f"J[{i}, {j}] = {{expr}}" for i, j in nonzero],
            names,
            first=["J[:, :] = 0.0"],
        ),
        _augmented_function(rhs, sysm.running_cost, jac, nonzero, nz, names),
        _function(
            "controls",
            ["z", "p", "u"],
            list(model.controls),
            [f"u[{i}] = {{expr}}" for i in range(model.nu)],
            names,
        ),
        _function(
            "hamiltonian_model",
            ["z", "p"],
            [sysm.model_hamiltonian()],
            ["return {expr}"],
            names,
        ),
        _function(
            "dH_du",
            ["z", "u", "p", "out"],
            dHdu,
            [f"out[{i}] = {{expr}}" for i in range(model.nu)],
            names_u,
        ),
        _function(
            "linearize", ["x", "u", "p", "f", "A", "B", "R"], lin_exprs, lin_targets, xu_names
        ),
    ]
    return "\n\n\n".join(parts) + "\n"


def _augmented_function(rhs, cost, jac, nonzero, nz, names):
    """``out = [G(z), L(z), DG(z) @ S]`` in one pass, so shared terms (trig) are computed once.

    ``S`` has ``k`` columns stored row-major; only the Jacobian's structural nonzeros are used.
    """
    entries = [jac[i, j] for i, j in nonzero]
    body, code = _cse_block([*rhs, cost, *entries], names, "    ")
    lines = [
        '@njit(cache=True, fastmath=FASTMATH, inline=INLINE, error_model="numpy")',
        "def model_augmented(z, p, S, k, out):",
        *body,
    ]
    lines += [f"    out[{i}] = {c}" for i, c in enumerate(code[: nz + 1])]
    lines += [f"    J{i}_{j} = {c}" for (i, j), c in zip(nonzero, code[nz + 1 :], strict=True)]
    lines.append("    for c in range(k):")
    lines += [f"        s{j} = S[{j} * k + c]" for j in sorted({j for _, j in nonzero})]
    for i in range(nz):
        terms = [f"J{i}_{j} * s{j}" for (ii, j) in nonzero if ii == i]
        lines.append(
            f"        out[{nz + 1} + {i} * k + c] = {' + '.join(terms) if terms else '0.0'}"
        )
    return "\n".join(lines)


def module_text(model: VehicleModel) -> str:
    return "\n\n".join([model_source(model), *(t.read_text() for t in TEMPLATES)])
