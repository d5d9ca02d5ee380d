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

from leapfrog_planner.compiled.abi import NewtonOutcome, SweepOutcome
from leapfrog_planner.compiled.linear import dot, transpose_times

# Simple shooting with classical Newton, the paper's modified Newton or NLEQ-ERR, fused into
# one call.
#
# This is the compiled twin of roots.loop.solve_root + roots.steps.{NewtonStep,
# ModifiedNewtonStep, NleqErrStep} + shooting.ShootingSystem (inexact evaluations included), for
# the local problems of Leapfrog, where the Python layers cost as much as the integration
# (measured: ~50 us per iteration against 10-100 us of flow). Same iterates bit for bit, same
# statuses and iterations; the tests compare the two. Status codes follow RootStatus's order.


@njit(cache=True, error_model="numpy")
def _shoot_eval(s, ends, accuracy, best_norm, kin, jac):
    """F(s) = x(t1) - x1 and DF(s), as ShootingSystem.evaluate; over more than two junction
    times, the multiple-shooting residual of :func:`_multiple_eval`.

    ``ends = (x0, x1, T)`` with the junction times ``T = (t0, t1)`` for simple shooting,
    ``accuracy = (rtol, atol, max_steps, inexact, k)``, ``kin`` the integrator's tableau and
    the problem data. Returns (ok, F, J, Y, |F|, accepted steps). ``k`` (= NX, the costate
    columns) comes from the caller at run time, as in the Flow's calls, so that both run the
    same code on the same values. ``jac`` False: F alone (J is zero), from the same steps and
    to the same bits (the sensitivities do not steer the steps).
    """
    x0, x1, T = ends
    if T.size > 2:
        return _multiple_eval(s, x0, x1, T, accuracy, kin, jac)
    t0, t1 = T[0], T[1]
    base_rtol, base_atol, max_steps, inexact, k = accuracy
    if not jac:
        k = 0
    A, b, e, e3, order, p, obs, weight, exponent, no_T, no_Z = kin
    Y0 = np.zeros(NZ + 1 + NZ * k)
    for m in range(NX):
        Y0[m] = x0[m]
        Y0[NX + m] = s[m]
        if k:
            Y0[NZ + 1 + (NX + m) * k + m] = 1.0  # seed: the costate columns of the identity
    rtol, atol = base_rtol, base_atol
    if inexact:
        loose = min(1e-6, 1e-4 * best_norm)
        rtol, atol = max(rtol, loose), max(atol, loose)
    F = np.empty(NX)
    J = np.empty((NX, NX))
    steps = 0
    norm = np.inf
    for attempt in range(2):
        Y, status, acc, _ = erk_adaptive(
            Y0, t0, t1, k, A, b, e, e3, order, rtol, atol, max_steps, p, obs, weight, exponent,
            no_T, no_Z,
        )  # fmt: skip
        steps += acc
        if status != OK:
            return False, F, J, Y, np.inf, steps
        for m in range(NX):
            F[m] = Y[m] - x1[m]
        norm = math.sqrt(dot(F, F))
        if attempt == 0 and rtol > base_rtol and norm <= 1e3 * rtol:
            # Too close to the integration error to trust: redo at the full tolerance.
            rtol, atol = base_rtol, base_atol
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
def _multiple_eval(w, x0, x1, T, accuracy, kin, jac):
    """The residual and Jacobian of multiple shooting over the junction times ``T``, as
    multiple_shooting.MultipleShootingSystem.evaluate: unknowns ``w = (lambda_0, z_1, ...,
    z_{q-1})``, residuals the continuity defects ``z(t_{j+1}; t_j, z_j) - z_{j+1}`` and the
    end-state error. Leapfrog's two-arc attempt is the case q = 2. Always at the flow's own
    tolerances (no inexact evaluations, as the Python system). Returns what
    :func:`_shoot_eval` returns; ``Y`` is the last arc's."""
    rtol, atol, max_steps = accuracy[0], accuracy[1], accuracy[2]
    A, b, e, e3, order, p, obs, weight, exponent, no_T, no_Z = kin
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
            Y0, T[j], T[j + 1], k, A, b, e, e3, order, rtol, atol, max_steps, p, obs, weight,
            exponent, no_T, no_Z,
        )  # fmt: skip
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
def _trial(s, ends, accuracy, best_norm, kin, jac):
    """:func:`_shoot_eval` at ``s`` as the loop records it: (ok, F, J, the latest evaluation
    ``(s, Y, ok)``, the smallest |F| so far, accepted steps)."""
    ok, F, J, Y, norm, steps = _shoot_eval(s, ends, accuracy, best_norm, kin, jac)
    return ok, F, J, (s.copy(), Y, ok), min(best_norm, norm), steps


