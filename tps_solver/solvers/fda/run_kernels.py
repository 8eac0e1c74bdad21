r"""Compiled modal coefficients of a run segment (:class:`~tps_solver.solvers.fda.exact.Segment` with run modes).

:func:`run_coefficients` is the loop form of the run path of
:meth:`~tps_solver.solvers.fda.exact.Segment.coefficients`: per mode :math:`k`, with
:math:`z = \lambda_k\tau`,

.. math::
    c_w &= e^{z}(a_k - r_i) + r_i\cos\tau + r_r\sin\tau - (s_k/\Gamma)\,\tau\varphi_1(z), \\
    c_z &= \tau\varphi_1(z)(a_k - r_i) + r_i\sin\tau + r_r(1 - \cos\tau) - (s_k/\Gamma)\,\tau^2\varphi_2(z),

(the closed forms (55)-(56) of :func:`~tps_solver.solvers.fda.exact.forced_response` in real
arithmetic, :math:`r_r + i r_i = s_k e^{it_c}/(i - \lambda_k)`), with :math:`\varphi_2` by its
Taylor series (10 terms, truncation below 1e-18 relative) for :math:`|z| < 0.1`.  Compiled
with numba when the ``fast`` extra is installed (:mod:`tps_solver.core.jit`); the numpy form in
:meth:`~tps_solver.solvers.fda.exact.Segment.coefficients` is the reference (option
``compiled=False`` of :class:`~tps_solver.solvers.fda.exact.ExactPropagator`).

:func:`step_candidates` is one step of the certified contact search of
:meth:`~tps_solver.solvers.fda.exact.ExactPropagator.advance` (the candidates, their safe steps
and bounds) with the tridiagonal operator products done node by node, in the same arithmetic
order as :class:`~tps_solver.solvers.fda.runs.Tridiagonal`.

The rest of an event's hot path, each the loop form of a numpy reference in
:mod:`~tps_solver.solvers.fda.exact` (tested against it in ``tests/test_fda_runs.py``):
:func:`search_start` (free accelerations, round-off levels and the nodes at rest on the plate),
:func:`closed_bounds12`, :func:`closed_bound` and :func:`closed_abs_sum` (the derivative bounds of
closed-form runs, one sum per run since :math:`|V_{jk}| \le 1`), :func:`closed_bracket` (the
certified bracket, the candidate group, the Newton polish and the repair of the order, with the
closed-form rows of :meth:`~tps_solver.solvers.fda.runs.ClosedRun.row` evaluated in place) and
:func:`tri_event_sets` (the contact and lift-off sets (54) of
:func:`~tps_solver.solvers.fda.events.event_sets`).  The run transforms (DST/DCT) stay in scipy.
"""
import math

import numpy as np

from tps_solver.core.jit import kernel

__all__ = ["run_coefficients", "step_candidates", "closed_bounds12", "tri_event_sets", "closed_bracket",
           "closed_abs_sum", "search_start", "closed_bound"]

_PHI2_SERIES = 1.0 / np.array([math.factorial(k + 2) for k in range(10)])


@kernel
def run_coefficients(lam, a_ri, rr, ri, sg, tau, cw, cz):
    """Fill ``cw``, ``cz`` (shape (m,)) with the velocity and displacement coefficients at ``tau``.

    Parameters
    ----------
    lam, a_ri, rr, ri, sg : ndarray of float, shape (m,)
        Eigenvalues, :math:`a - r_i`, :math:`r_r`, :math:`r_i` and :math:`s/\\Gamma` (module docstring).
    tau : float
    cw, cz : ndarray of float, shape (m,)
        Output.

    Examples
    --------
    A zero mode with no forcing keeps its velocity and moves ``a tau``:

    >>> cw, cz = np.empty(1), np.empty(1)
    >>> run_coefficients(np.zeros(1), np.array([2.0]), np.zeros(1), np.zeros(1), np.zeros(1), 0.5, cw, cz)
    >>> cw.tolist(), cz.tolist()
    ([2.0], [1.0])
    """
    c = math.cos(tau)
    sn = math.sin(tau)
    h = math.sin(0.5 * tau)
    omc = 2.0 * h * h
    tt = tau * tau
    series = _PHI2_SERIES
    for k in range(lam.size):
        z = lam[k] * tau
        em1 = math.expm1(z)
        if z != 0.0:
            p1 = em1 / z
        else:
            p1 = 1.0
        if abs(z) < 0.1:
            p2 = series[9]
            for i in range(8, -1, -1):
                p2 = p2 * z + series[i]
        else:
            p2 = (em1 - z) / (z * z)
        tp1 = tau * p1
        cw[k] = (em1 + 1.0) * a_ri[k] + (c * ri[k] + sn * rr[k]) - sg[k] * tp1
        cz[k] = tp1 * a_ri[k] + (sn * ri[k] + omc * rr[k]) - tt * sg[k] * p2


