r"""Contact patterns of the impact-and-stick TPS: the pattern type, and patterns read from FDA runs and shooting orbits.

A :class:`StickPattern` lists, per contact, the node, its kind (``"bounce"`` or
``"stick"``), the contact time, the lift-off time of a stick and what triggered it.
:func:`pattern_from_fda` and :func:`pattern_from_orbit` read one from a time-stepped
run or a periodic orbit found by shooting; :func:`check_with_fda` time-steps the FDA
from a solution and compares the events.
"""
import math

import numpy as np

from tps_solver.core import archive
from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_int, check_real
from tps_solver.solvers.shooting.periodic import ShootingOrbit
from tps_solver.solvers.fda.states import kink_state as fda_kink_state
from tps_solver.solvers.tps.stick_problem import KINDS, flat_stick_orbit

__all__ = ["StickPattern", "kink_state", "pattern_from_fda", "pattern_from_orbit", "check_with_fda"]


class StickPattern(Bunch):
    r"""A contact pattern with initial values: which contacts each node makes per period.

    Attributes
    ----------
    node : ndarray of int, shape (C,)
        Node of each contact; contacts are grouped by node, increasing in time.
    kind : ndarray of str, shape (C,)
        ``"bounce"`` or ``"stick"``.
    t : ndarray of float, shape (C,)
        Contact (impact) times, within one window of length T per node.
    J : ndarray of float, shape (C,)
        Impulses (velocity jumps) at the impacts.
    tau : ndarray of float, shape (C,)
        Lift-off time after a stick (nan for a bounce), ``tau > t``.
    trigger : ndarray of int, shape (C,)
        Index of the contact whose impact triggers the lift-off (-1: smooth lift-off).
    trigger_shift : ndarray of int, shape (C,)
        Period shift m with ``tau = t[trigger] + m T``.
    n_nodes : int
    period : float

    Examples
    --------
    The flat e = 0 orbit on one node: a touch-and-go, then a stick with a smooth lift-off.

    >>> from tps_solver import solve_stick_flat
    >>> p = solve_stick_flat(4.1).pattern
    >>> [str(k) for k in p.kind], p.trigger.tolist()
    (['bounce', 'stick'], [-1, -1])
    >>> bool(np.isnan(p.tau[0]) and p.tau[1] > p.t[1])
    True
    """


def make_pattern(node, kind, t, J, tau, trigger, trigger_shift, n_nodes, period):
    node = np.asarray(node, dtype=int)
    t = np.asarray(t, float)
    if t.size:                            # move the window so that the earliest contact is in [0, T)
        shift = math.floor(float(np.min(t)) / period) * period
        t = t - shift
        tau = np.asarray(tau, float) - shift
    order = np.lexsort((np.asarray(t, float), node))
    inv = np.empty_like(order)
    inv[order] = np.arange(order.size)
    trig = np.asarray(trigger, dtype=int)[order]
    trig = np.where(trig >= 0, inv[np.maximum(trig, 0)], -1)
    p = StickPattern(node=node[order], kind=np.asarray(kind, dtype="U6")[order],
                     t=np.asarray(t, float)[order], J=np.asarray(J, float)[order],
                     tau=np.asarray(tau, float)[order], trigger=trig,
                     trigger_shift=np.asarray(trigger_shift, dtype=int)[order],
                     n_nodes=int(n_nodes), period=float(period))
    check_pattern(p)
    return p


