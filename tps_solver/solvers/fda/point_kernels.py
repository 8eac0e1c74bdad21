r"""The contact search of :class:`~tps_solver.solvers.fda.point.PointIntegrator` as one compiled kernel.

:func:`search` is the search loop of :meth:`PointIntegrator.advance` on one segment: per step
the fused product ``K @ y(tau)`` (:class:`~tps_solver.solvers.fda.point._Segment`), the safe
steps of :func:`~tps_solver.solvers.fda.point._half_step`, the smallest candidate, the
certified bracket of the leading group and the safeguarded Newton polish of its root -- the
same rules and arithmetic, step by step (the interpreted path's batched walk through the
points proposed by a repeated segment is an economy of numpy calls and is not needed here).
The product is numpy's (BLAS) ``dot``; the polish evaluates its two rows as dot products, so
roots can differ from the interpreted path in the last bits.

Compiled with numba when the ``fast`` extra is installed (:mod:`tps_solver.core.jit`); the
integrator uses it by default then (option ``compiled``).
"""
import math

import numpy as np

from tps_solver.core.jit import kernel

__all__ = ["search", "STOP", "EVENT", "TOO_MANY_STEPS"]

#: Status codes of :func:`search`.
STOP, EVENT, TOO_MANY_STEPS = 0, 1, 2
_EPS = float(np.finfo(float).eps)
_PHI2_SERIES = 1.0 / np.array([math.factorial(k + 2) for k in range(10)])
_MAX_ENDS = 4096


@kernel
def _fill_y(y, lam, tau, nf, b, zero_only, c, sn, t_c, inv_gamma):
    """:meth:`_Segment.y`: the column vector of ``K`` at local time ``tau``, in place."""
    st = math.sin(tau)
    h = math.sin(0.5 * tau)
    vers = 2.0 * h * h
    if zero_only:
        for i in range(nf):
            y[i] = math.expm1(lam[i] * tau)
        zv = st - tau
    else:
        zmax = -1.0
        for i in range(nf):
            z = lam[i] * tau
            y[i] = math.expm1(z)
            if abs(z) < 0.1 and abs(z) > zmax:
                zmax = abs(z)
        k = 1
        if zmax >= 0.0:
            while k < 10 and zmax ** k * _PHI2_SERIES[k] > 1e-17:
                k += 1
        tt = tau * tau
        for i in range(nf):
            z = lam[i] * tau
            if abs(z) < 0.1:
                acc = _PHI2_SERIES[k - 1]
                for j in range(k - 2, -1, -1):
                    acc = acc * z + _PHI2_SERIES[j]
                y[nf + i] = tt * acc
            else:
                y[nf + i] = tt * ((y[i] - z) / (z * z))
        zv = st
    t = t_c + tau
    y[b] = c * st - sn * vers
    y[b + 1] = -sn * st - c * vers
    y[b + 2] = tau
    y[b + 3] = c * vers + sn * zv
    y[b + 4] = -sn * vers + c * zv
    y[b + 5] = -0.5 * tau * tau
    y[b + 6] = math.sin(t) - inv_gamma
    y[b + 7] = math.cos(t)
    y[b + 8] = 1.0


@kernel
def _half_step(f, fp, A2, h):
    """:func:`~tps_solver.solvers.fda.point._half_step` into ``h``."""
    for i in range(f.size):
        fpos = max(f[i], 0.0)
        q = fp[i] * fp[i]
        q += A2[i] * fpos
        q = math.sqrt(q)
        q += abs(fp[i])
        h[i] = fpos / q if fp[i] < 0.0 else q / A2[i]


@kernel
def _row_dot(K, r, y):
    acc = 0.0
    for j in range(y.size):
        acc += K[r, j] * y[j]
    return acc


