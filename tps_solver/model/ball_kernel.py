r"""The one-node ball with point impacts as compiled kernels: an ensemble of stroboscopic orbits in one call.

The same event rules and the same arithmetic as :class:`tps_solver.model.ball.ClosedFormBall`
(``model="point"``, constant restitution), written in the subset of Python that numba compiles
(:mod:`tps_solver.core.jit`): flights in closed form (16)-(17), the next landing by the certified
search of :meth:`tps_solver.model.flight.Flight.first_landing` (pieces between the zeros of g and
of w on which the height is monotone, a geometric bracket, Brent's method to a relative
tolerance of 4 eps, then safeguarded Newton steps), restitution (11), sticking while
:math:`g \le 0` and the lift-off where g turns positive (Sec. 4, after (37)).

:func:`basin_ensemble` follows many initial states through the stroboscopic map and stops each
one at the first repeated cycle, with the rule of
:func:`tps_solver.analyses.basins.flat_basins` (module docstring there).  Without numba the
functions run in the interpreter (slowly); the reference path of ``flat_basins`` is then the
per-sample :class:`~tps_solver.model.ball.ClosedFormBall`.

Brent's method here is written from its description (R. P. Brent, *Algorithms for Minimization
without Derivatives*, 1973, ch. 4: inverse quadratic interpolation, secant and bisection steps,
stopping when half the bracket is below :math:`(x_{tol} + r_{tol}|x|)/2`); its root can differ
from scipy's ``brentq`` in the last bits before the Newton polish.
"""
import math

import numpy as np

from tps_solver.core.jit import kernel

__all__ = ["basin_ensemble", "ball_cycles"]

_TWO_PI = 2.0 * math.pi
_RTOL = 4.0 * np.finfo(float).eps
_SMX = np.array([1.0 / math.factorial(2 * k + 3) for k in range(10)])
_FREE, _STUCK = 0, 1


@kernel
def _one_minus_cos(x):
    s = math.sin(0.5 * x)
    return 2.0 * s * s


@kernel
def _sin_minus_x(x):
    if abs(x) < 1.0:
        x2 = x * x
        acc = _SMX[9]
        for i in range(8, -1, -1):
            acc = _SMX[i] - x2 * acc
        return -x * x2 * acc
    return math.sin(x) - x


@kernel
def _fw(d, w_a, s, c, inv_G):
    return w_a + s * math.sin(d) + c * _one_minus_cos(d) - d * inv_G


@kernel
def _fz(d, w_a, z_a, s, c, inv_G):
    return z_a + w_a * d + s * _one_minus_cos(d) - c * _sin_minus_x(d) - 0.5 * d * d * inv_G


@kernel
def _f(which, d, w_a, z_a, s, c, inv_G):
    if which == 0:
        return _fw(d, w_a, s, c, inv_G)
    return _fz(d, w_a, z_a, s, c, inv_G)


@kernel
def _brent(which, a, b, w_a, z_a, s, c, inv_G):
    """Root of f(which) in [a, b] with a sign change (module docstring)."""
    fa = _f(which, a, w_a, z_a, s, c, inv_G)
    fb = _f(which, b, w_a, z_a, s, c, inv_G)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    cc, fc = a, fa
    d = e = b - a
    for _ in range(500):
        if (fb > 0.0) == (fc > 0.0):
            cc, fc = a, fa
            d = e = b - a
        if abs(fc) < abs(fb):
            a, b, cc = b, cc, b
            fa, fb, fc = fb, fc, fb
        tol = 0.5 * (1e-300 + _RTOL * abs(b))
        m = 0.5 * (cc - b)
        if abs(m) <= tol or fb == 0.0:
            return b
        if abs(e) < tol or abs(fa) <= abs(fb):
            d = e = m
        else:
            r3 = fb / fa
            if a == cc:
                p = 2.0 * m * r3
                q = 1.0 - r3
            else:
                q = fa / fc
                r = fb / fc
                p = r3 * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0))
                q = (q - 1.0) * (r - 1.0) * (r3 - 1.0)
            if p > 0.0:
                q = -q
            else:
                p = -p
            if 2.0 * p < 3.0 * m * q - abs(tol * q) and p < abs(0.5 * e * q):
                e = d
                d = p / q
            else:
                d = e = m
        a, fa = b, fb
        if abs(d) > tol:
            b = b + d
        else:
            b = b + (tol if m > 0.0 else -tol)
        fb = _f(which, b, w_a, z_a, s, c, inv_G)
    return b


