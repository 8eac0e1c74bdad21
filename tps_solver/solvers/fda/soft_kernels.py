r"""The step loop of :class:`~tps_solver.solvers.fda.soft.SoftIntegrator` as compiled kernels.

The numpy path of :class:`~tps_solver.solvers.fda.soft.SoftIntegrator` spends most of a step in
numpy call overhead (a step is a few dozen calls on arrays of a few hundred numbers).  These
kernels do the same arithmetic in loops:

* :func:`radau_step` -- one Radau IIA step of the piecewise-linear soft system (eqs. (51)-(52)
  with the contact force of (A.1)): the stage right-hand sides, the :math:`\lceil s/2\rceil`
  tridiagonal stage systems (solved by :func:`tridiagonal_solve`, Gaussian elimination with
  partial pivoting as LAPACK ``zgtsv`` does it), the end point and, on request, the stage values
  and :math:`\zeta` on the scan grid;
* :func:`march` -- the step-doubling loop of :meth:`SoftIntegrator.advance` up to a target time
  or to the first accepted step whose scan grid shows a crossing, with the crossing nodes, their
  polished guesses (Newton on the collocation polynomial) and brackets;
* :func:`locate` -- the safeguarded Newton iteration in the step size of
  :meth:`SoftIntegrator._locate`;
* :func:`configure`, :func:`violation`, :func:`simultaneous` -- the constants of a contact
  configuration, the violations of all nodes and the nodes switching together.

The rules (error control, scan, sliver of nodes moving away, polish) are those of the numpy path,
step by step; only the order of floating-point operations differs (sums in loops instead of BLAS
products, a reciprocal instead of a complex division in the tridiagonal solve), so the two paths agree
to rounding (event times to 1e-12 where the dynamics does not amplify rounding: tests/test_soft_kernels.py).
The event bookkeeping (the sticking rule, event records, the event bound) stays in
:mod:`~tps_solver.solvers.fda.soft`.

Compiled with numba when the ``fast`` extra is installed (:mod:`tps_solver.core.jit`); the
integrator uses them by default then (option ``compiled``).
"""
import math

import numpy as np

from tps_solver.core.jit import kernel

__all__ = ["tridiagonal_solve", "start_rhs", "radau_step", "radau_pair", "march", "locate", "violation",
           "simultaneous", "configure", "rhs", "initial_mode", "march_packed", "locate_packed",
           "violation_packed", "simultaneous_packed", "rhs_packed",
           "REACHED", "CROSSING", "NONFINITE", "UNDERFLOW", "SINGULAR", "UNVERIFIED", "STALLED"]

#: Status codes of :func:`march` and :func:`locate`.
REACHED, CROSSING, NONFINITE, UNDERFLOW, SINGULAR, UNVERIFIED, STALLED = 0, 1, 2, 3, 4, 5, 6


@kernel
def _cabs1(x):
    return abs(x.real) + abs(x.imag)


@kernel
def _inv(x):
    """1 / x for a nonzero complex x by one real division (no branches; |x| is far from overflow here)."""
    r = 1.0 / (x.real * x.real + x.imag * x.imag)
    return complex(x.real * r, -x.imag * r)


@kernel
def tridiagonal_solve(dl, d, du, b):
    r"""Solve ``m`` complex tridiagonal systems in place (partial pivoting, the algorithm of ``zgtsv``).

    The systems are eliminated together, row by row, so that their dependency chains overlap.

    Parameters
    ----------
    dl, du : ndarray of complex, shape (m, n - 1)
        Sub- and super-diagonals (overwritten).
    d : ndarray of complex, shape (m, n)
        Diagonals (overwritten).
    b : ndarray of complex, shape (m, n)
        Right-hand sides, overwritten by the solutions.

    Returns
    -------
    bool
        False if a matrix is singular (a zero pivot).

    Examples
    --------
    >>> dl, du = np.array([[1.0 + 0j, 1.0]]), np.array([[2.0 + 0j, 2.0]])
    >>> d, b = np.array([[4.0 + 0j, 4.0, 4.0]]), np.array([[6.0 + 0j, 7.0, 5.0]])
    >>> tridiagonal_solve(dl, d, du, b), np.round(b.real, 12).tolist()
    (True, [[1.0, 1.0, 1.0]])
    """
    m, n = d.shape
    rp = np.empty((m, n), np.complex128)            # reciprocals of the pivots (reused going back)
    for i in range(n - 1):
        for k in range(m):
            if _cabs1(d[k, i]) >= _cabs1(dl[k, i]):          # no row interchange
                if d[k, i] == 0.0:
                    return False
                r = _inv(d[k, i])
                rp[k, i] = r
                fact = dl[k, i] * r
                d[k, i + 1] -= fact * du[k, i]
                b[k, i + 1] -= fact * b[k, i]
                dl[k, i] = 0.0                       # dl now holds the second super-diagonal
            else:                                    # interchange rows i and i + 1
                r = _inv(dl[k, i])
                rp[k, i] = r
                fact = d[k, i] * r
                d[k, i] = dl[k, i]
                temp = d[k, i + 1]
                d[k, i + 1] = du[k, i] - fact * temp
                if i < n - 2:
                    dl[k, i] = du[k, i + 1]
                    du[k, i + 1] = -fact * dl[k, i]
                else:
                    dl[k, i] = 0.0
                du[k, i] = temp
                temp = b[k, i]
                b[k, i] = b[k, i + 1]
                b[k, i + 1] = temp - fact * b[k, i + 1]
    for k in range(m):
        if d[k, n - 1] == 0.0:
            return False
        b[k, n - 1] *= _inv(d[k, n - 1])
        if n > 1:
            b[k, n - 2] = (b[k, n - 2] - du[k, n - 2] * b[k, n - 1]) * rp[k, n - 2]
    for i in range(n - 3, -1, -1):
        for k in range(m):
            b[k, i] = (b[k, i] - du[k, i] * b[k, i + 1] - dl[k, i] * b[k, i + 2]) * rp[k, i]
    return True