@kernel
def _root(K, lam, nf, b, zero_only, c, sn, t_c, inv_gamma, r_f, r_fp, lo, hi, flo, dlo, y):
    """:meth:`PointIntegrator._root`: safeguarded Newton on rows ``r_f`` (value), ``r_fp`` (slope)."""
    if flo <= 0.0:
        return lo
    x, fx, dx = lo, flo, dlo
    for _ in range(200):
        tol = 1e-15 + 4 * _EPS * abs(x)
        if dx < 0.0:
            step = -fx / dx
            if abs(step) <= tol:
                return min(max(x + step, lo), hi)
            xn = x + step
            if not lo < xn < hi:
                xn = 0.5 * (lo + hi)
        else:
            xn = 0.5 * (lo + hi)
        _fill_y(y, lam, xn, nf, b, zero_only, c, sn, t_c, inv_gamma)
        fx, dx = _row_dot(K, r_f, y), _row_dot(K, r_fp, y)
        if fx == 0.0:
            return xn
        if fx > 0.0:
            lo = xn
        else:
            hi = xn
        if hi - lo <= tol:
            return xn
        x = xn
    return x


@kernel
def _bracket(K, lam, nf, b, zero_only, c, sn, t_c, inv_gamma, fo, po, f, fp, A2, hh, tau, m, time_tol,
             y, out):
    """:meth:`PointIntegrator._bracket` on the candidates ``f, fp, A2, hh``; NaN if not all certified."""
    nc = f.size
    fpos = np.maximum(f, 0.0)
    ok = np.empty(nc, dtype=np.bool_)
    upper = np.zeros(nc)
    for i in range(nc):
        fp2 = fp[i] * fp[i]
        Af = A2[i] * fpos[i]
        ok[i] = fp[i] < 0.0 and fp2 >= 1.25 * Af
        if ok[i]:
            root = math.sqrt(max(fp2 - Af, 0.0)) - fp[i]
            upper[i] = 2.0 * fpos[i] / root
    if not ok[m]:
        return math.nan
    span = upper[m]
    while True:
        group = np.flatnonzero(hh < 0.5 * span)
        if group.size == 0:
            group = np.array([m])
        for g in group:
            if not ok[g]:
                return math.nan
        new_span = upper[group].max()
        if new_span <= span or group.size == nc:
            break
        span = new_span
    lead, best = group[0], math.inf
    for g in group:
        v = fpos[g] / -fp[g]
        if v < best:
            lead, best = g, v
    tau_c = _root(K, lam, nf, b, zero_only, c, sn, t_c, inv_gamma, fo + nf + lead, po + nf + lead, tau,
                  tau + upper[lead], f[lead], fp[lead], y)
    if group.size == 1:
        return tau_c
    for _ in range(group.size):
        _fill_y(y, lam, tau_c, nf, b, zero_only, c, sn, t_c, inv_gamma)
        out[:] = K @ y
        below = False
        j, best = group[0], math.inf
        for g in group:
            v = out[fo + nf + g]
            if v < -time_tol * abs(fp[g]) - 64 * _EPS:
                below = True
            r = v / -fp[g]
            if r < best:
                j, best = g, r
        if not below:
            break
        tau_c = _root(K, lam, nf, b, zero_only, c, sn, t_c, inv_gamma, fo + nf + j, po + nf + j, tau, tau_c,
                      f[j], fp[j], y)
    return tau_c


