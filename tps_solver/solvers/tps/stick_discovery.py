r"""Pattern discovery for the impact-and-stick TPS: the e = 0 kink from the anti-continuum limit.

:func:`~tps_solver.solvers.tps.stick.solve_stick_lattice` solves for a periodic orbit whose
contact pattern (which contacts each node makes, which stick intervals end smoothly and
which are ended by a neighbour's landing) is given.  :func:`discover_stick_kink` finds the
pattern of the e = 0 kink itself, without the time stepper and without shooting.

**The start.**  With the lattice operator scaled by a coupling :math:`\nu`
(:class:`~tps_solver.operators.modal.ModalBasis` with ``coupling``), the nodes decouple as
:math:`\nu \to 0` and each one is a flat layer; a kink is then exact: the nodes left of the
front on the flat e = 0 orbit (:func:`~tps_solver.solvers.tps.stick_problem.flat_stick_orbit`:
a touch-and-go, then a stick with a smooth lift-off), the nodes right of it on the same
orbit half a period later (:func:`anticontinuum_pattern`).  Coupling ``nu`` on a lattice of
spacing dx is the lattice of spacing :math:`dx/\sqrt\nu` at coupling 1, so the path below is
also a path in the spacing, from :math:`dx/\sqrt{\nu_0}` down to dx.

**The path.**  :math:`\nu` is raised geometrically from ``coupling_start`` to 1 (adaptive
steps in :math:`\ln\nu`).  At every :math:`\nu` the TPS is solved by the one Newton engine in
*rounds*: after each round the stick segments are re-cut at the neighbours' events of the
current iterate (the cut structure follows the times; when Newton stops at a boundary of
the structure, the full Newton step predicts the structure beyond it), until Newton
converges on a structure that its own solution reproduces.  Then the solution is checked,
and the pattern changed where a check fails (an active-set step; the changes are listed in
``discovery.changes``):

* a stick whose plate reaction turns tensile before its lift-off lifts off where it first
  does, triggered by a neighbour's landing if that is where the reaction jumps below 0;
* a triggered lift-off whose reaction stays compressive after the neighbour's landing
  jump becomes smooth (later);
* a touch-and-go (or a stick of zero length) after which the free acceleration is
  negative becomes a stick;
* a stick whose reaction is tensile at its own landing becomes a touch-and-go;
* when Newton fails at the next :math:`\nu`, a smooth lift-off within 0.05 of a neighbour's
  landing becomes triggered by it (the landing reaches the lift-off along the path), and
  the step is retried; otherwise the step is halved.

Along the path, neighbour events within ``COARSE_MARGINS`` (1e-7 for impacts, 1e-3 for
lift-offs) of a stick interval's ends do not cut it: the near-coincident landings of the
far field (differences 1e-9 and below, whose order is not known until the solution is)
would make segments whose order flips during Newton.  The error this makes is of the size of
a neighbour's reaction jump times the margin (impacts) and of the cube of the margin
(smooth lift-offs, where the neighbour's acceleration is continuous).  At :math:`\nu = 1`
the orbit is polished on the default cuts (margins 1e-12 and 1e-6) to the tolerance ``tol``.

The continuation in the coupling loses digits for :math:`\nu \to 0`: the separable kernel
tables cancel for :math:`|\lambda T| \ll 1`
(:meth:`~tps_solver.operators.modal.ModalBasis.separable_table`); from
:math:`\nu_0 = 0.01` (spacing 20 at dx = 2) the residual reaches ~1e-9, which the path's
tolerance (``PATH_TOL``) allows.
"""
import math
import time

import numpy as np
from numpy.polynomial.legendre import legvander

from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_int, check_positive
from tps_solver.core.progress import progress_state
from tps_solver.operators.lattice import Lattice
from tps_solver.operators.modal import ModalBasis
from tps_solver.solvers.tps.stick import solve_pattern
from tps_solver.solvers.tps.stick_pattern import make_pattern
from tps_solver.solvers.tps.stick_problem import StickProblem, flat_stick_orbit

__all__ = ["anticontinuum_pattern", "discover_stick_kink", "COARSE_MARGINS", "PATH_TOL"]