@kernel
def start_rhs(w0, z0, dw, om2c, Ll, Lu, aw):
    """:meth:`SoftIntegrator._start`, w-rows: ``aw = A_C y0`` (the state part of the stage right-hand sides)."""
    n = w0.size
    for i in range(n):
        a = dw[i] * w0[i] - om2c[i] * z0[i]
        if i > 0:
            a += Ll[i - 1] * w0[i - 1]
        if i < n - 1:
            a += Lu[i] * w0[i + 1]
        aw[i] = a


@kernel
def radau_step(t0, h, w0, z0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, Trep, c, cT, dense,
               stages, w1, z1, Yw, Yz, Zg):
    r"""One ``s``-stage Radau IIA step of size ``h`` from ``(t0, w0, z0)`` (:meth:`SoftIntegrator._steps`).

    Parameters
    ----------
    t0, h : float
    w0, z0 : ndarray of float, shape (n,)
    aw : ndarray of float, shape (n,)
        :func:`start_rhs` of ``(w0, z0)``.
    dw, om2c, f : ndarray of float, shape (n,)
        Configuration: diagonal of the w-row on w, :math:`\omega_0^2 c`, free indicator.
    Ll, Lu : ndarray of float, shape (n - 1,)
        Off-diagonals of the operator with the held rows dropped.
    inv_gamma : float
        :math:`1/\Gamma`.
    lam, q : ndarray of complex, shape (m,)
        Eigenvalues of the Butcher matrix (one per conjugate pair) and :math:`T^{-1}1`.
    Tinv : ndarray of complex, shape (m, s)
    Trep : ndarray of complex, shape (s, m)
        Rows of :math:`T^{-1}` and columns of :math:`T` (doubled for a pair).
    c, cT : ndarray of float, shape (s,)
        Radau nodes (twice: ``cT`` is :math:`T\,\mathrm{diag}(\lambda)T^{-1}1`, equal to ``c`` to rounding).
    dense : ndarray of float, shape (G, s + 1)
        Lagrange basis on (0, c) at the scan grid.
    stages : bool
        Also fill ``Yw``, ``Yz`` (s, n) and ``Zg`` (G, n).
    w1, z1 : ndarray of float, shape (n,)
        Output: the end point.

    Returns
    -------
    bool
        False if a stage system is singular.
    """
    n = w0.size
    m = lam.size
    Z = np.empty((m, n), np.complex128)
    d = np.empty((m, n), np.complex128)
    dl = np.empty((m, max(n - 1, 0)), np.complex128)
    du = np.empty((m, max(n - 1, 0)), np.complex128)
    mus = np.empty(m, np.complex128)
    _assemble(t0, h, w0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, c, Z, d, dl, du, mus)
    if not tridiagonal_solve(dl, d, du, Z):
        return False
    _stage_values(h, w0, z0, Z, mus, Trep, cT, dense, stages, w1, z1, Yw, Yz, Zg)
    return True


@kernel
def radau_pair(t0, h, hh, w0, z0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, Trep, c, cT, dense,
               w1, z1, wa, za, Ywa, Yza, Zga):
    """Two :func:`radau_step` from the same start: ``h`` (end point only) and ``hh`` (with stages), one solve."""
    n = w0.size
    m = lam.size
    Z = np.empty((2 * m, n), np.complex128)
    d = np.empty((2 * m, n), np.complex128)
    dl = np.empty((2 * m, max(n - 1, 0)), np.complex128)
    du = np.empty((2 * m, max(n - 1, 0)), np.complex128)
    mus = np.empty(2 * m, np.complex128)
    _assemble(t0, h, w0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, c, Z[:m], d[:m], dl[:m], du[:m],
              mus[:m])
    _assemble(t0, hh, w0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, c, Z[m:], d[m:], dl[m:], du[m:],
              mus[m:])
    if not tridiagonal_solve(dl, d, du, Z):
        return False
    _stage_values(h, w0, z0, Z[:m], mus[:m], Trep, cT, dense, False, w1, z1, Ywa, Yza, Zga)
    _stage_values(hh, w0, z0, Z[m:], mus[m:], Trep, cT, dense, True, wa, za, Ywa, Yza, Zga)
    return True


