# The compiled shooting loops: simple and multiple shooting by classical Newton, the paper's
# modified Newton or NLEQ-ERR, and Leapfrog's warm-started sweep.
#
# This file is a template, not an importable module: leapfrog_planner.compiled.codegen appends it,
# after the integrator (flow_template.py), to the code generated for each vehicle model, which
# defines NX, NZ and the status codes (compiled/status.py). The records it exchanges with Python
# and the linear algebra it shares with the Python loop are imported below.

import math

import numpy as np
from numba import njit

from leapfrog_planner.compiled.abi import (
    Ends,
    Iterate,
    NewtonOutcome,
    Residual,
    StepControl,
    SweepOutcome,
)
from leapfrog_planner.compiled.linear import converges_next, dot, transpose_times

# Simple shooting with classical Newton, the paper's modified Newton or NLEQ-ERR, fused into
# one call.
#
# This is the compiled twin of roots.loop.solve_root + roots.steps.{NewtonStep,
# ModifiedNewtonStep, NleqErrStep} + shooting.ShootingSystem (inexact evaluations included), for
# the local problems of Leapfrog, where the Python layers cost as much as the integration
# (measured: ~50 us per iteration against 10-100 us of flow). Same iterates bit for bit, same
# statuses and iterations; the tests compare the two. Status codes follow RootStatus's order.
#
# The loop counts its work in ``counts`` (int64): evaluations, evaluations of F alone and
# accepted integrator steps, added to by each evaluation (:func:`_trial`). ``seen`` is the pair
# (the latest evaluation (s, Y, ok), the smallest |F| so far), which each evaluation updates.

EVALS, F_ALONE, STEPS = 0, 1, 2


@njit(cache=True, error_model="numpy")
def _shoot_eval(s, residual, best_norm, jac):
    """F(s) = x(t1) - x1 and DF(s), as ShootingSystem.evaluate; over more than two junction
    times, the multiple-shooting residual of :func:`_multiple_eval`.

    ``residual`` holds the ends (with the junction times ``(t0, t1)`` for simple shooting),
    the accuracy and the dynamics. Returns (ok, F, J, Y, |F|, accepted steps). ``k`` (= NX,
    the costate columns) comes from the caller at run time, as in the Flow's calls, so that
    both run the same code on the same values. ``jac`` False: F alone (J is zero), from the
    same steps and to the same bits (the sensitivities do not steer the steps).
    """
    ends, accuracy, dynamics = residual.ends, residual.accuracy, residual.dynamics
    if ends.times.size > 2:
        return _multiple_eval(s, residual, jac)
    t0, t1 = ends.times[0], ends.times[1]
    k = accuracy.k if jac else 0
    Y0 = np.zeros(NZ + 1 + NZ * k)
    for m in range(NX):
        Y0[m] = ends.x0[m]
        Y0[NX + m] = s[m]
        if k:
            Y0[NZ + 1 + (NX + m) * k + m] = 1.0  # seed: the costate columns of the identity
    base = accuracy.control
    control = base
    if accuracy.inexact:
        loose = min(1e-6, 1e-4 * best_norm)
        control = StepControl(max(base.rtol, loose), max(base.atol, loose), base.max_steps)
    F = np.empty(NX)
    J = np.empty((NX, NX))
    steps = 0
    norm = np.inf
    for attempt in range(2):
        Y, status, acc, _ = erk_adaptive(Y0, t0, t1, k, dynamics, control, dynamics.no_samples)
        steps += acc
        if status != OK:
            return False, F, J, Y, np.inf, steps
        for m in range(NX):
            F[m] = Y[m] - ends.x1[m]
        norm = math.sqrt(dot(F, F))
        if attempt == 0 and control.rtol > base.rtol and norm <= 1e3 * control.rtol:
            # Too close to the integration error to trust: redo at the full tolerance.
            control = base
            continue
        break
    if not k:
        J[:, :] = 0.0
        return _finite(dot(F, F)), F, J, Y, norm, steps
    for i in range(NX):
        for j in range(NX):
            J[i, j] = Y[NZ + 1 + i * k + j]
    # As the Python evaluator: a point whose |F|^2 or |J|^2 is not finite is unusable.
    ok = _finite(dot(F, F)) and _finite(np.sum(J * J))
    return ok, F, J, Y, norm, steps