#: Cut margins (impacts, lift-offs) along the continuation (module docstring).
COARSE_MARGINS = (1e-7, 1e-3)
#: Residual tolerance of the solves along the path (the final polish uses ``tol``).
PATH_TOL = 1e-8

_N_QUAD = 16
_REACTION_TOL = 1e-9         # a reaction below -this is tensile
_TRIGGER_WINDOW = 0.05       # a landing this close to a smooth lift-off may trigger it
_OPEN = 1e-3                 # a new stick interval starts with this length
_SHUT = 1e-10                # a stick interval shorter than this is an impact with w+ = 0


def anticontinuum_pattern(n_nodes, front, Gamma=4.1, M=2):
    """The kink of uncoupled nodes: the flat e = 0 orbit, shifted by half a period right of ``front``.

    Parameters
    ----------
    n_nodes : int
        Lattice nodes, >= 2.
    front : int
        Last node on the unshifted orbit, ``0 <= front < n_nodes - 1``.
    Gamma : float
        Plate acceleration (the e = 0 f/2 orbit exists for 3.857 <= Gamma <= 6.362).
    M : int
        Even period order, T = 2 pi M.

    Returns
    -------
    StickPattern
        Two contacts per node (a touch-and-go ``"bounce"`` and a ``"stick"`` with a smooth
        lift-off), with the flat orbit's times and impulses.

    Examples
    --------
    >>> p = anticontinuum_pattern(4, 1, 4.1)
    >>> [str(k) for k in p.kind[p.node == 0]], [str(k) for k in p.kind[p.node == 3]]
    (['bounce', 'stick'], ['bounce', 'stick'])
    >>> bool(abs((p.t[p.node == 3][1] - p.t[p.node == 0][1]) % p.period - p.period / 2) < 1e-12)
    True
    """
    n_nodes = check_int(n_nodes, "n_nodes", minimum=2)
    front = check_int(front, "front", minimum=0)
    if front >= n_nodes - 1:
        raise ValueError(f"front must be in [0, {n_nodes - 2}] (nodes on both sides), got {front}")
    M = check_int(M, "M", minimum=2)
    if M % 2:
        raise ValueError(f"M must be even (a kink joins two phases half a period apart), got {M}")
    flat = flat_stick_orbit(Gamma, M)
    T = flat.period
    node, kind, t, J, tau = [], [], [], [], []
    for j in range(n_nodes):
        shift = 0.0 if j <= front else T / 2
        for c in range(flat.t.size):
            tc = flat.t[c] + shift
            window = math.floor(tc / T) * T
            node.append(j)
            kind.append(flat.kind[c])
            t.append(tc - window)
            J.append(-flat.w_minus[c])
            tau.append(flat.tau[c] + shift - window)
    C = len(node)
    return make_pattern(node, kind, t, J, tau, -np.ones(C, int), np.zeros(C, int), n_nodes, T)


# ------------------------------------------------------------------ one coupling: rounds of re-cutting
def _structure(problem):
    return (problem.seg_a.tobytes(), problem.seg_b.tobytes(), problem.seg_ash.tobytes(),
            problem.seg_bsh.tobytes(), problem.stick.tobytes())


def _pattern_at(problem, x):
    """The pattern with the times of ``x`` (sticks kept open where a predicted step closes them)."""
    p = problem.p
    t, tau_s, J, _ = problem.unpack(x)
    tau = np.full(problem.C, np.nan)
    tau[problem.stick] = tau_s
    for c in np.nonzero(problem.collapsed)[0]:
        trig = p.trigger[c]
        tau[c] = t[trig] + p.trigger_shift[c] * problem.T if trig >= 0 else t[c] + 0.1 * _SHUT
    stick = p.kind == "stick"
    was_open = stick & (p.tau - p.t >= _SHUT)
    bad = was_open & (tau <= t + 1e-9)
    tau[bad] = t[bad] + np.minimum(_OPEN, 0.5 * (p.tau[bad] - p.t[bad]))
    tau[stick] = np.maximum(tau[stick], t[stick] + 0.1 * _SHUT)
    return make_pattern(p.node, p.kind, t, J, tau, p.trigger, p.trigger_shift, p.n_nodes, problem.T)