@kernel
def _assemble(t0, h, w0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, c, Z, d, dl, du, mus):
    """The m stage systems of a step of size h: right-hand sides ``Z``, matrices ``dl, d, du``, ``mus = h lam``."""
    n = w0.size
    m = lam.size
    s = c.size
    g = np.empty(s)
    for r in range(s):
        g[r] = math.sin(t0 + h * c[r])
    for k in range(m):
        mu = h * lam[k]
        mus[k] = mu
        acc = 0.0j
        for r in range(s):
            acc += Tinv[k, r] * g[r]
        a1 = mu * q[k]
        a2 = mu * (acc - q[k] * inv_gamma)
        a3 = -mu * a1
        mu2 = mu * mu
        # complex times real written out (numba would promote the real factor to complex)
        a1r, a1i, a2r, a2i, a3r, a3i = a1.real, a1.imag, a2.real, a2.imag, a3.real, a3.imag
        mur, mui, m2r, m2i = mu.real, mu.imag, mu2.real, mu2.imag
        for i in range(n):
            x = om2c[i] * w0[i]
            Z[k, i] = complex(a1r * aw[i] + a2r * f[i] + a3r * x, a1i * aw[i] + a2i * f[i] + a3i * x)
            d[k, i] = complex(1.0 - mur * dw[i] + m2r * om2c[i], -mui * dw[i] + m2i * om2c[i])
        for i in range(n - 1):
            dl[k, i] = complex(-mur * Ll[i], -mui * Ll[i])
            du[k, i] = complex(-mur * Lu[i], -mui * Lu[i])


@kernel
def _stage_values(h, w0, z0, Z, mus, Trep, cT, dense, stages, w1, z1, Yw, Yz, Zg):
    """End point (and with ``stages`` the stage values and the zeta grid) from the solved stage systems."""
    m, n = Z.shape
    s = cT.size
    Zr = np.empty((m, n))
    Zi = np.empty((m, n))
    for k in range(m):
        for i in range(n):
            Zr[k, i] = Z[k, i].real
            Zi[k, i] = Z[k, i].imag
    r0 = s - 1 if not stages else 0
    for r in range(r0, s):                          # Y = Re(T Z) + w0, Re(T diag(mu) Z) + h c w0 + z0
        ur = w1 if not stages else Yw[r]
        uz = z1 if not stages else Yz[r]
        hc = h * cT[r]
        for i in range(n):
            ur[i] = 0.0
            uz[i] = 0.0
        for k in range(m):
            tw = Trep[r, k]
            tz = tw * mus[k]
            twr, twi, tzr, tzi = tw.real, tw.imag, tz.real, tz.imag
            for i in range(n):
                ur[i] += twr * Zr[k, i] - twi * Zi[k, i]
                uz[i] += tzr * Zr[k, i] - tzi * Zi[k, i]
        for i in range(n):
            ur[i] += w0[i]
            uz[i] += hc * w0[i] + z0[i]
    if not stages:
        return
    G = dense.shape[0]
    for gi in range(G - 1):
        zg = Zg[gi]
        c0 = dense[gi, 0]
        for i in range(n):
            zg[i] = c0 * z0[i]
        for r in range(s):
            cr = dense[gi, r + 1]
            yz = Yz[r]
            for i in range(n):
                zg[i] += cr * yz[i]
    for i in range(n):
        Zg[G - 1, i] = Yz[s - 1, i]                 # theta = 1 is the last stage, exactly
        w1[i] = Yw[s - 1, i]
        z1[i] = Yz[s - 1, i]


@kernel
def _held_rows(u, hidx, him, hip, hLd, hLl, hLu, out):
    for k in range(hidx.size):
        out[k] = hLd[k] * u[hidx[k]] + hLl[k] * u[him[k]] + hLu[k] * u[hip[k]]


@kernel
def _grid_violation(t0, h, w0, Yw, Zg, sgn, hidx, him, hip, hLd, hLl, hLu, inv_gamma, theta, dense, out, row0):
    """:meth:`SoftIntegrator._grid_violation` into rows ``row0 .. row0 + G - 1`` of ``out``."""
    G, n = Zg.shape
    s = Yw.shape[0]
    for gi in range(G):
        for i in range(n):
            out[row0 + gi, i] = Zg[gi, i] * sgn[i]
    nh = hidx.size
    if nh == 0:
        return
    u = np.empty(n)
    a = np.empty(nh)
    for gi in range(G):
        tg = t0 + theta[gi] * h
        for k in range(nh):                  # w on the grid at the held nodes and their neighbours
            for col in (hidx[k], him[k], hip[k]):
                acc = 0.0
                for r in range(s):
                    acc += dense[gi, r + 1] * Yw[r, col]
                u[col] = acc + dense[gi, 0] * w0[col]
        _held_rows(u, hidx, him, hip, hLd, hLl, hLu, a)
        gt = math.sin(tg) - inv_gamma
        for k in range(nh):
            out[row0 + gi, hidx[k]] = a[k] + gt


