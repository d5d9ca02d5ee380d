# Explicit Runge-Kutta flow of the canonical system with its variational equations.
#
# This file is a template, not an importable module: leapfrog_planner.compiled.codegen appends it
# to the code generated for each vehicle model, which defines NX, NZ, FASTMATH, INLINE, the status
# codes (OK, NON_FINITE, ...: compiled/status.py), model_augmented, controls, hamiltonian_model,
# dH_du and linearize. What it takes from the package it imports below, so that the kernels'
# cache key (compiled/cache_key.py) finds it. Keeping the integrator in the same module as the
# model lets numba inline and cache everything (functions passed as arguments would not be cached
# on disk).
#
# The augmented state is Y = [z (NZ), cost (1), S (NZ x k, row-major)], with z = (x, lambda),
# S = dz/d(seed) and k sensitivity columns (k = 0: flow only). A method is just its tableau
# (A, b, c, and for embedded pairs the error weights e, e3 over s + 1 stages, the last being
# f(y_new)); the step-size controller follows Hairer, Norsett and Wanner (and SciPy's solve_ivp).
# The kernels take the records of compiled/abi.py: the equation's data, the method's tableau
# (together a Dynamics), the controller's tolerances (StepControl) and where to record (Samples).
# Each kernel unpacks them once, before its step loop, and hands the fields to the functions
# called per step or per stage (aug_rhs, _rk_step, _error_norm): numba counts a reference for
# each array read from a record, and such reads inside the loop made the flow 4 to 10% slower
# than with the old plain arguments (paper cases 4 and 1, measured), 0 to 2% unpacked once.

import math

import numpy as np
from numba import njit

from leapfrog_planner.model.penalty import has_penalty, penalty_at


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline=INLINE)
def aug_rhs(Y, k, p, obs, weight, exponent, out):
    """Right-hand side of the augmented system: canonical system, cost rate, sensitivities."""
    base = NZ + 1
    model_augmented(Y, p, Y[base:], k, out)
    if not has_penalty(obs):
        return
    P, Px, Py, Pxx, Pxy, Pyy = penalty_at(Y[0], Y[1], obs, weight, exponent, k > 0)
    out[NX] -= Px
    out[NX + 1] -= Py
    out[NZ] += P
    if k > 0:
        rx = base + NX * k
        ry = base + (NX + 1) * k
        for c in range(k):
            s0 = Y[base + c]
            s1 = Y[base + k + c]
            out[rx + c] -= Pxx * s0 + Pxy * s1
            out[ry + c] -= Pxy * s0 + Pyy * s1


@njit(cache=True, error_model="numpy", fastmath=FASTMATH)
def aug_rhs_once(Y, k, p, obs, weight, exponent, out):
    """:func:`aug_rhs` called, not inlined, for the evaluations made once per integration (the
    first derivative, the starting step's trial): each inlined copy of the model cost seconds
    of a fresh machine's first compile, and a call gives the same bits (no fast math)."""
    aug_rhs(Y, k, p, obs, weight, exponent, out)


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline=INLINE)
def _stage_states(Y, K, A, i, h, Yt):
    n = Y.size
    for m in range(n):
        Yt[m] = Y[m]
    for j in range(i):
        a = h * A[i, j]
        if a != 0.0:
            for m in range(n):
                Yt[m] += a * K[j, m]


# Finiteness is tested on the bits (exponent all ones = inf or NaN): under fast math LLVM may
# assume that no float is NaN or inf and fold a floating-point test away, even after inlining.
_EXP_MASK = np.int64(0x7FF0000000000000)


@njit(cache=True, error_model="numpy", inline=INLINE)
def _all_finite(Y, n):
    bits = Y.view(np.int64)
    for m in range(n):
        if (bits[m] & _EXP_MASK) == _EXP_MASK:
            return False
    return True


@njit(cache=True, error_model="numpy", inline=INLINE)
def _finite(x):
    box = np.empty(1)
    box[0] = x
    return _all_finite(box, 1)