@kernel
def _bracket_root(which, a, b, w_a, z_a, s, c, inv_G):
    """:func:`tps_solver.model.flight.bracket_root` of f(which): geometric shrink towards a, then Brent."""
    fa = _f(which, a, w_a, z_a, s, c, inv_G)
    L = b - a
    lo, hi = 0, 1100
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if (_f(which, a + math.ldexp(L, -mid), w_a, z_a, s, c, inv_G) > 0.0) == (fa > 0.0):
            hi = mid
        else:
            lo = mid
    left, right = a + math.ldexp(L, -hi), a + math.ldexp(L, -lo)
    if left == right:
        return right
    return _brent(which, left, right, w_a, z_a, s, c, inv_G)


@kernel
def _first_landing(t_a, w_a, z_a, Gamma, H):
    """Local time in (0, H] of the first landing of a flight, or -1 (:meth:`Flight.first_landing`)."""
    inv_G = 1.0 / Gamma
    s, c = math.sin(t_a), math.cos(t_a)
    brk = np.empty(12)
    nb = 1
    brk[0] = 0.0
    if Gamma >= 1.0:                      # the zeros of g in (t_a, t_a + H), sorted
        base = math.asin(1.0 / Gamma)
        t_b = t_a + H
        k = math.floor((t_a - math.pi) / _TWO_PI) - 1
        while base + _TWO_PI * k <= t_b + _TWO_PI:
            for zz in (base + _TWO_PI * k, math.pi - base + _TWO_PI * k):
                if t_a < zz < t_b:
                    j = nb
                    while j > 1 and brk[j - 1] > zz - t_a:
                        brk[j] = brk[j - 1]
                        j -= 1
                    brk[j] = zz - t_a
                    nb += 1
            k += 1
    brk[nb] = H
    nb += 1
    za = z_a
    first = True
    for i in range(nb - 1):
        p, q = brk[i], brk[i + 1]
        if not q > p:
            continue
        wp, wq = _fw(p, w_a, s, c, inv_G), _fw(q, w_a, s, c, inv_G)
        n_sub = 1
        cut = q
        if wp * wq < 0.0:
            cut = _bracket_root(0, p, q, w_a, z_a, s, c, inv_G)
            n_sub = 2
        for sub in range(n_sub):
            lo = p if sub == 0 else cut
            hi = (cut if n_sub == 2 else q) if sub == 0 else q
            if not first and za == 0.0:
                return lo
            first = False
            zq = _fz(hi, w_a, z_a, s, c, inv_G)
            if za > 0.0 and zq <= 0.0:
                if zq == 0.0:
                    return hi
                d = _bracket_root(1, lo, hi, w_a, z_a, s, c, inv_G)
                for _ in range(3):               # Flight._polish
                    slope = _fw(d, w_a, s, c, inv_G)
                    if slope == 0.0:
                        break
                    new = d - _fz(d, w_a, z_a, s, c, inv_G) / slope
                    if not lo <= new <= hi or new == d:
                        break
                    d = new
                return d
            za = zq
    return -1.0


@kernel
def _next_liftoff(t, Gamma):
    base = math.asin(1.0 / Gamma)
    k = math.ceil((t - base) / _TWO_PI)
    while base + _TWO_PI * (k - 1) >= t:
        k -= 1
    while base + _TWO_PI * k < t:
        k += 1
    return base + _TWO_PI * k