@njit(cache=True, error_model="numpy")
def _multiple_eval(w, residual, jac):
    """The residual and Jacobian of multiple shooting over the junction times ``T``, as
    multiple_shooting.MultipleShootingSystem.evaluate: unknowns ``w = (lambda_0, z_1, ...,
    z_{q-1})``, residuals the continuity defects ``z(t_{j+1}; t_j, z_j) - z_{j+1}`` and the
    end-state error. Leapfrog's two-arc attempt is the case q = 2. Always at the flow's own
    tolerances (no inexact evaluations, as the Python system). Returns what
    :func:`_shoot_eval` returns; ``Y`` is the last arc's."""
    x0, x1, T = residual.ends
    control, dynamics = residual.accuracy.control, residual.dynamics
    q = T.size - 1
    n = w.size
    F = np.empty(n)
    J = np.zeros((n, n))
    Y = np.empty(0)
    steps = 0
    for j in range(q):
        # The first arc's state is fixed (x0): only its costate columns are unknowns.
        k = (NX if j == 0 else NZ) if jac else 0
        Y0 = np.zeros(NZ + 1 + NZ * k)
        if j == 0:
            for m in range(NX):
                Y0[m] = x0[m]
                Y0[NX + m] = w[m]
                if k:
                    Y0[NZ + 1 + (NX + m) * k + m] = 1.0
        else:
            c = NX + (j - 1) * NZ
            for m in range(NZ):
                Y0[m] = w[c + m]
                if k:
                    Y0[NZ + 1 + m * k + m] = 1.0
        Y, status, acc, _ = erk_adaptive(
            Y0, T[j], T[j + 1], k, dynamics, control, dynamics.no_samples
        )
        steps += acc
        if status != OK:
            return False, F, J, Y, np.inf, steps
        r0 = j * NZ
        last = j == q - 1
        rows = NX if last else NZ
        for m in range(rows):
            F[r0 + m] = Y[m] - (x1[m] if last else w[NX + j * NZ + m])
        if k:
            c0 = 0 if j == 0 else NX + (j - 1) * NZ
            for m in range(rows):
                for c in range(k):
                    J[r0 + m, c0 + c] = Y[NZ + 1 + m * k + c]
                if not last:
                    J[r0 + m, NX + j * NZ + m] -= 1.0
    norm = math.sqrt(dot(F, F))
    ok = _finite(dot(F, F)) and (not jac or _finite(np.sum(J * J)))
    return ok, F, J, Y, norm, steps


@njit(cache=True, error_model="numpy")
def _trial(s, residual, best_norm, jac, counts):
    """:func:`_shoot_eval` at ``s`` as the loop records it: (ok, the Iterate, ``seen``), with
    the evaluation counted in ``counts``."""
    ok, F, J, Y, norm, steps = _shoot_eval(s, residual, best_norm, jac)
    counts[EVALS] += 1
    if not jac:
        counts[F_ALONE] += 1
    counts[STEPS] += steps
    return ok, Iterate(s, F, J), ((s.copy(), Y, ok), min(best_norm, norm))


@njit(cache=True, error_model="numpy")
def _full_step(x, norms, root, residual, seen, counts):
    """The evaluation at a full Newton step's point ``x``: F alone where convergence is predicted
    there (``root.predict``; :func:`converges_next` on the last two of ``norms``), and again
    with J where it then does not come (at the same tolerance: the same F). So every iterate
    returned without J has converged. Returns (ok, iterate, seen)."""
    n = norms.size
    alone = root.predict and n >= 2 and converges_next(norms[n - 2], norms[n - 1], root.tol)
    before = seen[1]
    ok, point, seen = _trial(x, residual, before, not alone, counts)
    if alone and ok and not math.sqrt(dot(point.F, point.F)) <= root.tol:
        ok, point, seen = _trial(x, residual, before, residual.jacobian, counts)
    return ok, point, seen