@kernel
def _poly_eval(vinv, z0, Yz, i, coef):
    """Ascending monomial coefficients of the collocation polynomial of node i (values z0, Yz at 0, c)."""
    s1 = vinv.shape[0]
    for p in range(s1):
        acc = vinv[p, 0] * z0[i]
        for r in range(1, s1):
            acc += vinv[p, r] * Yz[r - 1, i]
        coef[p] = acc


@kernel
def _poly_roots(vinv, z0, Yz, idx, lo, hi, guess):
    """:meth:`SoftIntegrator._poly_roots` for nodes ``idx`` in place of ``guess`` (same two regimes)."""
    k = idx.size
    s1 = vinv.shape[0]
    deg = s1 - 1
    coef = np.empty((k, s1))
    for a in range(k):
        _poly_eval(vinv, z0, Yz, idx[a], coef[a])
    x = np.empty(k)
    for a in range(k):
        x[a] = min(max(guess[a], lo[a]), hi[a])
    if k <= 16:                                    # few roots: Newton, one by one
        for a in range(k):
            xi = x[a]
            for _ in range(5):
                p = coef[a, deg]
                dp = 0.0
                for mm in range(deg - 1, -1, -1):
                    dp = dp * xi + p
                    p = p * xi + coef[a, mm]
                if dp == 0.0 or not math.isfinite(p / dp):
                    break
                xn = xi - p / dp
                if not (lo[a] <= xn <= hi[a]):
                    break
                done = abs(xn - xi) <= 1e-15
                xi = xn
                if done:
                    break
            guess[a] = xi
        return
    for _ in range(5):                             # many: Newton on all at once
        anymove = False
        for a in range(k):
            xa = x[a]
            p = coef[a, deg]
            dp = coef[a, deg] * deg
            for mm in range(deg - 1, -1, -1):
                p = p * xa + coef[a, mm]
                if mm:
                    dp = dp * xa + coef[a, mm] * mm
            if dp != 0.0:
                step = p / dp
            elif p != 0.0:
                step = math.inf
            else:
                step = math.nan
            xn = xa - step
            good = math.isfinite(xn) and lo[a] <= xn <= hi[a]
            if good:
                x[a] = xn
                if abs(step) > 1e-15:
                    anymove = True
        if not anymove:
            break
    for a in range(k):
        guess[a] = x[a]


