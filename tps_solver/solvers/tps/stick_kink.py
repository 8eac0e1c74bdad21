r"""The completely inelastic (e = 0) kink on a lattice: one call from the far field to a checked orbit.

:func:`solve_stick_kink` is what :func:`tps_solver.solve_kink` does for ``e = 0``, where every
node lands, sticks, lifts off and touches again each period (the single-contact TPS does not
apply).  Pipeline, each stage reported in the result:

1. the kink start of :func:`tps_solver.solvers.fda.kink_state` (the sticking flat orbit for
   x < 0, the same half a period later for x > 0, a linear transition of width 2) at a
   quarter period after the far field's lift-off, settled by ``periods`` periods of the
   exact FDA;
2. shooting: on a mirror-symmetric lattice first Newton on the mirrored half-period map
   (:func:`tps_solver.solvers.shooting.symmetric.solve_mirrored`: the kink centred on the lattice's
   mirror point, in a few steps), then the FDA period map (:func:`tps_solver.find_periodic_orbit`),
   which also gives the Floquet multipliers (:mod:`tps_solver.solvers.shooting.floquet`);
3. the impact-and-stick TPS (:func:`tps_solver.solve_stick_lattice`) on the contact pattern
   of the shooting orbit: contact and lift-off times to Newton accuracy, the spectral
   reaction on every stick, the physical checks;
4. the FDA started on the TPS orbit for ``fda_periods`` periods: the largest distance of its
   events from the TPS's contact and lift-off times and the state defect after the run.

With ``start="anticontinuum"`` stages 1-2 are replaced by the TPS's own discovery of the
pattern (:mod:`tps_solver.solvers.tps.stick_discovery`: continuation in the lattice coupling
from uncoupled nodes; no time stepping, no shooting), and the period map at the found orbit
gives the multipliers.  A pattern-free space-time complementarity Newton was tried too and
does not reach the kink (``validation/spacetime_discovery.py``).

The lattice spacing is the model's cut-off: pointwise impacts along a tilted landing front
are ill-posed on the continuum (docs/design.md, hazard 3), so the orbit belongs to its
lattice, and the result names it (``spacing``).
"""
import time

import numpy as np

from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_int, check_positive
from tps_solver.core.orbit import far_field
from tps_solver.core.progress import ProgressState, progress_state
from tps_solver.core.costs import DISCOVERY_SECONDS_PER_NODE3, check_cost, period_map_seconds, shooting_maps
from tps_solver.model.flat import FlatLayer
from tps_solver.operators.lattice import Lattice
from tps_solver.solvers.fda import kink_state, oscillon_state, simulate
from tps_solver.solvers.shooting.periodic import find_periodic_orbit
from tps_solver.solvers.shooting.symmetric import mirror_symmetric, solve_mirrored
from tps_solver.solvers.tps.stick import StickSolution, solve_stick_lattice
from tps_solver.solvers.tps.stick_pattern import check_with_fda, pattern_from_fda

__all__ = ["solve_stick_kink", "solve_stick_oscillon", "DEFAULT_LENGTH", "DEFAULT_SPACING", "FDA_TOL"]

#: Default lattice: spacing 1 on [-20, 20] (41 nodes).  Front widths at Gamma = 4.1 measured
#: with one definition (validation/tps_stick.py, FRONT_WIDTH) change by < 0.03 between
#: dx = 1, 0.5 and 0.25, not monotonically (pinning), so dx = 1 is converged to about 0.03.
DEFAULT_SPACING = 1.0
DEFAULT_LENGTH = 40.0

#: The FDA check passes when its events stay within this of the TPS's times (and the state too).
FDA_TOL = 1e-8


def _default_lattice(spacing, length):
    n = int(round(length / spacing)) + 1
    return Lattice.planar(n_nodes=n, length=length)