def _recut_solve(modal, pattern, ctx, tol, margins, rounds=6, inner=4):
    """Newton in rounds with the cuts re-derived from the iterate; returns (solution, rounds, nit)."""
    nit = 0
    for r in range(1, rounds + 1):
        sol = solve_pattern(modal, pattern, ctx.nodes, ctx.Gamma, ctx.M, 0.0, ctx.n_basis, _N_QUAD, tol,
                            inner, 8, margins=margins)
        nit += sol.nit
        if sol.status == 5:
            return sol, r, nit
        problem, x = sol.problem, sol.unknowns
        same = _structure(StickProblem(modal, sol.pattern, ctx.Gamma, 0.0, ctx.n_basis, _N_QUAD,
                                       margins)) == _structure(problem)
        if sol.converged and same:
            return sol, r, nit
        if not same:
            pattern = sol.pattern
            continue
        # stopped at a boundary of the cut structure: a full Newton step predicts the one beyond
        F, st, v = problem.residual(x)
        try:
            dx = np.linalg.solve(problem.jacobian_matrix(x, st, v, F), -F)
        except np.linalg.LinAlgError:
            return sol, r, nit
        for frac in (1.0, 0.5, 0.25, 0.125):
            try:
                pattern = _pattern_at(problem, x + frac * dx)
                break
            except ValueError:
                continue
        else:
            return sol, r, nit
    return sol, rounds, nit


# ------------------------------------------------------------------ the active set
def _reaction(problem, coef, g, a, b, ts):
    xi = 2 * (ts - a) / (b - a) - 1
    rho = legvander(xi, problem.nb[g] - 1) @ coef[problem.coef_off[g]:problem.coef_off[g + 1]]
    return rho - (np.sin(ts) - 1.0 / problem.Gamma)


def _diagnose(sol):
    """Pattern changes where the solution fails a check: (new pattern or None, list of str)."""
    problem, x, p = sol.problem, sol.unknowns, sol.pattern
    T, A = problem.T, problem.m.A
    t, _, J, coef = problem.unpack(x)
    kind, tau = p.kind.copy(), p.tau.copy()
    trig, shift = p.trigger.copy(), p.trigger_shift.copy()
    changes = []
    sa, sb = problem.seg_ends(x[:problem.n_theta])
    segs = {}
    for g in range(problem.G):
        segs.setdefault(int(problem.stick[problem.seg_s[g]]), []).append((sa[g], sb[g], g))
    for c, pieces in segs.items():
        pieces.sort()
        j = int(p.node[c])
        first = None
        for a, b, g in pieces:
            ts = np.linspace(a, b, 41)
            r = _reaction(problem, coef, g, a, b, ts)
            neg = np.nonzero(r < -_REACTION_TOL)[0]
            if neg.size:
                i = int(neg[0])
                if i == 0:
                    first = a
                else:
                    lo, hi = ts[i - 1], ts[i]
                    for _ in range(60):
                        mid = 0.5 * (lo + hi)
                        if _reaction(problem, coef, g, a, b, np.array([mid]))[0] < 0.0:
                            hi = mid
                        else:
                            lo = mid
                    first = lo
                break
        if first is None:
            continue
        if first - t[c] < 1e-7:
            kind[c], tau[c], trig[c], shift[c] = "bounce", np.nan, -1, 0
            changes.append(f"node {j}: the stick at t = {t[c]:.6f} becomes a touch-and-go (tensile at landing)")
            continue
        trig[c], shift[c] = -1, 0
        for k in np.nonzero((p.node != j) & (A[j, p.node] != 0))[0]:
            m = round((first - t[k]) / T)
            if abs(t[k] + m * T - first) < 1e-7:
                trig[c], shift[c] = int(k), int(m)
        tau[c] = first
        how = f"triggered by node {int(p.node[trig[c]])}'s landing" if trig[c] >= 0 else "smooth"
        changes.append(f"node {j}: lift-off earlier, at t = {first:.6f} ({how}; the reaction turned tensile)")
    for c in np.nonzero((p.kind == "stick") & (p.trigger >= 0))[0]:
        if kind[c] != "stick" or trig[c] != p.trigger[c] or int(c) not in segs:
            continue
        a, b, g = sorted(segs[int(c)])[-1]
        k = p.trigger[c]
        after = _reaction(problem, coef, g, a, b, np.array([b]))[0] - A[p.node[c], p.node[k]] * J[k]
        if after > _REACTION_TOL:
            trig[c], shift[c], tau[c] = -1, 0, tau[c] + _OPEN
            changes.append(f"node {int(p.node[c])}: the landing of node {int(p.node[k])} does not release "
                           f"it (reaction {after:.2e} after the jump); smooth lift-off later")
    shut = (p.kind == "bounce") | ((p.kind == "stick") & (p.tau - p.t < _SHUT))
    G_ = problem.Gamma
    for c in np.nonzero(shut)[0]:
        if kind[c] != p.kind[c]:
            continue
        tp = t[c] + 1e-9
        w_all = sol.velocity([tp])[0]
        w_all[p.node[c]] = 0.0
        acc = math.sin(tp) - 1.0 / G_ + float(A[p.node[c]] @ w_all)
        if acc < -_REACTION_TOL:
            kind[c], tau[c], trig[c], shift[c] = "stick", t[c] + _OPEN, -1, 0
            changes.append(f"node {int(p.node[c])}: the touch-and-go at t = {t[c]:.6f} becomes a stick "
                           f"(free acceleration {acc:.2e} after it)")
    if not changes:
        return None, changes
    return make_pattern(p.node, kind, t, J, tau, trig, shift, p.n_nodes, T), changes