# F alone is evaluated where Newton's quadratic convergence predicts convergence with this
# margin: |F_k+1| ~ |F_k|^3 / |F_k-1|^2 <= tol / PREDICT_MARGIN. A wrong prediction costs an
# evaluation, a right one the variational equations (about a quarter of one). Measured on 50
# random scenarios: margin 100 skips J in 10% of the local evaluations for 0.3% more of them,
# 10 in 14% for 0.4% more, 1 in 17% for 1.4% more.
PREDICT_MARGIN = 10.0


@njit(cache=True, error_model="numpy")
def _converges(norms, n, tol):
    """Whether the next iterate is predicted to converge, from the last two norms."""
    if n < 2 or not norms[n - 2] > 0.0:
        return False
    f = norms[n - 1]
    return f * f * f / (norms[n - 2] * norms[n - 2]) * PREDICT_MARGIN <= tol


@njit(cache=True, error_model="numpy")
def _out(code, x, F, iterations, evals, n, cond, last, steps, fonly):
    """shoot_newton's NewtonOutcome (``fonly`` of the ``evals`` evaluations were of F alone)."""
    return NewtonOutcome(code, x, F, iterations, evals, n, cond, last, steps, evals - fonly)


@njit(cache=True, error_model="numpy")
def _nleq_step(x, F, J, d, memo, step, ends, accuracy, best_norm, kin, full, last):
    """NLEQ-ERR's step (roots.steps.NleqErrStep): damping from the simplified correction
    dxbar = -J^-1 F(x + lam dx), predicted from the last step, corrected per trial. ``memo =
    (lam, lam_prev, has_memo, dx_prev, dxbar_prev)`` is its memory between steps. Returns
    (found, x_new, F_new, J_new, lam, last, best_norm, evaluations, steps, memo)."""
    max_halvings, initial_damping, min_damping, xtol, max_trials = step
    lam_memo, lam_prev, has_memo, dx_prev, dxbar_prev = memo
    evals = steps = 0
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
    for _ in range(max_trials):
        if lam < min_damping:
            break
        xt = x + lam * dx
        okt, Ft, Jt, last, best_norm, st = _trial(xt, ends, accuracy, best_norm, kin, full)
        evals += 1
        steps += st
        if not okt:
            lam, reduced = lam / 2, True  # outside the domain of F (the flow blew up)
            continue
        dxbar = -np.linalg.solve(J, Ft)
        nbar = math.sqrt(dot(dxbar, dxbar))
        if not (lam == 1.0 and nbar <= xtol * (1.0 + math.sqrt(dot(xt, xt)))):
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
        return True, xt, Ft, Jt, lam, last, best_norm, evals, steps, (lam, lam, True, dx, dxbar)
    return False, x, F, J, lam, last, best_norm, evals, steps, memo


@njit(cache=True, error_model="numpy")
def _mnm_step(x, F, J, d, cond, norms, n, root, max_halvings, ends, accuracy, best_norm, kin,
              full, last):  # fmt: skip
    """The modified Newton step (roots.steps.ModifiedNewtonStep): h = F^T F must fall by
    2^-m (gamma/4) |d| |Dh| for the smallest such m; the best of the tried steps is taken.
    Returns (found, x_new, F_new, J_new, lam, last, best_norm, evaluations, evaluations of F
    alone, steps)."""
    tol, predict = root.tol, root.predict
    evals = fonly = steps = 0
    g = 2.0 * transpose_times(J, F)
    slope = 0.25 * (1.0 / cond) * math.sqrt(dot(d, d)) * math.sqrt(dot(g, g))
    h0 = dot(F, F)
    best_h = np.inf
    x_new, F_new, J_new, lam = x, F, J, 1.0
    for m in range(max_halvings + 1):
        lt = 2.0**-m
        xt = x - lt * d
        jac = not (predict and m == 0 and _converges(norms, n, tol))
        before = best_norm
        okt, Ft, Jt, last, best_norm, st = _trial(xt, ends, accuracy, best_norm, kin, jac)
        evals += 1
        if not jac:
            fonly += 1
        steps += st
        h = dot(Ft, Ft) if okt else np.inf
        if not jac and h <= h0 - lt * slope and not math.sqrt(h) <= tol:
            # Accepted but not converged: the next iteration needs J here (same F).
            okt, Ft, Jt, last, best_norm, st = _trial(xt, ends, accuracy, before, kin, full)
            evals += 1
            steps += st
        if m == 0 or h < best_h:
            best_h, x_new, F_new, J_new, lam = h, xt, Ft, Jt, lt
        if h <= h0 - lt * slope:
            return True, x_new, F_new, J_new, lam, last, best_norm, evals, fonly, steps
    return False, x_new, F_new, J_new, lam, last, best_norm, evals, fonly, steps