@kernel
def _search(K, lam, nf, b, zero_only, c, sn, t_c, inv_gamma, fo, po, Ao, L, eps_w, tau_stop, floor, max_steps,
            time_tol, use_first, f_first, fp_first, A2_first, guarded, release_half):
    y = np.empty(K.shape[1])
    y2 = np.empty(K.shape[1])
    out = np.empty(K.shape[0])
    out2 = np.empty(K.shape[0])
    hh = np.empty(L)
    f, fp, A2 = np.empty(L), np.empty(L), np.empty(L)
    ends = np.empty(_MAX_ENDS)
    n_ends = 0
    tau = 0.0
    steps = 0
    while True:
        steps += 1
        if steps > max_steps:
            return TOO_MANY_STEPS, tau, -1, steps, ends[:n_ends]
        if tau > 0.0 or not use_first:
            _fill_y(y, lam, tau, nf, b, zero_only, c, sn, t_c, inv_gamma)
            out[:] = K @ y
            f[:], fp[:], A2[:] = out[fo:fo + L], out[po:po + L], out[Ao:Ao + L]
        else:
            f[:], fp[:], A2[:] = f_first, fp_first, A2_first
        _half_step(f, fp, A2, hh)
        for j in range(nf):
            if f[j] >= -eps_w and hh[j] > hh[nf + j]:
                hh[nf + j] = hh[j]
            if guarded:
                r = release_half[j] - 0.5 * tau
                if r > hh[nf + j]:
                    hh[nf + j] = r
        if L == nf:
            m, hm = 0, math.inf
        else:
            m = int(np.argmin(hh[nf:]))
            hm = 2.0 * hh[nf + m]
        if tau + hm >= tau_stop:
            return STOP, tau_stop, m, steps, ends[:n_ends]
        event = math.nan
        fm, fpm = f[nf + m], fp[nf + m]
        if fpm < 0.0 and fpm * fpm >= 1.25 * (A2[nf + m] * max(fm, 0.0)):
            event = _bracket(K, lam, nf, b, zero_only, c, sn, t_c, inv_gamma, fo, po, f[nf:], fp[nf:], A2[nf:],
                             hh[nf:], tau, m, time_tol, y2, out2)
        if math.isnan(event) and hm <= floor:
            event = tau + hm
        if not math.isnan(event):
            return EVENT, event, m, steps, ends[:n_ends]
        nxt = tau + hm
        if n_ends < _MAX_ENDS:
            ends[n_ends] = nxt
            n_ends += 1
        tau = nxt


def search(seg, eps_w, tau_stop, floor, max_steps, time_tol, first=None, release_half=None):
    r"""The contact search of one segment, from local time 0 to the next event or ``tau_stop``.

    Parameters
    ----------
    seg : _Segment
        The segment (its fused matrix ``K`` and its free set's layout).
    eps_w : float
        Velocity round-off below which a rising node is safe while its velocity bound is.
    tau_stop, floor : float
        End of the search, and the safe step below which the lead candidate is an event.
    max_steps : int
        Bound on search steps.
    time_tol : float
        Simultaneity window (the repair of the group's earliest root).
    first : tuple of ndarray, optional
        ``(f, f', 2A)`` at ``tau = 0`` from the nodal state (a node at rest on the plate).
    release_half : ndarray of float, shape (nf,), optional
        Half the remaining guard time of released nodes.

    Returns
    -------
    status : int
        :data:`STOP`, :data:`EVENT` or :data:`TOO_MANY_STEPS`.
    tau : float
        Local time of the event (or ``tau_stop``, or where the steps ran out).
    m : int
        Index of the smallest candidate at the last step.
    steps : int
        Search steps taken.
    ends : ndarray of float
        Natural ends ``tau + h`` of the steps (the next segment's proposal).

    Examples
    --------
    A flat layer's next impact, the default (compiled where numba is installed) against the numpy
    search (``compiled=False``):

    >>> import numpy as np
    >>> import tps_solver as tps
    >>> from tps_solver.solvers.fda.point import PointIntegrator
    >>> fl = tps.FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    >>> t = fl.t0 + 1.0
    >>> w, z = np.full(5, fl.velocity(t)), np.full(5, fl.height(t))
    >>> a = PointIntegrator(lat, 2.5, 0.45).advance(t, w, z, np.zeros(5, bool), t + 13.0)
    >>> b = PointIntegrator(lat, 2.5, 0.45, compiled=False).advance(t, w, z, np.zeros(5, bool), t + 13.0)
    >>> bool(abs(a.t - b.t) < 1e-14), a.contact.tolist() == b.contact.tolist()
    (True, True)
    """
    fs = seg.fs
    c, sn = seg.cs
    use_first = first is not None
    if use_first:
        f0, fp0, A20 = (np.ascontiguousarray(v, dtype=float) for v in first)
    else:
        f0 = fp0 = A20 = np.zeros(fs.L)
    guarded = release_half is not None
    rh = np.ascontiguousarray(release_half, dtype=float) if guarded else np.zeros(fs.nf)
    return _search(seg.K, fs.lam, fs.nf, fs.b, bool(fs.zero_only), c, sn, float(seg.t_c), float(seg.inv_gamma),
                   fs.f_off, fs.fp_off, fs.A_off, fs.L, float(eps_w), float(tau_stop), float(floor),
                   int(max_steps), float(time_tol), use_first, f0, fp0, A20, guarded, rh)