@kernel
def _safe(f, fp, A):
    """:func:`~tps_solver.solvers.fda.exact._safe_step` for one candidate."""
    if f < 0.0:
        f = 0.0
    root = math.sqrt(fp * fp + 2.0 * A * f)
    if fp >= 0.0:
        return (fp + root) / A if A > 0.0 else math.inf
    den = root - fp
    return 2.0 * f / den if den > 0.0 else 0.0


@kernel
def step_candidates(zF, wF, A, B, rel, eps_w, g, dg, F, S, lower, diag, upper, f, fp, Ab, h):
    r"""One search step: candidates ``f``, slopes ``fp``, bounds ``Ab`` and safe steps ``h`` (in place).

    Rows ``0 .. nf - 1`` are the free nodes ``F`` (heights; safe while above the plate or rising),
    rows ``nf ..`` the stuck nodes ``S`` (minus their free accelerations), as in the interpreted
    search of :meth:`~tps_solver.solvers.fda.exact.ExactPropagator.advance`.

    Parameters
    ----------
    zF, wF, A, B, rel : ndarray of float, shape (nf,)
        Heights, velocities, bounds :math:`D_1, D_2` and the release guards (local time left).
    eps_w, g, dg : float
        Velocity round-off, :math:`g(t)` and :math:`\dot g(t)`.
    F, S : ndarray of int64
        Free and stuck nodes.
    lower, diag, upper : ndarray of float, shape (n,)
        The lattice operator's diagonals (:class:`~tps_solver.solvers.fda.runs.Tridiagonal`).
    f, fp, Ab, h : ndarray of float, shape (nf + ns,)
        Output.

    Examples
    --------
    One free node falling onto the plate, no stuck node: safe for ``2 z / (sqrt(w^2 + 2 A z) - w)``:

    >>> F, S = np.array([0]), np.zeros(0, dtype=np.int64)
    >>> f, fp, Ab, h = (np.empty(1) for _ in range(4))
    >>> step_candidates(np.array([1.0]), np.array([-1.0]), np.array([2.0]), np.array([1.0]), np.zeros(1),
    ...                 1e-15, -0.5, 0.0, F, S, np.zeros(1), np.zeros(1), np.zeros(1), f, fp, Ab, h)
    >>> bool(abs(h[0] - 2.0 / (np.sqrt(5.0) + 1.0)) < 1e-15)
    True
    """
    n = lower.size
    nf = F.size
    u = np.zeros(n)
    acc = np.zeros(n)
    Bn = np.zeros(n)
    for j in range(nf):
        u[F[j]] = wF[j]
        Bn[F[j]] = B[j]
    for j in range(nf):
        i = F[j]
        a = diag[i] * u[i]
        if i > 0:
            a += lower[i] * u[i - 1]
        if i < n - 1:
            a += upper[i] * u[i + 1]
        a += g
        acc[i] = a
        w = wF[j]
        hc = _safe(zF[j], w, A[j])
        if w >= -eps_w:
            hr = _safe(w if w > 0.0 else 0.0, a, B[j])
            if hr > hc:
                hc = hr
        if rel[j] > hc:
            hc = rel[j]
        f[j] = zF[j]
        fp[j] = w
        Ab[j] = A[j]
        h[j] = hc
    for k in range(S.size):
        i = S[k]
        a = diag[i] * u[i]
        da = 0.0
        c = 0.0
        if i > 0:
            a += lower[i] * u[i - 1]
            da += lower[i] * acc[i - 1]
            c += abs(lower[i]) * Bn[i - 1]
        if i < n - 1:
            a += upper[i] * u[i + 1]
            da += upper[i] * acc[i + 1]
            c += abs(upper[i]) * Bn[i + 1]
        r = nf + k
        f[r] = -(g + a)
        fp[r] = -(dg + da)
        Ab[r] = 1.0 + c
        h[r] = _safe(f[r], fp[r], Ab[r])