@njit(cache=True, error_model="numpy", nogil=True)
def shoot_newton(ends, s0, method, root, step, accuracy, kin, norms, lams):
    """Simple shooting from ``s0`` by Newton (``method`` 0), MNM (1) or NLEQ-ERR (2).

    ``root`` (RootParams) and ``step`` (StepParams) are the settings; ``norms``
    (max_iterations + 1) and ``lams`` (max_iterations) receive the histories. With
    ``predict``, NM and MNM (its full step) evaluate F alone where :func:`_converges` predicts
    convergence, and again with J if it does not come: the same iterates, with one evaluation
    more per wrong prediction (evaluations count both kinds). Returns a NewtonOutcome: the
    status code, the final iterate and its residual, the counts, ``last = (s, Y, ok)`` the
    latest evaluation (for the result's cost and end costate), the accepted integrator steps
    of all evaluations and the number of evaluations that carried the variational equations.
    """
    tol, max_iterations, max_cond, divergence, stall_window, stall_factor, predict = root
    # With the Jacobian, as a run-time bool: numba compiles _trial (and the flow below it) once
    # per argument type, and a literal True is a type of its own (measured: 6 s of compilation).
    full = np.bool_(True)
    # NLEQ-ERR's memory between steps (roots.steps._NleqMemo)
    memo = (step.initial_damping, 1.0, False, np.zeros(s0.size), np.zeros(s0.size))
    x = s0.copy()
    bound = divergence * (1.0 + math.sqrt(dot(x, x)))
    ok, F, J, last, best_norm, steps = _trial(x, ends, accuracy, np.inf, kin, full)
    evals = 1
    fonly = 0  # evaluations of F alone (predict)
    n = 0
    it_done = 0
    cond = 0.0
    if not ok:
        return _out(NON_FINITE_F, x, F, 0, evals, n, cond, last, steps, fonly)
    for it in range(max_iterations + 1):
        norms[n] = math.sqrt(dot(F, F))
        n += 1
        if norms[n - 1] <= tol:
            return _out(CONVERGED, x, F, it_done, evals, n, cond, last, steps, fonly)
        if it == max_iterations:
            break
        if stall_window > 0 and it >= stall_window:
            big = 0.0
            for j in range(n - 1 - stall_window, n - 1):
                big = max(big, norms[j])
            if norms[n - 1] > stall_factor * big:
                return _out(STALLED, x, F, it_done, evals, n, cond, last, steps, fonly)
        sv = np.linalg.svd(J)[1]
        cond = sv[0] / sv[-1] if sv[-1] > 0.0 else np.inf
        if not cond <= max_cond:
            return _out(SINGULAR_JACOBIAN, x, F, it_done, evals, n, cond, last, steps, fonly)
        d = np.linalg.solve(J, F)
        have_F = False
        if method == 0:
            x_new, lam = x - d, 1.0
        else:
            if method == 2:
                found, x_new, F_new, J_new, lam, last, best_norm, ev, st, memo = _nleq_step(
                    x, F, J, d, memo, step, ends, accuracy, best_norm, kin, full, last
                )
                fo = 0
            else:
                found, x_new, F_new, J_new, lam, last, best_norm, ev, fo, st = _mnm_step(
                    x, F, J, d, cond, norms, n, root, step.max_halvings, ends, accuracy,
                    best_norm, kin, full, last,
                )  # fmt: skip
            evals += ev
            fonly += fo
            steps += st
            if not found:
                return _out(LINE_SEARCH_FAILED, x, F, it_done, evals, n, cond, last, steps, fonly)
            have_F = True  # the accepted trial passed its test, so its F is finite
            F, J = F_new, J_new
        x = x_new
        lams[it_done] = lam
        it_done += 1
        xx = dot(x, x)
        if not (_finite(xx) and math.sqrt(xx) <= bound):
            if not have_F:
                F = np.full(x.size, np.nan)
            return _out(DIVERGED, x, F, it_done, evals, n, cond, last, steps, fonly)
        if not have_F:
            jac = not (predict and _converges(norms, n, tol))
            before = best_norm
            ok, F, J, last, best_norm, st = _trial(x, ends, accuracy, best_norm, kin, jac)
            evals += 1
            if not jac:
                fonly += 1
            steps += st
            if not jac and not (ok and math.sqrt(dot(F, F)) <= tol):
                # Not converged after all: the next iteration needs J here (same F).
                ok, F, J, last, best_norm, st = _trial(x, ends, accuracy, before, kin, full)
                evals += 1
                steps += st
            if not ok:
                return _out(NON_FINITE_F, x, F, it_done, evals, n, cond, last, steps, fonly)
    return _out(MAX_ITERATIONS, x, F, it_done, evals, n, cond, last, steps, fonly)


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