@kernel
def march(t, t_target, h_ctl, max_step, w, z, dw, om2c, f, Ll, Lu, sgn, held, hidx, him, hip, hLd, hLl, hLu,
          inv_gamma, rtol, atol, order, time_tol, lam, q, Tinv, Trep, c, cT, dense, theta, vinv,
          xnodes, xguess, xtop, xstate):
    r"""The step-doubling loop of :meth:`SoftIntegrator.advance` from ``t`` towards ``t_target``.

    Accepted steps overwrite ``w`` and ``z``.  Stops at ``t_target`` (status :data:`REACHED`), at the
    first accepted step whose scan grid shows a crossing (:data:`CROSSING`: ``w``, ``z`` are the
    state at the step's start ``t``; the crossing nodes are ``xnodes[:count]`` with their guesses
    ``xguess``, the upper ends ``xtop`` of their grid brackets; ``xstate`` receives the step end
    ``t_new`` and whether the earliest node starts moving away), or on a failure
    (:data:`NONFINITE`, :data:`UNDERFLOW`, :data:`SINGULAR`).

    Parameters
    ----------
    t, t_target, h_ctl, max_step : float
        Start, target, the controller's step size and the largest step.
    w, z : ndarray of float, shape (n,)
    dw, om2c, f, Ll, Lu, sgn : ndarray of float
        Configuration (:meth:`SoftIntegrator._config`; ``sgn`` -1 free, +1 in contact).
    held : ndarray of bool, shape (n,)
    hidx, him, hip : ndarray of int
        Held nodes and their neighbours; ``hLd, hLl, hLu`` their rows of the full operator.
    inv_gamma, rtol, atol : float
    order : int
        Order of the method, ``2 s - 1``.
    time_tol : float
    lam, q, Tinv, Trep, c, cT, dense : ndarray
        As :func:`radau_step`.
    theta : ndarray of float, shape (G,)
        Scan grid in a step, ``(1..G)/G``.
    vinv : ndarray of float, shape (s + 1, s + 1)
        Inverse Vandermonde matrix on (0, c).
    xnodes : ndarray of int, shape (n,)
    xguess, xtop : ndarray of float, shape (n,)
    xstate : ndarray of float, shape (2,)
        Outputs (see above).

    Returns
    -------
    status : int
    t : float
        Time of ``w, z``.
    h_ctl : float
        The controller's next step size.
    count : int
        Crossing nodes (status :data:`CROSSING`).
    n_steps, n_rejected : int
        Collocation steps taken and steps rejected.
    """
    n = w.size
    s = c.size
    G = theta.size
    aw = np.empty(n)
    w1 = np.empty(n)
    z1 = np.empty(n)
    wa = np.empty(n)
    za = np.empty(n)
    wb = np.empty(n)
    zb = np.empty(n)
    Ywa = np.empty((s, n))
    Yza = np.empty((s, n))
    Zga = np.empty((G, n))
    Ywb = np.empty((s, n))
    Yzb = np.empty((s, n))
    Zgb = np.empty((G, n))
    vg = np.empty((2 * G + 1, n))
    tg = np.empty(2 * G + 1)
    hv = np.empty(hidx.size)
    kk = np.empty(n, np.int64)
    awayf = np.zeros(n, np.bool_)
    n_steps = 0
    n_rej = 0
    while True:
        start_rhs(w, z, dw, om2c, Ll, Lu, aw)
        h = min(h_ctl, max_step, t_target - t)
        last = h >= t_target - t
        t_new = t_target if last else t + h
        h = t_new - t
        t_mid = t + 0.5 * h
        hh = t_mid - t
        h2 = t_new - t_mid
        ok = radau_pair(t, h, hh, w, z, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, Trep, c, cT, dense,
                        w1, z1, wa, za, Ywa, Yza, Zga)
        n_steps += 2
        if not ok:
            return SINGULAR, t, h_ctl, 0, n_steps, n_rej
        start_rhs(wa, za, dw, om2c, Ll, Lu, aw)
        ok = radau_step(t_mid, h2, wa, za, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, Trep, c, cT,
                        dense, True, wb, zb, Ywb, Yzb, Zgb)
        n_steps += 1
        if not ok:
            return SINGULAR, t, h_ctl, 0, n_steps, n_rej
        err = 0.0
        for i in range(n):
            e1 = abs(w1[i] - wb[i]) / (atol + rtol * max(abs(w[i]), abs(wb[i])))
            e2 = abs(z1[i] - zb[i]) / (atol + rtol * max(abs(z[i]), abs(zb[i])))
            if e1 > err or e1 != e1:
                err = e1
            if e2 > err or e2 != e2:
                err = e2
        if not math.isfinite(err):
            return NONFINITE, t, h_ctl, 0, n_steps, n_rej
        if err > 1.0:
            n_rej += 1
            h_ctl = h * max(0.1, 0.8 * err ** (-1.0 / (order + 1)))
            if h_ctl < 1e-14 * max(1.0, abs(t)):
                return UNDERFLOW, t, h_ctl, 0, n_steps, n_rej
            continue
        grow = 4.0 if err == 0.0 else min(4.0, max(0.2, 0.8 * err ** (-1.0 / (order + 1))))
        if not last or h >= h_ctl:
            h_ctl = h * grow
        # scan both halves for crossings
        for i in range(n):
            vg[0, i] = z[i] * sgn[i]
        if hidx.size:
            _held_rows(w, hidx, him, hip, hLd, hLl, hLu, hv)
            g0 = math.sin(t) - inv_gamma
            for k in range(hidx.size):
                vg[0, hidx[k]] = hv[k] + g0
        _grid_violation(t, hh, w, Ywa, Zga, sgn, hidx, him, hip, hLd, hLl, hLu, inv_gamma, theta, dense, vg, 1)
        _grid_violation(t_mid, h2, wa, Ywb, Zgb, sgn, hidx, him, hip, hLd, hLl, hLu, inv_gamma, theta, dense,
                        vg, 1 + G)
        tg[0] = t
        for gi in range(G - 1):
            tg[1 + gi] = t + theta[gi] * hh
            tg[1 + G + gi] = t_mid + theta[gi] * h2
        tg[G] = t_mid
        tg[2 * G] = t_new
        count = 0
        for i in range(n):
            away = vg[0, i] > 0.0
            awayf[i] = away
            seen = False
            first = -1
            for r in range(2 * G + 1):
                v = vg[r, i]
                if away:
                    seen = seen or v <= 0.0
                    if v > 0.0 and (seen or tg[r] > t + 4.0 * time_tol):
                        first = r
                        break
                elif v > 0.0:
                    first = r
                    break
            if first >= 0:
                if away:
                    vg[0, i] = 0.0
                xnodes[count] = i
                kk[count] = first
                count += 1
        if count:
            nsel = 0
            for a in range(count):
                i = xnodes[a]
                k = kk[a]
                lo = vg[k - 1, i]
                hi = vg[k, i]
                xguess[a] = tg[k - 1] + (tg[k] - tg[k - 1]) * (-lo) / (hi - lo)
                if k == 1:
                    xguess[a] = tg[k]
                xtop[a] = tg[k]
            # polish on the collocation polynomial of each half (held nodes keep the grid guess)
            for half in range(2):
                ts_ = t if half == 0 else t_mid
                hs_ = hh if half == 0 else h2
                nsel = 0
                for a in range(count):
                    if ((kk[a] <= G) if half == 0 else (kk[a] > G)) and not held[xnodes[a]]:
                        nsel += 1
                if nsel == 0:
                    continue
                sel = np.empty(nsel, np.int64)
                idx = np.empty(nsel, np.int64)
                plo = np.empty(nsel)
                phi = np.empty(nsel)
                pg = np.empty(nsel)
                b = 0
                for a in range(count):
                    if ((kk[a] <= G) if half == 0 else (kk[a] > G)) and not held[xnodes[a]]:
                        sel[b] = a
                        idx[b] = xnodes[a]
                        plo[b] = (tg[kk[a] - 1] - ts_) / hs_
                        phi[b] = (tg[kk[a]] - ts_) / hs_
                        pg[b] = (xguess[a] - ts_) / hs_
                        b += 1
                if half == 0:
                    _poly_roots(vinv, z, Yza, idx, plo, phi, pg)
                else:
                    _poly_roots(vinv, za, Yzb, idx, plo, phi, pg)
                for b in range(nsel):
                    xguess[sel[b]] = ts_ + hs_ * pg[b]
            best = 0
            for a in range(1, count):
                if xguess[a] < xguess[best]:
                    best = a
            xstate[0] = t_new
            xstate[1] = 1.0 if awayf[xnodes[best]] else 0.0
            return CROSSING, t, h_ctl, count, n_steps, n_rej
        # accept the two half steps
        t = t_new
        for i in range(n):
            w[i] = wb[i]
            z[i] = zb[i]
        if t >= t_target:
            return REACHED, t, h_ctl, 0, n_steps, n_rej