def solve_stick_kink(Gamma=4.1, M=2, *, lattice=None, periods=10, max_iter=80, fda_periods=10,
                     n_basis=8, tol=1e-10, start="shooting", callback=None):
    r"""The e = 0 kink on a planar lattice, checked by the FDA (module docstring).

    Parameters
    ----------
    Gamma : float
        Plate acceleration; the sticking f/2 far field exists for 3.857 <= Gamma <= 6.362.
    M : int
        Even period order, T = 2 pi M (default 2).
    lattice : tps_solver.Lattice, optional
        Planar Neumann lattice with the front at x = 0.  Default: spacing
        :data:`DEFAULT_SPACING` on a length of :data:`DEFAULT_LENGTH` (41 nodes).
    periods : int
        FDA periods that settle the start before shooting, >= 0.
    max_iter : int
        Newton steps of the shooting (the front is nearly neutral: 33 at Gamma = 4.1, dx = 1).
    fda_periods : int
        Periods of the FDA check, >= 1.
    n_basis : int
        Legendre terms of the reaction per stick segment of the TPS.
    tol : float
        Residual target of the TPS.
    start : {"shooting", "anticontinuum"}
        Where the contact pattern comes from: stages 1-2 above (default), or the TPS itself,
        :func:`~tps_solver.solvers.tps.stick_discovery.discover_stick_kink` (continuation in the
        coupling from the uncoupled nodes; no time stepping, no shooting; the bond-centred
        kink with the front after node ``n_nodes // 2 - 1``).  The multipliers are then those of
        the FDA period map at the TPS orbit (:func:`tps_solver.find_periodic_orbit` started on
        it, which takes no Newton step when the orbit is accurate).  Slower on these lattices:
        7 s for 6 nodes, 36 s for 10 (validation/stick_discovery.py).
    callback : callable, optional
        ``callback(state)`` at the start of every stage -- ``"settle"``, ``"shooting"``,
        ``"multipliers"``, ``"tps"``, ``"checks"`` (``state.stage``) -- and within them: once per
        forcing cycle of the settling run, after every Newton step of the shooting and of the TPS
        (with ``start="anticontinuum"``: after every coupling of the path); the inner call's own
        stage is ``state.substage``.  A ``KeyboardInterrupt`` (Ctrl-C, or raised by the callback)
        in any stage returns ``status = 5`` with the state so far: ``run`` (the settling run),
        ``orbit`` (the shooting orbit), ``multipliers``, the TPS fields once the TPS has run, and
        ``interrupted_stage``.

    Returns
    -------
    StickSolution
        A :class:`~tps_solver.core.orbit.PeriodicOrbit` with its contact ``pattern`` and, in
        addition, ``formulation`` (str), ``spacing`` (float, the lattice's cut-off),
        ``orbit`` (the shooting orbit), ``multipliers`` (ndarray of complex, the shooting
        orbit's Floquet multipliers, largest modulus first; None if shooting failed),
        ``fda_check`` (Bunch: ``periods``, ``contact_error``, ``liftoff_error``,
        ``state_defect``, ``passed``), ``localized`` (False when the orbit is uniform: the
        front left the lattice), ``core_nodes`` (tuple of int: nodes on the shifted phase at
        the start and after the settling run) and ``seconds`` (Bunch of the stages'
        wall-clock times).  ``checks.all_pass`` is False unless the TPS converged, its
        physical checks pass, the FDA check passes and the orbit is localized.  An orbit that
        converged to the uniform flat layer is not the kink asked for: ``converged`` False and
        ``status = 9``.  ``far_field_stable`` (bool) and ``far_field_multipliers`` state whether
        the far field is stable (:func:`~tps_solver.core.orbit.far_field`).

    Raises
    ------
    ValueError
        For a lattice that is not planar with Neumann ends, odd ``M``, or a ``Gamma`` at
        which the sticking f/2 flat orbit does not exist.

    Examples
    --------
    A coarse lattice (dx = 8; the default dx = 1 takes about a minute):

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    >>> sol = solve_stick_kink(4.1, lattice=lat, periods=4, fda_periods=3)
    >>> sol.converged, sol.checks.all_pass, sol.fda_check.passed, sol.spacing
    (True, True, True, 8.0)
    >>> round(float(abs(sol.multipliers[0])), 3)
    0.031
    """
    M, periods, fda_periods, max_iter = _check_common(Gamma, M, periods, fda_periods, max_iter)
    if lattice is None:
        lattice = _default_lattice(DEFAULT_SPACING, DEFAULT_LENGTH)
    if not isinstance(lattice, Lattice) or lattice.geometry != "planar" or lattice.boundary != "neumann":
        raise ValueError("lattice must be a planar tps.Lattice with Neumann ends, e.g. "
                         "tps.Lattice.planar(n_nodes=41, length=40.0)")
    flat = _far_field(Gamma, M)
    _check_reach("solve_kink", lattice, flat, periods, fda_periods, start)
    if start == "anticontinuum":
        return _discovered(lattice, flat, max_iter, fda_periods, n_basis, tol, callback)
    if start != "shooting":
        raise ValueError(f"start must be 'shooting' or 'anticontinuum', got {start!r}")
    t_start = float(flat.t0 + 0.25 * flat.period)
    w0, z0 = kink_state(lattice, flat, t_start, width=2.0)
    return _pipeline(lattice, flat, w0, z0, t_start, "kink", periods, max_iter, fda_periods, n_basis, tol,
                     callback)