@kernel
def _advance(t, t_end, w, z, mode, Gamma, e, stick_velocity, max_events):
    """:meth:`ClosedFormBall.advance` (point, constant e): (w, z, mode, impacts, sticks, ok, t)."""
    inv_G = 1.0 / Gamma
    n_events = 0
    n_imp = 0
    n_stk = 0
    lifted = False
    while True:
        if n_events > max_events:
            return w, z, mode, n_imp, n_stk, False, t
        if mode == _STUCK:
            if math.sin(t) - inv_G > 0.0:
                tl = t
            elif Gamma <= 1.0:
                return 0.0, 0.0, _STUCK, n_imp, n_stk, True, t
            else:
                tl = _next_liftoff(t, Gamma)
            if tl >= t_end:
                return 0.0, 0.0, _STUCK, n_imp, n_stk, True, t
            t, w, z, mode, lifted = tl, 0.0, 0.0, _FREE, True
            n_events += 1
            continue
        if not lifted and z <= 0.0 and (w < 0.0 or (w == 0.0 and math.sin(t) - inv_G <= 0.0)):
            d = 0.0
            w_minus = min(w, 0.0)
        else:
            d = _first_landing(t, w, z, Gamma, t_end - t)
            if d >= 0.0:
                w_minus = min(_fw(d, w, math.sin(t), math.cos(t), inv_G), 0.0)
        lifted = False
        if d < 0.0:
            s, c = math.sin(t), math.cos(t)
            dd = t_end - t
            return (_fw(dd, w, s, c, inv_G), max(_fz(dd, w, z, s, c, inv_G), 0.0), _FREE, n_imp, n_stk,
                    True, t)
        t = t + d
        n_events += 1
        z = 0.0
        if abs(w_minus) <= stick_velocity or e == 0.0:
            w = 0.0
            if math.sin(t) - inv_G <= 0.0:
                mode = _STUCK
                n_stk += 1
                continue
        else:
            w = -e * w_minus
        n_imp += 1


@kernel
def _dist(states, i, a, b):
    if states[i, a, 2] != states[i, b, 2]:
        return math.inf
    return max(abs(states[i, a, 0] - states[i, b, 0]), abs(states[i, a, 1] - states[i, b, 1]))


@kernel
def _repeats(states, i, k, p, tol):
    for j in range(p):
        if not _dist(states, i, k - j, k - j - p) < tol:
            return False
    return True