def check_pattern(p):
    C = p.node.size
    if C == 0:
        raise ValueError("pattern must hold at least one contact per node (K >= 1), got none")
    counts = np.bincount(p.node, minlength=p.n_nodes)
    if p.node.min() < 0 or p.node.max() >= p.n_nodes:
        raise ValueError(f"pattern.node must lie in [0, {p.n_nodes}), got range "
                         f"[{p.node.min()}, {p.node.max()}]")
    if np.any(counts < 1):
        raise ValueError(f"every node needs K >= 1 contacts per period; nodes without a contact: "
                         f"{np.nonzero(counts < 1)[0][:10].tolist()}")
    bad = ~np.isin(p.kind, KINDS)
    if np.any(bad):
        raise ValueError(f"pattern.kind must be 'bounce' or 'stick', got {p.kind[bad][0]!r}")
    for arr, name in ((p.t, "t"), (p.J, "J")):
        if arr.shape != (C,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"pattern.{name} must be finite with shape ({C},)")
    stick = p.kind == "stick"
    if not np.all(np.isfinite(p.tau[stick])) or np.any(p.tau[stick] <= p.t[stick]):
        raise ValueError("pattern.tau must be finite and > t for every stick contact")
    for j in range(p.n_nodes):
        tj = p.t[p.node == j]
        ends = np.where(stick[p.node == j], p.tau[p.node == j], tj)
        if tj.size and (tj[-1] - tj[0] >= p.period or np.any(tj[1:] < ends[:-1])
                        or ends[-1] > tj[0] + p.period):
            raise ValueError(f"pattern at node {j} does not exist: its contacts and stick "
                             "intervals must be disjoint and fit in one period")
    if np.any((p.trigger >= 0) & ~stick):
        raise ValueError("pattern.trigger must be -1 for bounce contacts")


def kink_state(lattice, Gamma, M=2, t=None):
    r"""A kink start for e = 0: the flat orbit for x < 0, the same half a period later for x >= 0.

    The call form of the impact-and-stick TPS for :func:`tps_solver.solvers.fda.states.kink_state`
    (the one kink start) with the e = 0 sticking far field and a step (``width=0``).

    Parameters
    ----------
    lattice : tps_solver.Lattice
        Planar lattice.
    Gamma : float
    M : int
        Even (the half-period shift is a flat phase only for even M).
    t : float, optional
        Start time (default: lift-off + 0.5, a flight phase of both halves).

    Returns
    -------
    t : float
    w0, zeta0 : ndarray of float, shape (n_nodes,)

    Raises
    ------
    ValueError
        If ``M`` is odd.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=5, length=8.0)
    >>> t, w0, zeta0 = kink_state(lat, 4.1)
    >>> left = lat.nodes < 0                       # two flat halves, half a period apart
    >>> bool(np.all(w0[left] == w0[0]) and np.all(w0[~left] == w0[-1]) and w0[0] != w0[-1])
    True
    >>> w0.shape, bool(np.all(zeta0 >= 0))
    ((5,), True)
    """
    if M % 2:
        raise ValueError(f"M must be even for a kink start, got {M}")
    orb = flat_stick_orbit(Gamma, M)
    t = orb.t_liftoff + 0.5 if t is None else check_real(t, "t")
    w0, zeta0 = fda_kink_state(lattice, orb.orbit, t, width=0.0)
    return t, w0, zeta0