def solve_stick_oscillon(Gamma=4.1, M=2, *, lattice=None, core_radius=10.0, periods=10, max_iter=80,
                         fda_periods=10, n_basis=8, tol=1e-10, callback=None):
    r"""The e = 0 oscillon on an axisymmetric lattice, or the statement that none was found.

    The pipeline of :func:`solve_stick_kink` from the start of
    :func:`tps_solver.solvers.fda.oscillon_state` (the far field's sticking orbit half a period
    later inside ``core_radius``, a transition of width 2).  Time stepping shows e = 0 cores
    shrinking on resolved lattices; when the core is gone after the settling run or the orbit
    found is uniform, the result says so: ``localized`` False, ``checks.all_pass`` False, and the
    message gives the core's node count before and after the settling run.

    Parameters
    ----------
    Gamma, M, periods, max_iter, fda_periods, n_basis, tol, callback
        As in :func:`solve_stick_kink`.
    lattice : tps_solver.Lattice, optional
        Axisymmetric lattice.  Default: uniform spacing 1 up to r = 40 (41 nodes).
    core_radius : float
        Radius of the phase-shifted core of the start, inside the lattice.

    Returns
    -------
    StickSolution
        As :func:`solve_stick_kink`'s, with ``localized`` (bool) and ``core_nodes`` (nodes on the
        core's phase at the start and after the settling run).

    Raises
    ------
    ValueError
        As :func:`solve_stick_kink`, and for a ``core_radius`` outside the lattice.

    Examples
    --------
    On a very coarse lattice (dr = 8) the lattice pins a core of radius 12:

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform")
    >>> sol = solve_stick_oscillon(4.1, lattice=lat, core_radius=12.0, periods=6, fda_periods=3)
    >>> sol.converged, sol.localized, sol.checks.all_pass, sol.core_nodes
    (True, True, True, (2, 2))
    """
    M, periods, fda_periods, max_iter = _check_common(Gamma, M, periods, fda_periods, max_iter)
    if lattice is None:
        lattice = Lattice.axisymmetric(n_nodes=41, r_max=40.0, grid="uniform")
    if not isinstance(lattice, Lattice) or lattice.geometry != "axisymmetric":
        raise ValueError("lattice must be an axisymmetric tps.Lattice, e.g. "
                         "tps.Lattice.axisymmetric(n_nodes=41, r_max=40.0, grid='uniform')")
    core_radius = check_positive(core_radius, "core_radius")
    r_max = float(lattice.nodes[-1])
    if core_radius >= r_max:
        raise ValueError(f"core_radius must lie inside the lattice, 0 < core_radius < {r_max:g}, got {core_radius!r}")
    flat = _far_field(Gamma, M)
    _check_reach("solve_oscillon", lattice, flat, periods, fda_periods, "shooting")
    t_start = float(flat.t0 + 0.25 * flat.period)
    w0, z0 = oscillon_state(lattice, flat, t_start, r_core=core_radius, width=2.0)
    return _pipeline(lattice, flat, w0, z0, t_start, "oscillon", periods, max_iter, fda_periods, n_basis,
                     tol, callback)