@kernel
def violation(t, w, z, dw, om2c, f, Ll, Lu, sgn, hidx, him, hip, hLd, hLl, hLu, inv_gamma, with_rate, v, dv):
    """:meth:`SoftIntegrator._violation` into ``v`` (and its rate into ``dv`` if ``with_rate``)."""
    n = w.size
    for i in range(n):
        v[i] = z[i] * sgn[i]
    nh = hidx.size
    a = np.empty(nh)
    gt = math.sin(t) - inv_gamma
    if nh:
        _held_rows(w, hidx, him, hip, hLd, hLl, hLu, a)
        for k in range(nh):
            v[hidx[k]] = a[k] + gt
    if not with_rate:
        return
    for i in range(n):
        dv[i] = w[i] * sgn[i]
    if nh:
        r = np.empty(n)
        for i in range(n):
            x = dw[i] * w[i] - om2c[i] * z[i] + gt * f[i]
            if i > 0:
                x += Ll[i - 1] * w[i - 1]
            if i < n - 1:
                x += Lu[i] * w[i + 1]
            r[i] = x
        _held_rows(r, hidx, him, hip, hLd, hLl, hLu, a)
        ct = math.cos(t)
        for k in range(nh):
            dv[hidx[k]] = a[k] + ct


@kernel
def simultaneous(te, we, ze, dw, om2c, f, Ll, Lu, sgn, hidx, him, hip, hLd, hLl, hLu, inv_gamma, j, time_tol,
                 nodes):
    """:meth:`SoftIntegrator._simultaneous`: the nodes switching with node j at ``te``.

    Returns
    -------
    count : int
        Nodes switching at ``te`` (written to ``nodes[:count]``); 0 when a node crossed earlier.
    early : int
        The earliest node that crossed more than ``time_tol`` before ``te``, else -1.
    dt : float
        How long before ``te`` it crossed.
    """
    n = we.size
    v = np.empty(n)
    dv = np.empty(n)
    violation(te, we, ze, dw, om2c, f, Ll, Lu, sgn, hidx, him, hip, hLd, hLl, hLu, inv_gamma, True, v, dv)
    early = -1
    best = -math.inf
    for i in range(n):
        thr = time_tol * dv[i]
        if i != j and v[i] > max(thr, 0.0) and not (dv[i] < 0.0 and v[i] <= -2.0 * thr):
            dt = v[i] / dv[i] if dv[i] > 0.0 else math.inf          # te - t_cross
            if early < 0 or dt > best:
                early = i
                best = dt
    if early >= 0:
        return 0, early, (best if math.isfinite(best) else 0.0)
    count = 0
    for i in range(n):
        if i == j or (abs(v[i]) <= time_tol * dv[i] and dv[i] > 0.0):
            nodes[count] = i
            count += 1
    return count, -1, 0.0