@kernel
def closed_bounds12(abs_lam, abs_a, tau, offsets, f1, f2, A, B):
    r"""The bounds :math:`D_1, D_2` of :meth:`~tps_solver.solvers.fda.exact.Segment.bounds12` (in place),
    every run closed-form (:math:`|V_{jk}| \le 1`: one sum per run).

    Parameters
    ----------
    abs_lam, abs_a : ndarray of float, shape (nf,)
        :math:`|\lambda_k|` and :math:`|a_k|`, runs concatenated.
    tau : float
    offsets : ndarray of int64, shape (n_runs + 1,)
        Run boundaries in the concatenated vectors.
    f1, f2 : ndarray of float, shape (nf,)
        Forcing parts of :math:`D_1, D_2`.
    A, B : ndarray of float, shape (nf,)
        Output.

    Examples
    --------
    One run of two modes:

    >>> A, B = np.empty(2), np.empty(2)
    >>> closed_bounds12(np.array([0.0, 2.0]), np.array([1.0, 1.0]), 0.0, np.array([0, 2]), np.zeros(2),
    ...                 np.ones(2), A, B)
    >>> A.tolist(), B.tolist()
    ([2.0, 2.0], [5.0, 5.0])
    """
    for r in range(offsets.size - 1):
        s1 = 0.0
        s2 = 0.0
        for k in range(offsets[r], offsets[r + 1]):
            lam = abs_lam[k]
            decay = math.exp(-lam * tau) * abs_a[k]
            x = lam * decay
            s1 += x
            s2 += lam * x
        for k in range(offsets[r], offsets[r + 1]):
            A[k] = s1 + f1[k]
            B[k] = s2 + f2[k]