def _check_reach(what, lattice, flat, periods, fda_periods, start):
    """Refuse, before any work, a lattice out of reach: by shooting, the settling and checking
    periods and one Newton step of period maps (separate contacts, O(n**2) each); from the
    anticontinuum limit, the discovery's measured O(n**3) pace."""
    n = lattice.n_nodes
    if start == "anticontinuum":
        seconds = DISCOVERY_SECONDS_PER_NODE3 * float(n) ** 3
        hint = "the TPS's discovery from the anticontinuum limit grows as n_nodes**3 at least"
    else:
        maps = shooting_maps(n)
        seconds = (periods + fda_periods + maps) * period_map_seconds(n, flat.period, "exact", 0.0)
        hint = (f"{periods} settling and {fda_periods} checking periods and one Newton step of {maps} period "
                "maps, O(n_nodes**2) each")
    check_cost(what, "lattice.n_nodes", n, 1e6 + 16.0 * (4 * n) ** 2, seconds,
               hint=hint + "; use a coarser lattice")


def _check_common(Gamma, M, periods, fda_periods, max_iter):
    M = check_int(M, "M", minimum=2)
    if M % 2:
        raise ValueError(f"M must be even for a kink or an oscillon, got {M}")
    check_positive(Gamma, "Gamma")
    return (M, check_int(periods, "periods", minimum=0), check_int(fda_periods, "fda_periods", minimum=1),
            check_int(max_iter, "max_iter", minimum=0))


def _far_field(Gamma, M):
    try:
        return FlatLayer(Gamma, M, e=0.0, pattern="stick")
    except ValueError as exc:
        raise ValueError(f"Gamma = {Gamma:g} has no sticking flat orbit of period 2 pi M = {2 * M} pi "
                         f"at e = 0 ({exc}); the f/2 one exists for 3.857 <= Gamma <= 6.362") from None


def _shifted_nodes(flat, t, w, zeta):
    """Nodes whose state (w, zeta) at time t is nearer the far field half a period later than now."""
    a = np.hypot(w - flat.velocity(t), zeta - flat.height(t))
    b = np.hypot(w - flat.velocity(t + 0.5 * flat.period), zeta - flat.height(t + 0.5 * flat.period))
    return int(np.count_nonzero(b < a))


def _uniform(sol, n_samples=64, rel=1e-3):
    """Whether the orbit is the same at the two ends of the lattice over the period (no front left)."""
    ts = sol.period * np.arange(n_samples) / n_samples
    Z = np.asarray(sol.height(ts))
    return bool(np.max(np.abs(Z[:, 0] - Z[:, -1])) <= rel * max(float(np.max(np.abs(Z))), 1e-300))


class _Interrupted(Exception):
    """A stage of the pipeline was interrupted; carries the stage's name."""

    def __init__(self, stage):
        super().__init__(stage)
        self.stage = stage


def _staged(callback, stage):
    """``callback`` with every state relabelled ``stage`` (the inner call's own stage kept as ``substage``)."""
    if callback is None:
        return None

    def relabel(state):
        callback(ProgressState(dict(state, stage=stage, substage=state.get("stage"))))
    return relabel


def _announce(callback, stage):
    """Tell the callback that ``stage`` starts (a KeyboardInterrupt raised there stops the call)."""
    if callback is not None:
        callback(progress_state(stage, 0))


def _multipliers_at(lattice, flat, guess, t_start, max_iter, callback, section="auto"):
    """The multipliers stage: the FDA period map at an orbit (no Newton step when it is accurate)."""
    _announce(callback, "multipliers")
    orbit = find_periodic_orbit(lattice, Gamma=flat.Gamma, M=flat.M, e=0.0, guess=guess, t_start=t_start,
                                method="exact", max_iter=max_iter, section=section,
                                callback=_staged(callback, "multipliers"))
    if orbit.status == 5:
        raise _Interrupted("multipliers")
    return orbit