# The entry points release the GIL, so that threads (one per initial path) integrate in parallel.
@njit(cache=True, error_model="numpy", inline=INLINE)
def _record(Z_out, row, Y):
    """``(z, cost)`` of ``Y`` into row ``row`` of the samples, element by element: a slice
    assignment has its shapes checked, and compiling that check's error message (numba's
    string formatting) cost seconds of a fresh machine's first plan."""
    for m in range(NZ + 1):
        Z_out[row, m] = Y[m]


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, nogil=True)
def erk_fixed(Y0, t0, t1, k, dynamics, nsteps, samples):
    """``nsteps`` equal steps; returns (Y1, status, steps, 0 rejected). Records (t, z, cost) in
    ``samples`` if they have room."""
    A, b = dynamics.tableau.A, dynamics.tableau.b
    p, obs, weight, exponent = dynamics.equation
    T_out, Z_out = samples
    n = Y0.size
    s = b.size
    K = np.empty((s, n))
    Y = Y0.copy()
    Yt = np.empty(n)
    h = (t1 - t0) / nsteps
    record = T_out.size > nsteps
    if record:
        T_out[0] = t0
        _record(Z_out, 0, Y)
    for step in range(nsteps):
        for i in range(s):
            _stage_states(Y, K, A, i, h, Yt)
            aug_rhs(Yt, k, p, obs, weight, exponent, K[i])
        for i in range(s):
            w = h * b[i]
            if w != 0.0:
                for m in range(n):
                    Y[m] += w * K[i, m]
        if not _all_finite(Y, n):  # sensitivities too: a NaN Jacobian is a failure
            return Y, NON_FINITE, step + 1, 0
        if record:
            T_out[step + 1] = t0 + (step + 1) * h
            _record(Z_out, step + 1, Y)
    return Y, OK, nsteps, 0


@njit(cache=True, error_model="numpy")
def _error_norm(K, h, e, e3, rtol, atol, Y, Ynew):
    """Hairer's RMS error norm on (z, cost); DOP853's 5th/3rd order blend if the tableau has e3."""
    n_err = NZ + 1
    s1 = K.shape[0]
    err5 = 0.0
    err3 = 0.0
    use3 = e3.size > 0
    for m in range(n_err):
        scale = atol + rtol * max(abs(Y[m]), abs(Ynew[m]))
        a = 0.0
        b3 = 0.0
        for i in range(s1):
            a += e[i] * K[i, m]
            if use3:
                b3 += e3[i] * K[i, m]
        err5 += (a / scale) ** 2
        err3 += (b3 / scale) ** 2
    if not use3:
        return abs(h) * math.sqrt(err5 / n_err)
    if err5 == 0.0 and err3 == 0.0:
        return 0.0
    return abs(h) * err5 / math.sqrt((err5 + 0.01 * err3) * n_err)


@njit(cache=True, error_model="numpy")
def _initial_step(Y, f0, t0, t1, k, dynamics, control):
    """Hairer's starting step size (as in SciPy's select_initial_step)."""
    order = dynamics.tableau.error_order
    rtol, atol = control.rtol, control.atol
    n_err = NZ + 1
    direction = 1.0 if t1 >= t0 else -1.0
    n = Y.size
    d0 = 0.0
    d1 = 0.0
    for m in range(n_err):
        scale = atol + abs(Y[m]) * rtol
        d0 += (Y[m] / scale) ** 2
        d1 += (f0[m] / scale) ** 2
    d0 = math.sqrt(d0 / n_err)
    d1 = math.sqrt(d1 / n_err)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, abs(t1 - t0))
    Y1 = np.empty(n)
    for m in range(n):
        Y1[m] = Y[m] + direction * h0 * f0[m]
    f1 = np.empty(n)
    p, obs, weight, exponent = dynamics.equation
    aug_rhs_once(Y1, k, p, obs, weight, exponent, f1)
    d2 = 0.0
    for m in range(n_err):
        scale = atol + abs(Y[m]) * rtol
        d2 += ((f1[m] - f0[m]) / scale) ** 2
    d2 = math.sqrt(d2 / n_err) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1, abs(t1 - t0))


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline=INLINE)
def _rk_step(Y, K, hs, k, A, b, p, obs, weight, exponent, Yt, Ynew):
    """One explicit Runge-Kutta step of size ``hs`` from ``Y`` (whose derivative is ``K[0]``):
    the stages into ``K[1:s]``, the new state into ``Ynew`` and its derivative into ``K[s]``."""
    n = Y.size
    s = b.size
    for i in range(1, s):
        _stage_states(Y, K, A, i, hs, Yt)
        aug_rhs(Yt, k, p, obs, weight, exponent, K[i])
    for m in range(n):
        Ynew[m] = Y[m]
    for i in range(s):
        w = hs * b[i]
        if w != 0.0:
            for m in range(n):
                Ynew[m] += w * K[i, m]
    aug_rhs(Ynew, k, p, obs, weight, exponent, K[s])


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, nogil=True)
def erk_adaptive(Y0, t0, t1, k, dynamics, control, samples):
    """Embedded pair with error control on (z, cost). Returns (Y1, status, accepted, rejected).

    The sensitivities ride along on the accepted steps: the Jacobian returned is then the exact
    derivative of the discrete flow for that step sequence ("internal differentiation").
    """
    A, b, e, e3, error_order = dynamics.tableau
    p, obs, weight, exponent = dynamics.equation
    rtol, atol, max_steps = control
    T_out, Z_out = samples
    n = Y0.size
    s = b.size
    K = np.empty((s + 1, n))
    Y = Y0.copy()
    Ynew = np.empty(n)
    Yt = np.empty(n)
    record = T_out.size > 0
    if record:
        T_out[0] = t0
        _record(Z_out, 0, Y)
    aug_rhs_once(Y, k, p, obs, weight, exponent, K[0])
    if not (_all_finite(Y, n) and _all_finite(K[0], n)):
        return Y, NON_FINITE, 0, 0
    direction = 1.0 if t1 >= t0 else -1.0
    h = _initial_step(Y, K[0], t0, t1, k, dynamics, control)
    expo = -1.0 / (error_order + 1.0)
    t = t0
    accepted = 0
    rejected = 0
    while direction * (t1 - t) > 0.0:
        if accepted >= max_steps or (record and accepted + 1 >= T_out.size):
            return Y, MAX_STEPS, accepted, rejected
        min_step = 10.0 * abs(np.nextafter(t, direction * np.inf) - t)
        h = min(h, abs(t1 - t))
        step_rejected = False
        while True:
            if h < min_step:
                return Y, STEP_TOO_SMALL, accepted, rejected
            hs = h * direction
            _rk_step(Y, K, hs, k, A, b, p, obs, weight, exponent, Yt, Ynew)
            err = _error_norm(K, hs, e, e3, rtol, atol, Y, Ynew)
            if not _finite(err):
                # A blow-up inside the step: shrink hard and retry, as for a large error.
                h *= 0.2
                rejected += 1
                step_rejected = True
                continue
            if err < 1.0:
                if err == 0.0:
                    factor = 10.0
                else:
                    factor = min(10.0, 0.9 * err**expo)
                if step_rejected:
                    factor = min(1.0, factor)
                t_new = t + hs
                if direction * (t_new - t1) > -min_step:
                    t_new = t1
                t = t_new
                h *= factor
                break
            h *= max(0.2, 0.9 * err**expo)
            rejected += 1
            step_rejected = True
        for m in range(n):
            Y[m] = Ynew[m]
            K[0, m] = K[s, m]
        accepted += 1
        if not _all_finite(Y, n):  # sensitivities too: a NaN Jacobian is a failure
            return Y, NON_FINITE, accepted, rejected
        if record:
            T_out[accepted] = t
            _record(Z_out, accepted, Y)
    return Y, OK, accepted, rejected