@kernel
def tri_event_sets(g, dg, wF, zF, F, S, lower, diag, upper, time_tol, eps_z, contact, liftoff):
    r""":func:`~tps_solver.solvers.fda.events.event_sets` on a tridiagonal operator, in one pass.

    ``eps_z`` is the height round-off of each free node; the acceleration round-off of a stuck
    node is :math:`64\epsilon(1 + |g| + (|\underline L_{SF}||w_F|)_i)` (as in
    :meth:`~tps_solver.solvers.fda.exact.ExactPropagator.advance`).  Writes the contact nodes to
    ``contact`` and the lift-off nodes to ``liftoff`` and returns their numbers.

    Parameters
    ----------
    g, dg : float
        :math:`g(t)`, :math:`\dot g(t)`.
    wF, zF, eps_z : ndarray of float, shape (nf,)
    F, S : ndarray of int64
        Free and stuck nodes.
    lower, diag, upper : ndarray of float, shape (n,)
    time_tol : float
    contact, liftoff : ndarray of int64, shape (nf,), (ns,)
        Output.

    Returns
    -------
    n_contact, n_liftoff : int

    Examples
    --------
    The example of :func:`~tps_solver.solvers.fda.events.event_sets` (node 0 lands, node 2 lifts off):

    >>> F, S = np.array([0, 1]), np.array([2])
    >>> c, l = np.empty(2, dtype=np.int64), np.empty(1, dtype=np.int64)
    >>> tri_event_sets(0.6, 0.0, np.array([-1.0, 0.5]), np.array([0.0, 1.0]), F, S, np.array([0.0, 1.0, 2.0]),
    ...                np.array([-2.0, -2.0, -2.0]), np.array([2.0, 1.0, 0.0]), 1e-12, np.full(2, 1e-14), c, l)
    (1, 1)
    >>> int(c[0]), int(l[0])
    (0, 2)
    """
    eps64 = 64.0 * 2.220446049250313e-16
    n = lower.size
    nf = F.size
    u = np.zeros(n)
    wmax = 0.0
    for j in range(nf):
        u[F[j]] = wF[j]
        if abs(wF[j]) > wmax:
            wmax = abs(wF[j])
    eps_w = eps64 * (1.0 + wmax)
    acc = np.zeros(n)
    for j in range(nf):
        i = F[j]
        a = diag[i] * u[i]
        if i > 0:
            a += lower[i] * u[i - 1]
        if i < n - 1:
            a += upper[i] * u[i + 1]
        acc[i] = a + g
    nc = 0
    for j in range(nf):
        w = wF[j]
        lim = w * -time_tol
        if eps_z[j] > lim:
            lim = eps_z[j]
        if zF[j] <= lim:
            hit = w < -eps_w
            if not hit and abs(w) <= eps_w:
                i = F[j]
                ea = abs(diag[i]) * abs(u[i])
                if i > 0:
                    ea += abs(lower[i]) * abs(u[i - 1])
                if i < n - 1:
                    ea += abs(upper[i]) * abs(u[i + 1])
                hit = acc[i] < -eps64 * (1.0 + abs(g) + ea)
            if hit:
                contact[nc] = F[j]
                nc += 1
    nl = 0
    for k in range(S.size):
        i = S[k]
        a = diag[i] * u[i]
        da = 0.0
        ea = 0.0
        if i > 0:
            a += lower[i] * u[i - 1]
            da += lower[i] * acc[i - 1]
            ea += abs(lower[i]) * abs(u[i - 1])
        if i < n - 1:
            a += upper[i] * u[i + 1]
            da += upper[i] * acc[i + 1]
            ea += abs(upper[i]) * abs(u[i + 1])
        accS = g + a
        daccS = dg + da
        eps_a = eps64 * (1.0 + abs(g) + ea)
        near = time_tol * daccS if daccS > 0.0 else 0.0
        if eps_a > near:
            near = eps_a
        if accS > eps_a or (accS >= -near and daccS > 0.0):
            liftoff[nl] = i
            nl += 1
    return nc, nl


@kernel
def _row_dot(theta, code, m, j, o, cw, cz):
    """``(row . cz, row . cw)`` for local node ``j`` of a closed run (modes ``o .. o + m - 1``)."""
    vz = 0.0
    vw = 0.0
    for k in range(m):
        if code == 0:
            r = math.sin(theta[o + k] * (j + 1))
        elif code == 2:
            r = math.cos(theta[o + k] * (m - 1 - j))
        else:
            r = math.cos(theta[o + k] * j)
        vz += r * cz[k]
        vw += r * cw[k]
    return vz, vw


@kernel
def _free_value(seg, theta, code, offsets, j, tau):
    """``(zeta_j, w_j)`` of free row ``j`` at local time ``tau`` (see :func:`closed_bracket`)."""
    lam, a_ri, rr, ri, sg, zeta0 = seg
    r = np.searchsorted(offsets, j, side="right") - 1
    o = offsets[r]
    m = offsets[r + 1] - o
    cw = np.empty(m)
    cz = np.empty(m)
    run_coefficients(lam[o:o + m], a_ri[o:o + m], rr[o:o + m], ri[o:o + m], sg[o:o + m], tau, cw, cz)
    vz, vw = _row_dot(theta, code[r], m, j - o, o, cw, cz)
    return zeta0[j] + vz, vw