def pattern_from_fda(run, lattice, period, t_window=None, tol=1e-9):
    r"""Read the contact pattern of the last period of an FDA run (``tps.simulate`` events).

    Parameters
    ----------
    run : SimulationResult
        A run of at least two periods that has settled on a T-periodic state.
    lattice : tps_solver.Lattice
    period : float
    t_window : float, optional
        Start of the window of length T whose contacts are read; default: one
        and a half periods before the end, moved to the largest event-free gap.
    tol : float
        Coincidence tolerance for lift-offs triggered by a neighbour's impact.

    Returns
    -------
    StickPattern

    Raises
    ------
    ValueError
        If the run ends before a stick of the window lifts off, or the pattern read is
        not a valid one (a node without contacts: run longer or move ``t_window``).

    Examples
    --------
    A uniform 3-node lattice released at the flat lift-off settles at once on the flat orbit:

    >>> import tps_solver as tps
    >>> orb = flat_stick_orbit(4.1)
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> run = tps.simulate(lat, 4.1, 0.0, np.zeros(3), np.zeros(3), t_start=orb.t_liftoff + 1e-9,
    ...                    t_end=orb.t_liftoff + 3 * orb.period)
    >>> p = pattern_from_fda(run, lat, orb.period)
    >>> [str(k) for k in p.kind[p.node == 1]], bool(np.max(np.abs(p.t[p.node == 1] - orb.t)) < 1e-9)
    (['bounce', 'stick'], True)
    """
    ev = run.events
    T = float(period)
    n = lattice.n_nodes
    if t_window is None:
        lo = run.t - 1.5 * T
        sel = ev.t[(ev.t > lo) & (ev.t < lo + T)]
        ph = np.sort(np.concatenate([[lo, lo + T], sel]))
        gap = np.argmax(np.diff(ph))
        t_window = 0.5 * (ph[gap] + ph[gap + 1])
    A = np.asarray(lattice.operator)
    node, kind, t, J, tau = [], [], [], [], []
    for j in range(n):
        e_j = ev[ev.node == j]
        inside = np.nonzero((e_j.t >= t_window) & (e_j.t < t_window + T) & (e_j.kind != "liftoff"))[0]
        for i in inside:
            node.append(j)
            t.append(float(e_j.t[i]))
            J.append(-float(e_j.w_before[i]))
            if e_j.kind[i] == "stick":
                later = np.nonzero((e_j.kind == "liftoff") & (e_j.t >= e_j.t[i]))[0]
                if later.size == 0:
                    raise ValueError(f"the FDA run ends before node {j} lifts off: run longer")
                kind.append("stick")
                tau.append(float(e_j.t[later[0]]))
            else:
                kind.append("bounce")
                tau.append(math.nan)
    node, t, tau = np.array(node), np.array(t), np.array(tau)
    trigger = np.full(node.size, -1)
    shift = np.zeros(node.size, dtype=int)
    for c in np.nonzero(np.isfinite(tau))[0]:
        j = node[c]
        nb = np.nonzero((A[j] != 0) & (np.arange(n) != j))[0]
        cand = np.nonzero(np.isin(node, nb))[0]
        if cand.size == 0:
            continue
        m = np.round((tau[c] - t[cand]) / T)
        d = np.abs(tau[c] - t[cand] - m * T)
        k = np.argmin(d)
        if d[k] < tol:
            trigger[c], shift[c] = cand[k], int(m[k])
    return make_pattern(node, kind, t, np.array(J), tau, trigger, shift, n, T)


def same_lattice(a, b):
    return (a is b) or (a.n_nodes == b.n_nodes and a.geometry == b.geometry and a.boundary == b.boundary
                        and np.allclose(a.nodes, b.nodes, rtol=1e-12, atol=1e-12))


def pattern_from_orbit(orbit, lattice=None, tol=1e-9):
    r"""Read the contact pattern of a converged periodic orbit found by shooting.

    The orbit (:class:`~tps_solver.solvers.shooting.periodic.ShootingOrbit`, point impacts) is integrated
    by the exact FDA integrator for 2.5 periods from its section state (its stuck nodes
    held), and :func:`pattern_from_fda` reads the contacts of the window of length T
    that starts in the largest event-free gap after half a period.  On a converged
    orbit (residual ~1e-12) the contact times are those of the orbit to that accuracy,
    so the pattern is the orbit's own (an unsettled time-stepped run may still carry
    transient touch-and-go landings).

    Parameters
    ----------
    orbit : ShootingOrbit
        Result of :func:`tps_solver.find_periodic_orbit` with ``method="exact"`` or
        ``"point"``, preferably converged.
    lattice : tps_solver.Lattice, optional
        If given, it must be the orbit's lattice.
    tol : float
        Coincidence tolerance for triggered lift-offs (see :func:`pattern_from_fda`).

    Returns
    -------
    StickPattern

    Raises
    ------
    ValueError
        If ``orbit`` is not a ShootingOrbit of point impacts, or ``lattice`` is not its lattice.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, multipliers=False)
    >>> p = pattern_from_orbit(orb)
    >>> [str(k) for k in p.kind[p.node == 0]], bool(np.all(p.trigger == -1))
    (['bounce', 'stick'], True)
    """
    from tps_solver.solvers.fda import simulate

    if not isinstance(orbit, ShootingOrbit):
        raise ValueError(f"orbit must be a ShootingOrbit (tps.find_periodic_orbit), got {type(orbit).__name__}")
    if orbit.method not in ("exact", "point"):
        raise ValueError(f"orbit.method must be 'exact' or 'point' (point impacts), got {orbit.method!r}")
    if lattice is not None and not same_lattice(lattice, orbit.lattice):
        raise ValueError("lattice must be the orbit's lattice (same nodes, geometry and boundary)")
    T = orbit.period
    run = simulate(orbit.lattice, orbit.Gamma, orbit.e, orbit.w0, orbit.zeta0, t_start=orbit.t_start,
                   t_end=orbit.t_start + 2.5 * T, method="exact", stuck0=orbit.stuck0)
    if run.status != 0:
        raise ValueError(f"the FDA run on the orbit failed: {run.message}")
    return pattern_from_fda(run, orbit.lattice, T, tol=tol)