@njit(cache=True, error_model="numpy")
def along_path(Z, equation, U, H, dHdu):
    """Controls, Hamiltonian and dH/du (at the computed controls) at each row of Z = (x, lambda)."""
    p, obs, weight, exponent = equation
    for r in range(Z.shape[0]):
        z = Z[r, :NZ]
        controls(z, p, U[r])
        P, Px, Py, Pxx, Pxy, Pyy = penalty_at(z[0], z[1], obs, weight, exponent, False)
        H[r] = hamiltonian_model(z, p) + P
        dH_du(z, U[r], p, dHdu[r])


@njit(cache=True, error_model="numpy")
def linearize_rows(X, u, p, f, A, B, R):
    """``linearize`` at each row of ``X`` (controls ``u``), into row-indexed outputs: one call
    for the whole path (path_ranking evaluates hundreds of points per candidate path)."""
    for r in range(X.shape[0]):
        linearize(X[r], u, p, f[r], A[r], B[r], R[r])


@njit(cache=True, error_model="numpy")
def rhs_along(Z, p, obs, weight, exponent, dZ):
    """Time derivative of (z, cost) at each row of Z, for Hermite interpolation between steps.
    The equation's data come unpacked: SciPy's solvers call it as their right-hand side
    (experiments/peers.py), where typing a record would cost more than the call."""
    for r in range(Z.shape[0]):
        aug_rhs(Z[r], 0, p, obs, weight, exponent, dZ[r])


@njit(cache=True, error_model="numpy")
def hermite_dense(T, Z, dZ, t, out):
    """Cubic Hermite interpolation between steps: rows ``Z`` with derivatives ``dZ`` at ``T``,
    sampled at ``t`` (monotone in the same direction as ``T``). Part of the integrator's dense
    output, compiled with it; the tests compare it with SciPy's CubicHermiteSpline."""
    n = T.size
    forward = T[n - 1] >= T[0]
    j = 0
    for i in range(t.size):
        ti = t[i]
        if forward:
            while j < n - 2 and ti > T[j + 1]:
                j += 1
        else:
            while j < n - 2 and ti < T[j + 1]:
                j += 1
        h = T[j + 1] - T[j]
        s = (ti - T[j]) / h
        s1 = 1.0 - s
        h00 = (1.0 + 2.0 * s) * s1 * s1
        h10 = s * s1 * s1 * h
        h01 = s * s * (3.0 - 2.0 * s)
        h11 = s * s * (s - 1.0) * h
        for c in range(Z.shape[1]):
            out[i, c] = h00 * Z[j, c] + h10 * dZ[j, c] + h01 * Z[j + 1, c] + h11 * dZ[j + 1, c]