@kernel
def _value_slope(seg, theta, code, offsets, row_of, S, lower, diag, upper, t_c, Gamma, nf, j, tau):
    """``(f_j, f_j')``: height and velocity of a free row, minus the free acceleration and its rate of a stuck row."""
    if j < nf:
        return _free_value(seg, theta, code, offsets, j, tau)
    t = t_c + tau
    g = math.sin(t) - 1.0 / Gamma
    n = lower.size
    node = S[j - nf]
    lo = max(node - 2, 0)
    hi = min(node + 3, n)
    w = np.zeros(5)
    isfree = np.zeros(5, dtype=np.bool_)
    for k in range(lo, hi):
        if row_of[k] >= 0:
            w[k - lo] = _free_value(seg, theta, code, offsets, row_of[k], tau)[1]
            isfree[k - lo] = True
    f = g
    fp = math.cos(t)
    for side in range(2):
        k = node - 1 + 2 * side
        c = lower[node] if side == 0 else upper[node]
        if k < lo or k >= hi or not isfree[k - lo]:
            continue
        f += c * w[k - lo]
        acc = g + diag[k] * w[k - lo]
        if k - 1 >= lo and isfree[k - 1 - lo]:
            acc += lower[k] * w[k - 1 - lo]
        if k + 1 < hi and isfree[k + 1 - lo]:
            acc += upper[k] * w[k + 1 - lo]
        fp += c * acc
    return -f, -fp


@kernel
def _newton_root(seg, theta, code, offsets, row_of, S, lower, diag, upper, t_c, Gamma, nf, j, lo, hi,
                 f_lo, fp_lo, A):
    """:meth:`~tps_solver.solvers.fda.exact.ExactPropagator.advance`'s Newton polish in its bracket."""
    eps = 2.220446049250313e-16
    if f_lo <= 0.0:
        return lo
    x, f, fp = lo, f_lo, fp_lo
    for _ in range(200):
        if fp < 0.0:
            step = f / fp
            x_new = x - step
            if lo < x_new < hi and A * step * step <= -1e-16 * fp:
                return x_new
        else:
            x_new = 0.5 * (lo + hi)
        if not lo < x_new < hi:
            x_new = 0.5 * (lo + hi)
        if abs(x_new - x) <= 1e-15 + 4 * eps * abs(x_new) or hi - lo <= 1e-15 + 4 * eps * abs(hi):
            return x_new
        x = x_new
        f, fp = _value_slope(seg, theta, code, offsets, row_of, S, lower, diag, upper, t_c, Gamma, nf, j, x)
        if f == 0.0:
            return x
        if f > 0.0:
            lo = x
        else:
            hi = x
    return x