@njit(cache=True, error_model="numpy")
def _nleq_step(point, d, memo, step, residual, seen, counts):
    """NLEQ-ERR's step (roots.steps.NleqErrStep): damping from the simplified correction
    dxbar = -J^-1 F(x + lam dx), predicted from the last step, corrected per trial. ``memo =
    (lam, lam_prev, has_memo, dx_prev, dxbar_prev)`` is its memory between steps. Returns
    (found, the new iterate, lam, seen, memo)."""
    lam_memo, lam_prev, has_memo, dx_prev, dxbar_prev = memo
    x, J = point.x, point.J
    dx = -d
    ndx = math.sqrt(dot(dx, dx))
    lam = lam_memo
    if has_memo:
        diff = dxbar_prev - dx
        denom = math.sqrt(dot(diff, diff)) * ndx
        if denom == 0:
            mu = np.inf
        else:
            mu = (
                math.sqrt(dot(dx_prev, dx_prev)) * math.sqrt(dot(dxbar_prev, dxbar_prev)) / denom
            ) * lam_prev
        lam = min(1.0, mu)
    reduced = False
    for _ in range(step.max_trials):
        if lam < step.min_damping:
            break
        xt = x + lam * dx
        okt, trial, seen = _trial(xt, residual, seen[1], residual.jacobian, counts)
        if not okt:
            lam, reduced = lam / 2, True  # outside the domain of F (the flow blew up)
            continue
        dxbar = -np.linalg.solve(J, trial.F)
        nbar = math.sqrt(dot(dxbar, dxbar))
        if not (lam == 1.0 and nbar <= step.xtol * (1.0 + math.sqrt(dot(xt, xt)))):
            theta = nbar / ndx if ndx > 0 else 0.0
            r = dxbar - (1.0 - lam) * dx
            denom = math.sqrt(dot(r, r))
            mu_c = np.inf if denom == 0 else 0.5 * ndx * lam * lam / denom
            if theta >= 1.0 - lam / 4.0:
                lam, reduced = min(mu_c, lam / 2.0), True
                continue
            lam_c = min(1.0, mu_c)
            if not reduced and lam_c >= 4.0 * lam and lam < 1.0:
                lam = lam_c
                continue
        # (else converged in Deuflhard's sense: the full step is taken)
        return True, trial, lam, seen, (lam, lam, True, dx, dxbar)
    return False, point, lam, seen, memo


@njit(cache=True, error_model="numpy")
def _mnm_step(point, d, cond, norms, solver, residual, seen, counts):
    """The modified Newton step (roots.steps.ModifiedNewtonStep): h = F^T F must fall by
    2^-m (gamma/4) |d| |Dh| for the smallest such m; the best of the tried steps is taken.
    ``norms`` are those of the iterates so far. Returns (found, the new iterate, lam, seen)."""
    root = solver.root
    x, F, J = point
    g = 2.0 * transpose_times(J, F)
    slope = 0.25 * (1.0 / cond) * math.sqrt(dot(d, d)) * math.sqrt(dot(g, g))
    h0 = dot(F, F)
    best_h = np.inf
    best, lam = point, 1.0
    for m in range(solver.step.max_halvings + 1):
        lt = 2.0**-m
        xt = x - lt * d
        if m == 0:
            okt, trial, seen = _full_step(xt, norms, root, residual, seen, counts)
        else:
            okt, trial, seen = _trial(xt, residual, seen[1], residual.jacobian, counts)
        h = dot(trial.F, trial.F) if okt else np.inf
        if m == 0 or h < best_h:
            best_h, best, lam = h, trial, lt
        if h <= h0 - lt * slope:
            return True, best, lam, seen
    return False, best, lam, seen