@njit(cache=True, error_model="numpy", nogil=True)
def sweep_warm(T, X, L0, L1, C, i, method, root, step, accuracy, kin, norms, lams):
    """Junctions ``i, i+1, ..., q-1`` of a Gauss-Seidel sweep over the arcs ``(T, X, L0, L1, C)``
    (updated in place), each from its warm guess ``L0[i-1]`` by :func:`shoot_newton` (the
    shooter's arguments). Returns a SweepOutcome: why and at which junction it stopped, and
    its counts."""
    q = T.size - 1
    A, b, e, e3, order, p, obs, weight, exponent, no_T, no_Z = kin
    rtol, atol, max_steps = accuracy[0], accuracy[1], accuracy[2]
    no_k = np.int64(0)
    iterations = evals = rejected = steps = integrations = jacobians = 0
    while i < q:
        ta, tb = T[i - 1], T[i + 1]
        xa = X[i - 1]
        times = np.empty(2)
        times[0], times[1] = ta, tb
        ends = (xa, X[i + 1], times)
        code, x, _, its, ev, _, _, last, st, jac = shoot_newton(
            ends, L0[i - 1].copy(), method, root, step, accuracy, kin, norms, lams
        )
        if code != CONVERGED:
            return SweepOutcome(
                SWEEP_WARM_FAILED, i, iterations + its, evals + ev, rejected, steps + st,
                integrations + ev, jacobians + jac,
            )  # fmt: skip
        last_s, Y, last_ok = last
        if not (last_ok and (last_s == x).all()):
            return SweepOutcome(
                SWEEP_PYTHON, i, iterations, evals, rejected, steps, integrations, jacobians
            )
        iterations += its
        evals += ev
        steps += st
        integrations += ev
        jacobians += jac
        cost = Y[NZ]
        old = C[i - 1] + C[i]
        if cost > old + 1e-10 * max(1.0, abs(old)):
            rejected += 1
            i += 1
            continue
        # The junction moves to the middle of the local extremal (the flow of leapfrog.sweep).
        tm = 0.5 * (ta + tb)
        Y0 = np.zeros(NZ + 1)
        for m in range(NX):
            Y0[m] = xa[m]
            Y0[NX + m] = x[m]
        # k = 0 as a run-time int64: a literal 0 would compile erk_adaptive a second time.
        H, _, acc, _ = erk_adaptive(
            Y0, ta, tm, no_k, A, b, e, e3, order, rtol, atol, max_steps, p, obs, weight,
            exponent, no_T, no_Z,
        )  # fmt: skip
        steps += acc
        integrations += 1
        T[i] = tm
        for m in range(NX):
            X[i, m] = H[m]
            L0[i - 1, m] = x[m]
            L1[i - 1, m] = H[NX + m]
            L0[i, m] = H[NX + m]
            L1[i, m] = Y[NX + m]
        C[i - 1] = H[NZ]
        C[i] = cost - H[NZ]
        i += 1
    return SweepOutcome(SWEEP_DONE, q, iterations, evals, rejected, steps, integrations, jacobians)