def _stopped(stage, lattice, flat, what, state, seconds, clock):
    """Status 5: the state so far (settling run, shooting orbit, TPS iterate, FDA check)."""
    sol = state.get("sol")
    if sol is None:
        n = lattice.n_nodes            # no TPS fields yet: empty ones, so the result saves and loads
        sol = StickSolution(nodes=np.asarray(lattice.nodes, float).copy(), lattice=lattice, Gamma=flat.Gamma,
                            e=0.0, M=flat.M, period=flat.period, flat=flat, nit=0, residual=np.nan,
                            residual_history=np.empty(0), checks=Bunch(all_pass=False),
                            contact_times=np.empty((n, 0)), contact_kinds=np.empty((n, 0), dtype="<U6"),
                            liftoff_times=np.empty((n, 0)), impulses=np.empty((n, 0)),
                            w_hat=np.empty((0, n), dtype=complex), K=0)
    orbit = state.get("orbit")
    mu = state.get("multipliers")
    done = [name for name in ("settle", "shooting", "multipliers", "tps", "checks") if name in state["done"]]
    sol.update(converged=False, success=False, status=5, interrupted_stage=stage, orbit=orbit,
               run=state.get("run"), multipliers=mu, spacing=float(lattice.spacing), localized=False,
               core_nodes=state.get("core", ()))
    if "fda_check" not in sol or stage == "checks":
        sol.fda_check = Bunch(periods=0, contact_error=np.nan, liftoff_error=np.nan, state_defect=np.nan,
                              passed=False)
    sol.checks = sol.get("checks") or Bunch()
    sol.checks.localized = False
    sol.checks.all_pass = False
    seconds.total = time.perf_counter() - clock
    sol.seconds = seconds
    kept = ", ".join(f"{k} ({v})" for k, v in (("settling run", "run"), ("shooting orbit", "orbit"),
                                                  ("multipliers", "multipliers"), ("TPS iterate", "fields"))
                     if (k == "TPS iterate" and state.get("sol") is not None) or
                     (k != "TPS iterate" and state.get(v) is not None))
    sol.message = (f"interrupted (KeyboardInterrupt) in the {stage} stage of the e = 0 {what}; stages done: "
                   f"{', '.join(done) or 'none'}; kept: {kept or 'nothing yet'}. "
                   + (sol.get("message") or ""))
    return sol


def _discovered(lattice, flat, max_iter, fda_periods, n_basis, tol, callback):
    """The kink found by the TPS itself, its multipliers from the period map at it, the FDA check."""
    clock = time.perf_counter()
    seconds = Bunch(settle=0.0)
    state = {"done": set()}
    try:
        return _discovered_stages(lattice, flat, max_iter, fda_periods, n_basis, tol, callback, state,
                                  seconds, clock)
    except _Interrupted as stop:
        return _stopped(stop.stage, lattice, flat, "kink", state, seconds, clock)


def _discovered_stages(lattice, flat, max_iter, fda_periods, n_basis, tol, callback, state, seconds, clock):
    from tps_solver.solvers.tps.stick_discovery import discover_stick_kink

    try:
        _announce(callback, "tps")
        cb = _staged(callback, "tps")
        sol = discover_stick_kink(lattice, flat.Gamma, flat.M, tol=tol, n_basis=n_basis, callback=cb)
    except KeyboardInterrupt:
        raise _Interrupted("tps") from None
    seconds.tps = time.perf_counter() - clock
    if sol.status == 5:
        state["sol"] = sol
        raise _Interrupted("tps")
    state["sol"] = sol
    state["done"].add("tps")
    tick = time.perf_counter()
    orbit, note = None, ""
    if sol.converged:
        # the section: the time (on a grid) at which every node is highest above the plate
        ts = sol.period * np.arange(256) / 256
        t_s = float(ts[int(np.argmax(np.min(sol.height(ts), axis=1)))])
        w_s, z_s = sol.velocity([t_s])[0], np.maximum(sol.height([t_s])[0], 0.0)
        try:
            orbit = _multipliers_at(lattice, flat, (w_s, z_s), t_s, max_iter, callback)
        except KeyboardInterrupt:
            raise _Interrupted("multipliers") from None
        state["orbit"] = orbit
        if not orbit.converged:
            note = f"the period map at the TPS orbit did not converge ({orbit.message}); "
    seconds.shooting = time.perf_counter() - tick
    sol.orbit = orbit
    sol.multipliers = orbit.multipliers if orbit is not None and orbit.converged else None
    state["multipliers"] = sol.multipliers
    state["done"].add("multipliers")
    if sol.multipliers is None and sol.converged:
        sol.converged = sol.success = False
        sol.status = 2
    return _checked(sol, lattice, "kink", fda_periods, (), seconds, note, clock, callback=callback,
                    state=state)