@njit(cache=True, error_model="numpy")
def _verdict(norms, iteration, root):
    """The status that ends the loop at an iterate whose |F| is the last of ``norms``, or -1
    to go on."""
    n = norms.size
    if norms[n - 1] <= root.tol:
        return CONVERGED
    if iteration == root.max_iterations:
        return MAX_ITERATIONS
    w = root.stall_window
    if w > 0 and iteration >= w:
        big = 0.0
        for j in range(n - 1 - w, n - 1):
            big = max(big, norms[j])
        if norms[n - 1] > root.stall_factor * big:
            return STALLED
    return -1


@njit(cache=True, error_model="numpy")
def _out(code, point, iterations, n, cond, seen, counts):
    """shoot_newton's NewtonOutcome."""
    evals = counts[EVALS]
    return NewtonOutcome(
        code, point.x, point.F, iterations, evals, n, cond, seen[0], counts[STEPS],
        evals - counts[F_ALONE],
    )  # fmt: skip


@njit(cache=True, error_model="numpy", nogil=True)
def shoot_newton(ends, s0, solver, dynamics, history):
    """Simple (or, over more junction times, multiple) shooting from ``s0`` by the ``solver``'s
    method: Newton (0), MNM (1) or NLEQ-ERR (2), with its settings; ``history`` receives |F| of
    the iterates and the damping of the steps. With ``solver.root.predict``, NM and MNM (its
    full step) evaluate F alone where convergence is predicted (:func:`_full_step`), as the
    Python loop does with RootSettings.predict: the same iterates, counts and statuses.
    Returns a NewtonOutcome: the status code, the final iterate
    and its residual, the counts, ``last = (s, Y, ok)`` the latest evaluation (for the result's
    cost and end costate), the accepted integrator steps of all evaluations and the number of
    evaluations that carried the variational equations.
    """
    root, norms, lams = solver.root, history.norms, history.lams
    residual = Residual(ends, solver.accuracy, dynamics, np.bool_(True))
    counts = np.zeros(3, np.int64)
    # NLEQ-ERR's memory between steps (roots.steps._NleqMemo)
    memo = (solver.step.initial_damping, 1.0, False, np.zeros(s0.size), np.zeros(s0.size))
    bound = root.divergence * (1.0 + math.sqrt(dot(s0, s0)))
    ok, point, seen = _trial(s0.copy(), residual, np.inf, residual.jacobian, counts)
    n = done = 0
    cond = 0.0
    if not ok:
        return _out(NON_FINITE_F, point, done, n, cond, seen, counts)
    for iteration in range(root.max_iterations + 1):
        norms[n] = math.sqrt(dot(point.F, point.F))
        n += 1
        code = _verdict(norms[:n], iteration, root)
        if code >= 0:
            return _out(code, point, done, n, cond, seen, counts)
        sv = np.linalg.svd(point.J)[1]
        cond = sv[0] / sv[-1] if sv[-1] > 0.0 else np.inf
        if not cond <= root.max_cond:
            return _out(SINGULAR_JACOBIAN, point, done, n, cond, seen, counts)
        d = np.linalg.solve(point.J, point.F)
        found, have_F, new, lam = True, True, point, 1.0
        if solver.method == 0:
            have_F, new = False, Iterate(point.x - d, point.F, point.J)
        elif solver.method == 2:
            found, new, lam, seen, memo = _nleq_step(
                point, d, memo, solver.step, residual, seen, counts
            )
        else:
            found, new, lam, seen = _mnm_step(point, d, cond, norms[:n], solver, residual, seen,
                                              counts)  # fmt: skip
        if not found:
            return _out(LINE_SEARCH_FAILED, point, done, n, cond, seen, counts)
        lams[done] = lam
        done += 1
        point = new  # an accepted trial passed its test, so its F is finite
        xx = dot(point.x, point.x)
        if not (_finite(xx) and math.sqrt(xx) <= bound):
            if not have_F:
                point = Iterate(point.x, np.full(point.x.size, np.nan), point.J)
            return _out(DIVERGED, point, done, n, cond, seen, counts)
        if not have_F:
            ok, point, seen = _full_step(point.x, norms[:n], root, residual, seen, counts)
            if not ok:
                return _out(NON_FINITE_F, point, done, n, cond, seen, counts)
    return _out(MAX_ITERATIONS, point, done, n, cond, seen, counts)