@kernel
def closed_bracket(f, fp, A, h, tau, time_tol, seg, theta, code, offsets, row_of, S, lower, diag, upper,
                   t_c, Gamma, nf):
    r"""The certified bracket, the root polish and the order repair of the search, every run closed-form.

    The compiled form of ``_bracket`` of :class:`~tps_solver.solvers.fda.exact.ExactPropagator`
    with run modes: the monotone brackets :math:`u = 2f/(|f'| + \sqrt{f'^2 - 2Af})` of the
    candidates with :math:`f'^2 \ge 2.5Af`, the closed candidate group
    (:func:`~tps_solver.solvers.fda.exact.candidate_group`), Newton's method from the earliest
    estimate and the repair of the order; candidate values from the closed-form rows
    (:meth:`~tps_solver.solvers.fda.runs.ClosedRun.row`) and the modal coefficients of
    :func:`run_coefficients`.

    Parameters
    ----------
    f, fp, A, h : ndarray of float, shape (nf + ns,)
        Candidates, slopes, bounds and safe steps of the search step (:func:`step_candidates`).
    tau, time_tol : float
        Local time of the step; simultaneity window.
    seg : tuple of ndarray of float, shape (nf,)
        ``(lam, a - r_i, r_r, r_i, s/Gamma, zeta0)`` of the segment (:func:`run_coefficients`).
    theta : ndarray of float, shape (nf,)
        Mode angles of the runs, concatenated.
    code : ndarray of int64, shape (n_runs,)
        End types (0 DD, 1 ND, 2 DN, 3 NN).
    offsets : ndarray of int64, shape (n_runs + 1,)
    row_of : ndarray of int64, shape (n,)
        Free row of each node, -1 for a stuck node.
    S : ndarray of int64, shape (ns,)
    lower, diag, upper : ndarray of float, shape (n,)
    t_c, Gamma : float
        Segment start and plate acceleration.
    nf : int

    Returns
    -------
    tau_c : float
        The event's local time, or -1.0 if a member of the group has no certified bracket
        (the caller then takes a smaller step).
    group : ndarray of int64
        The candidate group.
    """
    eps = 2.220446049250313e-16
    N = f.size
    fpos = np.maximum(f, 0.0)
    upper_b = np.empty(N)
    ok = np.empty(N, dtype=np.bool_)
    for i in range(N):
        ok[i] = fp[i] < 0.0 and fp[i] * fp[i] >= 2.5 * A[i] * fpos[i]
        if ok[i]:
            disc = fp[i] * fp[i] - 2.0 * A[i] * fpos[i]
            upper_b[i] = 2.0 * fpos[i] / (-fp[i] + math.sqrt(max(disc, 0.0)))
        else:
            upper_b[i] = math.inf
    m = int(np.argmin(h))
    span = upper_b[m]
    while True:
        group = np.flatnonzero(h < span)
        if group.size == 0:
            group = np.array([m], dtype=np.int64)
        for i in group:
            if not ok[i]:
                return -1.0, group
        new_span = upper_b[group].max()
        if new_span <= span:
            break
        span = new_span
    best = math.inf
    lead = group[0]
    for i in group:
        est = fpos[i] / -fp[i]
        if est < best:
            best = est
            lead = i
    tau_hi = tau + upper_b[lead]
    tau_c = _newton_root(seg, theta, code, offsets, row_of, S, lower, diag, upper, t_c, Gamma, nf, lead,
                         tau, tau_hi, f[lead], fp[lead], A[lead])
    repeats = group.size if group.size > 1 else 0
    for _ in range(repeats):
        any_early = False
        best = math.inf
        j = group[0]
        for i in group:
            val = _value_slope(seg, theta, code, offsets, row_of, S, lower, diag, upper, t_c, Gamma, nf, i,
                               tau_c)[0]
            if val < -time_tol * abs(fp[i]) - 64 * eps:
                any_early = True
            r = val / -fp[i]
            if r < best:
                best = r
                j = i
        if not any_early:
            break
        tau_c = _newton_root(seg, theta, code, offsets, row_of, S, lower, diag, upper, t_c, Gamma, nf, j,
                             tau, tau_c, f[j], fp[j], A[j])
    return tau_c, group


@kernel
def closed_abs_sum(x, offsets, out):
    r"""``out`` = the bound :math:`\sum_k x_k` over each closed-form run, broadcast to its rows (of ``|V| x``).

    Examples
    --------
    >>> out = np.empty(3)
    >>> closed_abs_sum(np.array([1.0, 2.0, 4.0]), np.array([0, 2, 3]), out)
    >>> out.tolist()
    [3.0, 3.0, 4.0]
    """
    for r in range(offsets.size - 1):
        s = 0.0
        for k in range(offsets[r], offsets[r + 1]):
            s += x[k]
        for k in range(offsets[r], offsets[r + 1]):
            out[k] = s