def _pipeline(lattice, flat, w0, z0, t_start, what, periods, max_iter, fda_periods, n_basis, tol, callback):
    clock = time.perf_counter()
    seconds = Bunch()
    state = {"done": set()}
    try:
        return _stages(lattice, flat, w0, z0, t_start, what, periods, max_iter, fda_periods, n_basis, tol,
                       callback, state, seconds, clock)
    except _Interrupted as stop:
        return _stopped(stop.stage, lattice, flat, what, state, seconds, clock)


def _stages(lattice, flat, w0, z0, t_start, what, periods, max_iter, fda_periods, n_basis, tol, callback, state,
            seconds, clock):
    Gamma, M, T = flat.Gamma, flat.M, flat.period
    tick = time.perf_counter()
    guess, t_guess, run = (w0, z0), t_start, None
    core = (_shifted_nodes(flat, t_start, w0, z0),)
    state["core"] = core
    try:
        _announce(callback, "settle")
        if periods:
            run = simulate(lattice, Gamma, 0.0, w0, z0, t_start=t_start, t_end=t_start + periods * T,
                           method="exact", callback=_staged(callback, "settle"))
            state["run"] = run
            if run.status == 5:
                raise _Interrupted("settle")
            if run.success:
                guess, t_guess = run, None
                core += (_shifted_nodes(flat, run.t, run.w, run.zeta),)
                state["core"] = core
    except KeyboardInterrupt:
        raise _Interrupted("settle") from None
    state["done"].add("settle")
    seconds.settle = time.perf_counter() - tick
    tick = time.perf_counter()
    sym_note, sym_nit = "", None
    try:
        _announce(callback, "shooting")
        if what == "kink" and mirror_symmetric(lattice):
            # the kink as a fixed point of the mirrored half-period map (no creeping along the front's
            # near-neutral translation), then the period map (0 steps)
            if t_guess is None:
                w_s, z_s, st_s, t_s = run.w, run.zeta, np.asarray(run.stuck, bool), float(run.t)
            else:
                w_s, z_s, st_s, t_s = w0, z0, np.zeros(lattice.n_nodes, bool), t_start
            found, why, _ = solve_mirrored(lattice, Gamma, 0.0, T, t_s, w_s, z_s, st_s, max_iter=max_iter,
                                           callback=callback)
            if found is not None:
                guess, t_guess, sym_nit = found[:3], t_s, found[3]
                sym_note = f"mirrored half-period Newton: {found[3]} steps; "
            else:
                sym_note = why
        orbit = find_periodic_orbit(lattice, Gamma=Gamma, M=M, e=0.0, guess=guess, t_start=t_guess,
                                    method="exact", max_iter=max_iter, multipliers=False, callback=callback)
    except KeyboardInterrupt:
        raise _Interrupted("shooting") from None
    orbit.symmetric_nit = sym_nit
    if sym_note:
        orbit.message = sym_note + orbit.message
    state["orbit"] = orbit
    if orbit.status == 5:
        raise _Interrupted("shooting")
    state["done"].add("shooting")
    if orbit.converged:
        # the multipliers stage: the period map at the converged orbit (0 Newton steps)
        try:
            with_mu = _multipliers_at(lattice, flat, orbit, None, max_iter, callback, section="fixed")
        except KeyboardInterrupt:
            raise _Interrupted("multipliers") from None
        if with_mu.converged:
            with_mu.symmetric_nit = sym_nit
            with_mu.message = orbit.message + f"; multipliers from the period map at it ({with_mu.message})"
            orbit = with_mu
            state["orbit"] = orbit
            state["multipliers"] = orbit.multipliers
        state["done"].add("multipliers")
    seconds.shooting = time.perf_counter() - tick
    tick = time.perf_counter()
    note = ""
    pattern = orbit
    if not orbit.converged:
        note = f"shooting did not converge ({orbit.message}); "
        if run is not None:
            try:
                pattern = pattern_from_fda(run, lattice, T)
                note += "the TPS started on the pattern of the settling run. "
            except ValueError:
                note += "the TPS started on the pattern of the last shooting iterate. "
    try:
        _announce(callback, "tps")
        sol = solve_stick_lattice(lattice, Gamma, M, 0.0, pattern=pattern, n_basis=n_basis, tol=tol,
                                  refresh=0, callback=_staged(callback, "tps"))
    except KeyboardInterrupt:
        raise _Interrupted("tps") from None
    state["sol"] = sol
    if sol.status == 5:
        raise _Interrupted("tps")
    state["done"].add("tps")
    seconds.tps = time.perf_counter() - tick
    sol.orbit = orbit
    sol.multipliers = orbit.multipliers if orbit.converged else None
    sol.formulation = ("impact-and-stick TPS (solve_stick_lattice) on the contact pattern of a shooting "
                       "orbit (find_periodic_orbit after FDA settling)")
    moved = (f"; nodes on the shifted phase: {core[0]} at the start, {core[-1]} after {periods} "
             "settling periods" if len(core) > 1 else "")
    return _checked(sol, lattice, what, fda_periods, core, seconds, note, clock, moved, callback=callback,
                    state=state)