# --------------------------------------------------------------------------------------------
# A Leapfrog sweep's warm-started local problems, fused into one call.
#
# The compiled twin of leapfrog.sweep's common case: the local problem of junction i converges
# from the costate of arc i-1, and its extremal replaces the two arcs if it is not dearer. The
# Python code around each local solve (the shooter's packing, the result object, the half flow's
# wrapper) cost about 50 us per junction, as much as the solve itself on paper case 1 (its serial
# CPU time fell by 36% with this kernel, cases 2-4 by 2-20%). The first junction whose
# warm attempt fails (or whose answer needs the Python path) is handed back; Python runs its
# fallbacks and calls again from the next junction. Same arithmetic as the Python sweep, bit for
# bit (tested).


@njit(cache=True, error_model="numpy")
def _move_junction(arcs, i, lam, Y, dynamics, control):
    """Replace arcs ``i - 1`` and ``i`` by the local extremal from junction ``i - 1`` with
    initial costate ``lam`` (``Y`` its end), split at the middle of its time: the flow of
    leapfrog.sweep. Returns the half flow's accepted steps."""
    T, X, L0, L1, C = arcs
    ta = T[i - 1]
    tm = 0.5 * (ta + T[i + 1])
    Y0 = np.zeros(NZ + 1)
    for m in range(NX):
        Y0[m] = X[i - 1, m]
        Y0[NX + m] = lam[m]
    # k = 0 as a run-time int64: a literal 0 would compile erk_adaptive a second time.
    H, _, acc, _ = erk_adaptive(Y0, ta, tm, np.int64(0), dynamics, control, dynamics.no_samples)
    T[i] = tm
    for m in range(NX):
        X[i, m] = H[m]
        L0[i - 1, m] = lam[m]
        L1[i - 1, m] = H[NX + m]
        L0[i, m] = H[NX + m]
        L1[i, m] = Y[NX + m]
    C[i] = Y[NZ] - H[NZ]
    C[i - 1] = H[NZ]
    return acc


@njit(cache=True, error_model="numpy", nogil=True)
def sweep_warm(arcs, i, solver, dynamics, history):
    """Junctions ``i, i+1, ..., q-1`` of a Gauss-Seidel sweep over the ``arcs`` (updated in
    place), each from its warm guess ``L0[i-1]`` by :func:`shoot_newton` (the shooter's
    ``solver``, ``dynamics`` and ``history``). Returns a SweepOutcome: why and at which
    junction it stopped, and its counts."""
    T, X, L0, L1, C = arcs
    q = T.size - 1
    iterations = evals = rejected = steps = integrations = jacobians = 0
    while i < q:
        times = np.empty(2)
        times[0], times[1] = T[i - 1], T[i + 1]
        out = shoot_newton(
            Ends(X[i - 1], X[i + 1], times), L0[i - 1].copy(), solver, dynamics, history
        )
        if out.code != CONVERGED:
            return SweepOutcome(
                SWEEP_WARM_FAILED, i, iterations + out.iterations, evals + out.f_evals, rejected,
                steps + out.steps, integrations + out.f_evals, jacobians + out.jacobians,
            )  # fmt: skip
        last_s, Y, last_ok = out.last
        if not (last_ok and (last_s == out.x).all()):
            return SweepOutcome(
                SWEEP_PYTHON, i, iterations, evals, rejected, steps, integrations, jacobians
            )
        iterations += out.iterations
        evals += out.f_evals
        steps += out.steps
        integrations += out.f_evals
        jacobians += out.jacobians
        old = C[i - 1] + C[i]
        if Y[NZ] > old + 1e-10 * max(1.0, abs(old)):
            rejected += 1
        else:
            steps += _move_junction(arcs, i, out.x, Y, dynamics, solver.accuracy.control)
            integrations += 1
        i += 1
    return SweepOutcome(SWEEP_DONE, q, iterations, evals, rejected, steps, integrations, jacobians)