@kernel
def search_start(wF, zF, F, lower, diag, upper, g, dg, accF, jerk, eps_a, at_plate):
    r"""The start of a contact search: free accelerations, round-off levels and the nodes at rest on the plate.

    Fills ``accF`` (:math:`\underline L_{FF}w_F + g`) and ``at_plate`` (:math:`\zeta = 0`,
    :math:`|w| \le \epsilon_w`); for the nodes at the plate also ``jerk``
    (:math:`\underline L_{FF}a_F + \dot g`) and ``eps_a``
    (:math:`64\epsilon(1 + |g| + (|\underline L_{FF}||w_F|)_j)`).

    Returns
    -------
    eps_w, eps_z : float
        :math:`64\epsilon(1 + \max|w|)` and :math:`64\epsilon(1 + \max|\zeta| + \max|w|)`.
    n_at_plate : int

    Examples
    --------
    Two free nodes at rest on the plate under g = -0.4:

    >>> F = np.array([0, 1])
    >>> acc, jerk, ea, at = np.empty(2), np.empty(2), np.empty(2), np.empty(2, dtype=np.bool_)
    >>> eps_w, eps_z, k = search_start(np.zeros(2), np.zeros(2), F, np.array([0.0, 2.0]), np.array([-2.0, -2.0]),
    ...                                np.array([2.0, 0.0]), -0.4, 1.0, acc, jerk, ea, at)
    >>> k, acc.tolist(), jerk.tolist()
    (2, [-0.4, -0.4], [1.0, 1.0])
    """
    eps64 = 64.0 * 2.220446049250313e-16
    n = lower.size
    nf = F.size
    u = np.zeros(n)
    wmax = 0.0
    zmax = 0.0
    for j in range(nf):
        u[F[j]] = wF[j]
        if abs(wF[j]) > wmax:
            wmax = abs(wF[j])
        if abs(zF[j]) > zmax:
            zmax = abs(zF[j])
    eps_w = eps64 * (1.0 + wmax)
    eps_z = eps64 * (1.0 + zmax + wmax)
    acc = np.zeros(n)
    for j in range(nf):
        i = F[j]
        a = diag[i] * u[i]
        if i > 0:
            a += lower[i] * u[i - 1]
        if i < n - 1:
            a += upper[i] * u[i + 1]
        acc[i] = a + g
        accF[j] = a + g
    count = 0
    for j in range(nf):
        at_plate[j] = zF[j] == 0.0 and abs(wF[j]) <= eps_w
        if not at_plate[j]:
            continue
        count += 1
        i = F[j]
        b = diag[i] * acc[i]
        e = abs(diag[i]) * abs(u[i])
        if i > 0:
            b += lower[i] * acc[i - 1]
            e += abs(lower[i]) * abs(u[i - 1])
        if i < n - 1:
            b += upper[i] * acc[i + 1]
            e += abs(upper[i]) * abs(u[i + 1])
        jerk[j] = b + dg
        eps_a[j] = eps64 * (1.0 + abs(g) + e)
    return eps_w, eps_z, count


@kernel
def closed_bound(abs_lam, abs_a, tau, p, offsets, forcing, out):
    r"""The bound :math:`D_p` of :meth:`~tps_solver.solvers.fda.exact.Segment.derivative_bound` (in place),
    every run closed-form: :math:`\sum_k|\lambda_k|^p e^{-|\lambda_k|\tau}|a_k|` over each run plus ``forcing``.

    Examples
    --------
    >>> out = np.empty(2)
    >>> closed_bound(np.array([0.0, 2.0]), np.ones(2), 0.0, 3, np.array([0, 2]), np.ones(2), out)
    >>> out.tolist()
    [9.0, 9.0]
    """
    for r in range(offsets.size - 1):
        s = 0.0
        for k in range(offsets[r], offsets[r + 1]):
            lam = abs_lam[k]
            s += lam ** p * (math.exp(-lam * tau) * abs_a[k])
        for k in range(offsets[r], offsets[r + 1]):
            out[k] = s + forcing[k]


@kernel
def tri_pulled_off(g, w, stuck, lower, diag, upper, out):
    r""":func:`~tps_solver.solvers.fda.events.pulled_off` on a tridiagonal operator: writes the stuck nodes
    whose free acceleration :math:`g + (\underline L w)_i` exceeds :math:`64\epsilon(1 + |g| + (|\underline L||w|)_i)`
    to ``out`` and returns their number.

    Examples
    --------
    >>> out = np.empty(3, dtype=np.int64)
    >>> tri_pulled_off(-0.4, np.array([1.0, 0.0, 0.0]), np.array([False, True, False]), np.array([0.0, 1.0, 2.0]),
    ...                np.array([-2.0, -2.0, -2.0]), np.array([2.0, 1.0, 0.0]), out), int(out[0])
    (1, 1)
    """
    eps64 = 64.0 * 2.220446049250313e-16
    n = w.size
    k = 0
    for i in range(n):
        if not stuck[i]:
            continue
        a = diag[i] * w[i]
        e = abs(diag[i]) * abs(w[i])
        if i > 0:
            a += lower[i] * w[i - 1]
            e += abs(lower[i]) * abs(w[i - 1])
        if i < n - 1:
            a += upper[i] * w[i + 1]
            e += abs(upper[i]) * abs(w[i + 1])
        if g + a > eps64 * (1.0 + abs(g) + e):
            out[k] = i
            k += 1
    return k