def _checked(sol, lattice, what, fda_periods, core, seconds, note, clock, moved="", callback=None, state=None):
    """The FDA check of a TPS orbit (stage 4), localisation, timings and the summary flags.

    An orbit that converged to the uniform flat layer is not the kink or oscillon asked for:
    ``converged`` False, status 9.
    """
    tick = time.perf_counter()
    sol.spacing = float(lattice.spacing)
    sol.flat = sol.get("flat") or _far_field(sol.Gamma, sol.M)
    sol.far_field_stable, sol.far_field_multipliers, far_note = far_field(sol.flat)
    note = far_note + note
    sol.localized = bool(sol.converged) and not _uniform(sol)
    sol.core_nodes = core
    if sol.converged:
        try:
            _announce(callback, "checks")
            chk = check_with_fda(sol, periods=fda_periods)
        except KeyboardInterrupt:
            raise _Interrupted("checks") from None
        if chk.run.status == 5:
            raise _Interrupted("checks")
        t_end = chk.run.t
        defect = max(float(np.max(np.abs(chk.run.w - sol.velocity([t_end])[0]))),
                     float(np.max(np.abs(chk.run.zeta - np.maximum(sol.height([t_end])[0], 0.0)))))
        passed = bool(chk.run.status == 0 and max(chk.contact_error, chk.liftoff_error, defect) <= FDA_TOL)
        sol.fda_check = Bunch(periods=fda_periods, contact_error=float(chk.contact_error),
                              liftoff_error=float(chk.liftoff_error), state_defect=defect, passed=passed)
        if not passed:
            note += (f"the FDA started on the TPS orbit leaves it (event error "
                     f"{max(chk.contact_error, chk.liftoff_error):.2e}, state defect {defect:.2e} after "
                     f"{fda_periods} periods, tolerance {FDA_TOL:g}). ")
        if not sol.localized:
            note += (f"no {what} found: the orbit is uniform (the flat layer), the phase-shifted region "
                     f"did not survive{moved}; converged = False, status 9 (not the orbit asked for). ")
            sol.converged = sol.success = False
            sol.status = 9
    else:
        sol.fda_check = Bunch(periods=0, contact_error=np.nan, liftoff_error=np.nan, state_defect=np.nan,
                              passed=False)
    if state is not None:
        state["done"].add("checks")
    seconds.fda_check = time.perf_counter() - tick
    seconds.total = time.perf_counter() - clock
    sol.seconds = seconds
    sol.checks.localized = sol.localized
    sol.checks.all_pass = bool(sol.converged and sol.checks.all_pass and sol.fda_check.passed and sol.localized)
    if note:
        sol.message = note + sol.message
    return sol