@kernel
def _ensemble(Gamma, e, stick_velocity, t_section, w0, z0, max_cycles, p_max, tol, converging, max_events):
    N = w0.size
    states = np.zeros((N, max_cycles + 1, 3))
    status = np.ones(N, dtype=np.int64)
    info = np.zeros((N, 5), dtype=np.int64)       # period, n_cycles, first_index, impacts, sticks
    t_fail = np.zeros(N)
    counts = np.zeros((max_cycles, 2), dtype=np.int64)
    t_end = t_section + _TWO_PI
    for i in range(N):
        w, z, mode = w0[i], z0[i], _FREE
        states[i, 0, 0], states[i, 0, 1], states[i, 0, 2] = w, z, mode
        info[i, 1] = max_cycles
        for k in range(1, max_cycles + 1):
            w, z, mode, ni, ns, ok, tf = _advance(t_section, t_end, w, z, mode, Gamma, e, stick_velocity,
                                                  max_events)
            if not ok:
                status[i], info[i, 1], t_fail[i] = 2, k - 1, tf
                break
            states[i, k, 0], states[i, k, 1], states[i, k, 2] = w, z, mode
            counts[k - 1, 0], counts[k - 1, 1] = ni, ns
            found = False
            for p in range(1, min(p_max, k // 2) + 1):
                if not _repeats(states, i, k, p, tol):
                    continue
                shorter = False
                for dd in range(1, p):
                    if p % dd == 0 and _repeats(states, i, k, dd, converging):
                        shorter = True
                        break
                if shorter:
                    continue
                info[i, 0], info[i, 1], info[i, 2] = p, k, k - p + 1
                info[i, 3] = counts[k - p:k, 0].sum()
                info[i, 4] = counts[k - p:k, 1].sum()
                found = True
                break
            if found:
                status[i] = 0
                break
    return states, status, info, t_fail


def basin_ensemble(Gamma, e, stick_velocity, t_section, w0, zeta0, max_cycles, p_max, tol, converging,
                   max_events):
    r"""Follow free initial states of the point-impact ball to their first repeated stroboscopic cycle.

    Parameters
    ----------
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Constant restitution in [0, 1].
    stick_velocity : float
        Impacts at or below this speed end at rest.
    t_section : float
        Phase of the section; the states are ``(w, zeta)`` there, free (``zeta >= 0``).
    w0, zeta0 : ndarray of float, shape (N,)
        Initial states.
    max_cycles, p_max : int
        Longest run and longest cycle sought, in forcing cycles.
    tol, converging : float
        Return distance of a repeated cycle, and the distance below which a shorter cycle
        that divides it is still converging (then the run goes on).
    max_events : int
        A sample with more events in one forcing cycle fails.

    Returns
    -------
    states : ndarray of float, shape (N, max_cycles + 1, 3)
        ``(w, zeta, mode)`` at the sections (zeros after a sample stopped).
    status : ndarray of int, shape (N,)
        0 periodic, 1 irregular (no repeat within ``max_cycles``), 2 failed (too many events).
    info : ndarray of int, shape (N, 5)
        Period, cycles run, first strobe index of the repeated cycle, impacts and sticks over it.
    t_fail : ndarray of float, shape (N,)
        Time of the failure (status 2).

    Examples
    --------
    The completely inelastic ball at Gamma = 4.1 settles on the f/2 sticking orbit:

    >>> states, status, info, _ = basin_ensemble(4.1, 0.0, 1e-6, 0.0, np.array([0.3]), np.array([0.5]),
    ...                                          40, 8, 1e-8, 1e-3, 1000)
    >>> int(status[0]), info[0, [0, 3, 4]].tolist()
    (0, [2, 1, 1])
    """
    w0 = np.ascontiguousarray(w0, dtype=float)
    zeta0 = np.ascontiguousarray(zeta0, dtype=float)
    return _ensemble(float(Gamma), float(e), float(stick_velocity), float(t_section), w0, zeta0,
                     int(max_cycles), int(p_max), float(tol), float(converging), int(max_events))


def ball_cycles(Gamma, e, stick_velocity, t_section, w0, zeta0, n_cycles, max_events=10000):
    r"""The stroboscopic orbit of one free initial state, ``n_cycles`` forcing cycles, compiled.

    Returns
    -------
    ndarray of float, shape (n_cycles + 1, 3)
        ``(w, zeta, mode)`` at the sections (modes as in :mod:`tps_solver.model.ball`).

    Raises
    ------
    RuntimeError
        If a forcing cycle has more than ``max_events`` events.

    Examples
    --------
    >>> x = ball_cycles(2.5, 0.5, 1e-6, 0.0, 0.2, 1.0, 3)
    >>> x.shape
    (4, 3)
    """
    out = np.empty((n_cycles + 1, 3))
    w, z, mode = float(w0), float(zeta0), _FREE
    out[0] = w, z, mode
    for k in range(1, n_cycles + 1):
        w, z, mode, _, _, ok, tf = _advance(float(t_section), float(t_section) + _TWO_PI, w, z, mode,
                                            float(Gamma), float(e), float(stick_velocity), int(max_events))
        if not ok:
            raise RuntimeError(f"more than {max_events} events in one forcing cycle near t = {tf:.12g}")
        out[k] = w, z, mode
    return out