def _near_triggers(p, A, window):
    """(|d|, stick, landing, shift): smooth lift-offs with a neighbour's landing within ``window``."""
    T, out = p.period, []
    for c in np.nonzero((p.kind == "stick") & (p.trigger < 0) & (p.tau - p.t >= _SHUT))[0]:
        j = p.node[c]
        for k in np.nonzero((p.node != j) & (A[j, p.node] != 0))[0]:
            m0 = math.floor((p.tau[c] - p.t[k]) / T + 0.5)
            for m in (m0 - 1, m0, m0 + 1):
                d = p.t[k] + m * T - p.tau[c]
                if abs(d) < window:
                    out.append((abs(d), int(c), int(k), int(m)))
    return sorted(out)


def _predict(prev, last, nu):
    """Secant predictor in ln(nu) of the times when the last two accepted patterns agree."""
    (p0, nu0), (p1, nu1) = prev, last
    if (p0 is None or nu0 >= nu1 or p0.node.size != p1.node.size or not np.array_equal(p0.node, p1.node)
            or not np.array_equal(p0.kind, p1.kind) or not np.array_equal(p0.trigger, p1.trigger)
            or not np.array_equal(np.isnan(p0.tau), np.isnan(p1.tau))):
        return p1
    r = (math.log(nu) - math.log(nu1)) / (math.log(nu1) - math.log(nu0))
    d_t = np.mod(p1.t - p0.t + p1.period / 2, p1.period) - p1.period / 2
    t = p1.t + r * d_t
    tau = p1.tau + r * (p1.tau - p0.tau - (p1.t - p0.t) + d_t)
    try:
        return make_pattern(p1.node, p1.kind, t, p1.J, tau, p1.trigger, p1.trigger_shift, p1.n_nodes,
                            p1.period)
    except ValueError:
        return p1


def _triggered(p, pairs):
    trig, shift, tau = p.trigger.copy(), p.trigger_shift.copy(), p.tau.copy()
    for _, c, k, m in pairs:
        trig[c], shift[c], tau[c] = k, m, p.t[k] + m * p.period
    return make_pattern(p.node, p.kind, p.t, p.J, tau, trig, shift, p.n_nodes, p.period)