# ------------------------------------------------------------------ the problem


def check_with_fda(sol, periods=1, t_start=None):
    r"""Time-step the FDA (exact integrator) from the TPS state and compare the events.

    Parameters
    ----------
    sol : StickSolution
        A lattice solution (``sol.lattice`` set).
    periods : int
        Periods to integrate.
    t_start : float, optional
        Start time; default: the middle of the largest event-free gap of the TPS orbit.

    Returns
    -------
    Bunch
        ``contact_error`` and ``liftoff_error`` (max over nodes and periods of the
        distance between each TPS time and the nearest FDA event of the same node
        and type), ``events_per_period`` (FDA impacts+sticks per node and period, shape
        (n_nodes,)), ``run`` (the FDA result), ``t_start``.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, multipliers=False)
    >>> sol = tps.solve_stick_lattice(lat, 4.1, pattern=orb)
    >>> chk = check_with_fda(sol, periods=2)
    >>> bool(chk.contact_error < 1e-10 and chk.liftoff_error < 1e-10), chk.events_per_period.tolist()
    (True, [2.0, 2.0, 2.0])
    """
    from tps_solver.solvers.fda import simulate

    lat = sol.lattice
    T = sol.period
    p = sol.pattern
    periods = check_int(periods, "periods", minimum=1)
    if t_start is None:
        ev = np.mod(np.concatenate([p.t, p.tau[np.isfinite(p.tau)]]), T)
        ph = np.sort(np.concatenate([ev, ev[:1] + T]))
        k = int(np.argmax(np.diff(ph)))
        t_start = 0.5 * (ph[k] + ph[k + 1])
    w0 = sol.velocity([t_start])[0]
    z0 = sol.height([t_start])[0]
    # nodes inside a stick interval at t_start are held on the plate
    stuck = np.zeros(p.n_nodes, dtype=bool)
    for c in np.nonzero(p.kind == "stick")[0]:
        ph = p.t[c] + np.mod(t_start - p.t[c], T)
        if ph < p.tau[c]:
            stuck[p.node[c]] = True
    w0 = np.where(stuck, 0.0, w0)
    z0 = np.where(stuck, 0.0, np.maximum(z0, 0.0))
    run = simulate(lat, sol.Gamma, sol.e, w0, z0, t_start=t_start, t_end=t_start + periods * T,
                   method="exact", stuck0=stuck)
    ev = run.events
    c_err, l_err = 0.0, 0.0
    counts = np.zeros(p.n_nodes)
    for j in range(p.n_nodes):
        e_j = ev[ev.node == j]
        imp = e_j.t[e_j.kind != "liftoff"]
        lif = e_j.t[e_j.kind == "liftoff"]
        counts[j] = imp.size / periods
        for c in np.nonzero(p.node == j)[0]:
            for m in range(periods):
                tc = t_start + np.mod(p.t[c] - t_start, T) + m * T
                c_err = max(c_err, float(np.min(np.abs(imp - tc))) if imp.size else math.inf)
                if np.isfinite(p.tau[c]):
                    tl = tc + (p.tau[c] - p.t[c])
                    if tl < run.t:
                        l_err = max(l_err, float(np.min(np.abs(lif - tl))) if lif.size else math.inf)
    return Bunch(contact_error=c_err, liftoff_error=l_err, events_per_period=counts, run=run,
                 t_start=t_start)



archive.register("StickPattern", StickPattern)      # file codec: every field by the generic encoder