@kernel
def configure(mode, Ld, Ll_full, Lu_full, two_beta, omega0_sq):
    """:meth:`SoftIntegrator._make_config` (mode 0 free, 1 soft contact, 2 held) in one pass.

    Returns
    -------
    F : ndarray of float, shape (7, n)
        Rows ``dw, om2c, f, sgn, rows_ok`` and the off-diagonals ``Ll, Lu`` (first n - 1 entries).
    held : ndarray of bool, shape (n,)
    H : ndarray of int, shape (3, n_held)
        Held nodes and their left and right neighbours (clamped to the ends).
    HL : ndarray of float, shape (3, n_held)
        Their rows of the full operator: diagonal, left and right entries (0 beyond the ends).

    Few arrays are returned: each returned array costs a conversion to a Python object.
    """
    n = mode.size
    F = np.zeros((7, n))
    held = np.empty(n, np.bool_)
    nh = 0
    for i in range(n):
        mi = mode[i]
        c = 1.0 if mi == 1 else 0.0
        held[i] = mi == 2
        nh += mi == 2
        F[2, i] = 1.0 if mi == 0 else 0.0
        F[3, i] = -1.0 if mi == 0 else 1.0
        F[4, i] = 0.0 if mi == 2 else 1.0
        F[1, i] = omega0_sq * c
        F[0, i] = Ld[i] * F[4, i] - two_beta * c
    for i in range(n - 1):
        F[5, i] = Ll_full[i] * F[4, i + 1]
        F[6, i] = Lu_full[i] * F[4, i]
    H = np.empty((3, nh), np.int64)
    HL = np.empty((3, nh))
    k = 0
    for i in range(n):
        if held[i]:
            H[0, k] = i
            H[1, k] = max(i - 1, 0)
            H[2, k] = min(i + 1, n - 1)
            HL[0, k] = Ld[i]
            HL[1, k] = Ll_full[i - 1] if i > 0 else 0.0
            HL[2, k] = Lu_full[i] if i < n - 1 else 0.0
            k += 1
    return F, held, H, HL


@kernel
def rhs(t, w, z, dw, om2c, f, Ll, Lu, rows_ok, inv_gamma):
    """:meth:`SoftIntegrator._rhs`: the right-hand side (dw/dt, dzeta/dt), shape (2, n)."""
    n = w.size
    out = np.empty((2, n))
    gt = math.sin(t) - inv_gamma
    for i in range(n):
        x = dw[i] * w[i] - om2c[i] * z[i] + gt * f[i]
        if i > 0:
            x += Ll[i - 1] * w[i - 1]
        if i < n - 1:
            x += Lu[i] * w[i + 1]
        out[0, i] = x
        out[1, i] = w[i] * rows_ok[i]
    return out


@kernel
def initial_mode(stuck, w, z):
    """:meth:`SoftIntegrator._initial_mode`: 0 free, 1 in soft contact, 2 held (in contact at w = zeta = 0)."""
    n = w.size
    mode = np.empty(n, np.int64)
    for i in range(n):
        mode[i] = (2 if w[i] == 0.0 and z[i] == 0.0 else 1) if stuck[i] else 0
    return mode


@kernel
def _violation_at(j, t, w, z, dw, om2c, f, Ll, Lu, sgn, rows_ok, Ld_j, Ll_j, Lu_j, inv_gamma):
    """:meth:`SoftIntegrator._violation_at`: violation of node j and its rate."""
    n = w.size
    if sgn[j] < 0.0:
        return -z[j], -w[j]
    if rows_ok[j] != 0.0:
        return z[j], w[j]
    jm = max(j - 1, 0)
    jp = min(j + 1, n - 1)
    gt = math.sin(t) - inv_gamma
    v = Ld_j * w[j] + Ll_j * w[jm] + Lu_j * w[jp] + gt
    r = np.empty(3)
    for a in range(3):
        i = min(max(j - 1 + a, 0), n - 1)
        x = dw[i] * w[i] - om2c[i] * z[i] + gt * f[i]
        if i > 0:
            x += Ll[i - 1] * w[i - 1]
        if i < n - 1:
            x += Lu[i] * w[i + 1]
        r[a] = x
    dv = Ld_j * r[1] + Ll_j * r[0 if j > 0 else 1] + Lu_j * r[2 if j < n - 1 else 1] + math.cos(t)
    return v, dv