# ------------------------------------------------------------------ the front end
def discover_stick_kink(lattice, Gamma=4.1, M=2, *, front=None, coupling_start=0.01, step=0.16,
                        min_step=2e-3, tol=1e-10, max_steps=300, n_basis=8, callback=None):
    r"""The e = 0 kink found by the TPS itself: continuation in the coupling from the anti-continuum limit.

    See the module docstring for the method.  No time stepping and no shooting take part.

    Parameters
    ----------
    lattice : tps_solver.Lattice
        Planar lattice with Neumann ends.
    Gamma : float
        Plate acceleration (3.857 <= Gamma <= 6.362 for the e = 0 f/2 far field).
    M : int
        Even period order (default 2).
    front : int, optional
        Last node of the unshifted side at the start; default ``n_nodes // 2 - 1`` (the front
        between the two middle nodes of an even lattice: the bond-centred kink).
    coupling_start : float
        :math:`\nu_0` in (0, 1): the path starts at spacing ``dx / sqrt(nu_0)``.
    step : float
        Largest step in :math:`\ln\nu`.
    min_step : float
        The path gives up when the step falls below this.
    tol : float
        Residual of the final polish on the default cuts.
    max_steps : int
        Bound on the continuation steps (accepted and failed).
    n_basis : int
        Legendre terms of the reaction per stick segment.
    callback : callable, optional
        ``callback(state)`` after every coupling solved: a
        :class:`~tps_solver.core.progress.ProgressState` of stage ``"discovery"`` with
        ``fraction`` (:math:`\ln(\nu/\nu_0)/\ln(1/\nu_0)`), ``coupling`` and ``residual``.

    Returns
    -------
    StickSolution
        The orbit at coupling 1 with its discovered ``pattern`` (a
        :class:`~tps_solver.core.orbit.PeriodicOrbit`; ``converged`` only if the polish
        converged and the pattern needed no further change), and ``discovery``
        (:class:`~tps_solver.core.bunch.Bunch`: ``couplings`` (the accepted :math:`\nu`),
        ``steps`` and ``failed`` (continuation steps), ``rounds`` and ``newton_steps``
        (totals over the path), ``changes`` (list of (coupling, text)), ``reached`` (the
        largest coupling solved), ``seconds``), ``formulation``, ``spacing`` and ``lattice``.
        ``checks.all_pass`` is False unless the solution converged and passes every check.

    Raises
    ------
    ValueError
        For a lattice that is not planar with Neumann ends, or bad parameters.

    Examples
    --------
    Six nodes at spacing 4 (the front between nodes 2 and 3; about 7 s):

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=6, length=20.0)
    >>> sol = discover_stick_kink(lat, 4.1, coupling_start=0.02, step=0.4)
    >>> sol.converged, sol.checks.all_pass, sol.discovery.reached
    (True, True, 1.0)
    >>> sol.contacts.sequence(2)             # the two nodes at the front only touch and go
    'TT'
    """
    start_clock = time.perf_counter()
    if not isinstance(lattice, Lattice) or lattice.geometry != "planar" or lattice.boundary != "neumann":
        raise ValueError("lattice must be a planar tps.Lattice with Neumann ends, e.g. "
                         "tps.Lattice.planar(n_nodes=20, length=38.0)")
    n = lattice.n_nodes
    if front is None:
        front = n // 2 - 1
    pattern = anticontinuum_pattern(n, front, Gamma, M)
    T = pattern.period
    if not (0.0 < float(coupling_start) < 1.0):
        raise ValueError(f"coupling_start must be in (0, 1), got {coupling_start!r}")
    step = check_positive(step, "step")
    min_step = check_positive(min_step, "min_step")
    tol = check_positive(tol, "tol")
    max_steps = check_int(max_steps, "max_steps", minimum=1)
    n_basis = check_int(n_basis, "n_basis", minimum=1, maximum=12)
    ctx = Bunch(nodes=lattice.nodes, Gamma=float(Gamma), M=M, n_basis=n_basis)
    log0 = math.log(float(coupling_start))
    nu, nu_ok, pat_ok = float(coupling_start), None, None
    h = step
    tried = set()
    prev = (None, None)
    info = Bunch(couplings=[], steps=0, failed=0, rounds=0, newton_steps=0, changes=[])
    sol = None
    while info.steps < max_steps:
        info.steps += 1
        modal = ModalBasis(lattice, coupling=nu, period=T)
        ok = False
        for _ in range(6):                         # active-set rounds at this coupling
            first = nu_ok is None               # the start is furthest from its solution
            sol, rounds, nit = _recut_solve(modal, pattern, ctx, PATH_TOL, COARSE_MARGINS,
                                            rounds=12 if first else 6, inner=4)
            info.rounds += rounds
            info.newton_steps += nit
            if sol.status == 5:
                return _finish(sol, lattice, info, nu_ok, start_clock, interrupted=True)
            if not sol.converged:
                break
            new, changes = _diagnose(sol)
            if new is None:
                ok = True
                break
            info.changes += [(nu, text) for text in changes]
            pattern = new
        if ok:
            if nu_ok is not None and nu > nu_ok:
                prev = (pat_ok, nu_ok)
            pat_ok, nu_ok = sol.pattern, nu
            tried.clear()
            info.couplings.append(nu)
            if callback is not None:
                callback(progress_state("discovery", len(info.couplings),
                                        fraction=(math.log(nu) - log0) / -log0, residual=sol.residual,
                                        coupling=nu))
            if nu >= 1.0:
                break
            h = min(1.5 * h, step)
        else:
            info.failed += 1
            if pat_ok is None:
                break
            A = ModalBasis(lattice, coupling=nu_ok, period=T).A
            near = [q for q in _near_triggers(pat_ok, A, _TRIGGER_WINDOW) if q[1:] not in tried]
            if near:
                tried.update(q[1:] for q in near)
                try:
                    pattern = _triggered(pat_ok, near)
                except ValueError as exc:     # no admissible pattern to go on with: the path ends here
                    info.changes.append((nu_ok, f"triggered lift-offs near nodes "
                                                f"{sorted({int(pat_ok.node[c]) for _, c, _, _ in near})} "
                                                f"give no admissible pattern ({exc})"))
                    break
                info.changes += [(nu_ok, f"node {int(pat_ok.node[c])}: lift-off triggered by node "
                                         f"{int(pat_ok.node[k])}'s landing ({d:.1e} away)")
                                 for d, c, k, m in near]
                nu = nu_ok
                continue
            h /= 2
            pattern = pat_ok
            if h < min_step:
                break
        nu = min(1.0, math.exp(math.log(nu_ok) + h))
        pattern = _predict(prev, (pat_ok, nu_ok), nu)
    if nu_ok is None or nu_ok < 1.0:
        return _finish(sol, lattice, info, nu_ok, start_clock)
    # the polish on the default cuts
    modal = ModalBasis(lattice, coupling=1.0, period=T)
    polished, rounds, nit = _recut_solve(modal, pat_ok, ctx, tol, None, rounds=8, inner=8)
    info.rounds += rounds
    info.newton_steps += nit
    if polished.converged:
        new, changes = _diagnose(polished)
        if new is not None:
            polished.converged = polished.success = False
            polished.status = 2
            polished.message = ("the polished orbit fails a pattern check (" + "; ".join(changes)
                                + "); " + polished.message)
        sol = polished
    else:
        sol.message = (f"the polish on the default cuts did not converge ({polished.message}); the fields "
                       f"hold the orbit on the coarse cuts (margins {COARSE_MARGINS}), residual "
                       f"{sol.residual:.1e}")
        sol.converged = sol.success = False
        sol.status = polished.status
    return _finish(sol, lattice, info, nu_ok, start_clock)


def _finish(sol, lattice, info, nu_ok, start_clock, interrupted=False):
    info.reached = 0.0 if nu_ok is None else float(nu_ok)
    info.couplings = np.asarray(info.couplings, dtype=float)
    info.seconds = time.perf_counter() - start_clock
    sol.discovery = info
    sol.lattice = lattice
    sol.spacing = float(lattice.spacing)
    sol.formulation = ("impact-and-stick TPS, pattern discovered by continuation in the coupling from "
                       "the anti-continuum limit (discover_stick_kink)")
    if interrupted:
        sol.message = f"interrupted at coupling {info.reached:.4g}; " + sol.message
    elif info.reached < 1.0:
        sol.converged = sol.success = False
        if sol.status == 0:
            sol.status = 2
        sol.message = (f"the continuation in the coupling stopped at nu = {info.reached:.4g} (last step "
                       f"failed after {info.steps} steps, {info.failed} failed; pattern changes tried: "
                       f"{len(info.changes)}); try a smaller step or a larger coupling_start. "
                       + sol.message)
    sol.checks.all_pass = bool(sol.converged and sol.checks.all_pass)
    return sol