@kernel
def locate(t0, w0, z0, j, guess, h_hi, verified, h_lo, dw, om2c, f, Ll, Lu, sgn, rows_ok, Ld_j, Ll_j, Lu_j,
           inv_gamma, lam, q, Tinv, Trep, c, cT, dense, we, ze):
    """:meth:`SoftIntegrator._locate`: safeguarded Newton in the step size for the crossing of node j.

    Every evaluation is a full collocation step from ``t0`` (:func:`radau_step`).  ``we, ze`` receive
    the state at the crossing.  ``Ld_j, Ll_j, Lu_j``: row j of the full operator (0 beyond the ends).

    Returns
    -------
    status : int
        0 (found), :data:`UNVERIFIED` (an unverified guess failed: the caller does a trial step),
        :data:`STALLED` or :data:`SINGULAR`.
    h : float
        Step size of the crossing.
    n_steps : int
    """
    n = w0.size
    aw = np.empty(n)
    start_rhs(w0, z0, dw, om2c, Ll, Lu, aw)
    dummy = np.empty((0, 0))
    bw = np.empty(n)
    bz = np.empty(n)
    lo = min(h_lo, 0.5 * h_hi)
    hi = h_hi
    hk = min(max(guess, 0.0), h_hi)
    best_c = math.inf
    best_h = 0.0
    n_steps = 0
    for it in range(60):
        if not verified and it >= 6:
            return UNVERIFIED, 0.0, n_steps
        if hk <= lo:
            hk = 0.5 * (lo + hi)
        n_steps += 1
        if not radau_step(t0, hk, w0, z0, aw, dw, om2c, f, Ll, Lu, inv_gamma, lam, q, Tinv, Trep, c, cT, dense,
                          False, we, ze, dummy, dummy, dummy):
            return SINGULAR, hk, n_steps
        vj, dvj = _violation_at(j, t0 + hk, we, ze, dw, om2c, f, Ll, Lu, sgn, rows_ok, Ld_j, Ll_j, Lu_j,
                                inv_gamma)
        if vj > 0.0:
            hi = hk
            verified = True
        else:
            lo = hk
        corr = -vj / dvj if dvj > 0.0 else math.inf
        if it == 0 or abs(corr) < best_c:
            best_c = abs(corr)
            best_h = hk
            for i in range(n):
                bw[i] = we[i]
                bz[i] = ze[i]
        if abs(corr) <= 1e-10:
            # the root is hk + corr to O(corr^2): move the state there along the pre-switch flow
            gt = math.sin(t0 + hk) - inv_gamma
            for i in range(n):
                x = dw[i] * we[i] - om2c[i] * ze[i] + gt * f[i]
                if i > 0:
                    x += Ll[i - 1] * we[i - 1]
                if i < n - 1:
                    x += Lu[i] * we[i + 1]
                bw[i] = we[i] + corr * x
                bz[i] = ze[i] + corr * (we[i] * rows_ok[i])
            for i in range(n):
                we[i] = bw[i]
                ze[i] = bz[i]
            return 0, hk + corr, n_steps
        ahk = abs(hk)
        if hi - lo <= 4.0 * (np.nextafter(ahk, math.inf) - ahk):      # 4 ulp(hk)
            if not verified:
                return UNVERIFIED, 0.0, n_steps
            for i in range(n):
                we[i] = bw[i]
                ze[i] = bz[i]
            return 0, best_h, n_steps
        hn = hk + corr
        if not (lo < hn < hi) or not math.isfinite(hn):
            hn = 0.5 * (lo + hi)
        hk = hn
    return STALLED, hk, n_steps


# ----------------------------------------------------------------------------- packed entry points
# A kernel call converts every array argument (about 0.4 us each): these take the configuration as
# the three arrays of :func:`configure` (``F``, ``H``, ``HL``) and unpack it inside.

@kernel
def march_packed(t, t_target, h_ctl, max_step, w, z, F, held, H, HL, inv_gamma, rtol, atol, order, time_tol,
                 lam, q, Tinv, Trep, c, cT, dense, theta, vinv, xnodes, xguess, xtop, xstate):
    """:func:`march` with the configuration packed as :func:`configure` returns it."""
    return march(t, t_target, h_ctl, max_step, w, z, F[0], F[1], F[2], F[5], F[6], F[3], held, H[0], H[1], H[2],
                 HL[0], HL[1], HL[2], inv_gamma, rtol, atol, order, time_tol, lam, q, Tinv, Trep, c, cT, dense,
                 theta, vinv, xnodes, xguess, xtop, xstate)


@kernel
def locate_packed(t0, w0, z0, j, guess, h_hi, verified, h_lo, F, Ld_j, Ll_j, Lu_j, inv_gamma, lam, q, Tinv,
                  Trep, c, cT, dense, we, ze):
    """:func:`locate` with the configuration packed as :func:`configure` returns it."""
    return locate(t0, w0, z0, j, guess, h_hi, verified, h_lo, F[0], F[1], F[2], F[5], F[6], F[3], F[4], Ld_j,
                  Ll_j, Lu_j, inv_gamma, lam, q, Tinv, Trep, c, cT, dense, we, ze)


@kernel
def violation_packed(t, w, z, F, H, HL, inv_gamma, with_rate):
    """:func:`violation` with the configuration packed; returns ``(v, dv)`` (``dv`` unset without rate)."""
    n = w.size
    v = np.empty(n)
    dv = np.empty(n)
    violation(t, w, z, F[0], F[1], F[2], F[5], F[6], F[3], H[0], H[1], H[2], HL[0], HL[1], HL[2], inv_gamma,
              with_rate, v, dv)
    return v, dv


@kernel
def simultaneous_packed(te, we, ze, F, H, HL, inv_gamma, j, time_tol):
    """:func:`simultaneous` with the configuration packed; returns ``(nodes, early, dt)``."""
    nodes = np.empty(we.size, np.int64)
    count, early, dt = simultaneous(te, we, ze, F[0], F[1], F[2], F[5], F[6], F[3], H[0], H[1], H[2], HL[0],
                                    HL[1], HL[2], inv_gamma, j, time_tol, nodes)
    return nodes[:count], early, dt


@kernel
def rhs_packed(t, w, z, F, inv_gamma):
    """:func:`rhs` with the configuration packed."""
    return rhs(t, w, z, F[0], F[1], F[2], F[5], F[6], F[4], inv_gamma)

