r"""Stability of limit cycles by the event-driven FDA: :func:`check_stability`.

A limit cycle -- a :class:`~tps_solver.FlatLayer` or a TPS ``PeriodicSolution``
-- is sampled at a section time :math:`t_s` onto a lattice and integrated for
``periods`` periods with :func:`~tps_solver.solvers.fda.simulate`.

What is measured
----------------
* **defects** -- per period, :math:`\max_i|\zeta_i(t_s+(k+1)T)-\zeta_i(t_s+kT)|` and
  the same for :math:`w` (a periodic orbit of the lattice gives round-off).
* **growth factor** -- a random zero-mean perturbation of relative size
  ``perturbation`` is added to :math:`(\underline w, \underline\zeta)` and
  followed next to the reference run; the distance
  :math:`d_k = \max_i\max(|\Delta\zeta_i|, |\Delta w_i|)` at :math:`t_s + kT` is
  fitted by :math:`d_k \propto \rho^k` over the second half of the linear window
  (the periods before :math:`d_k` first exceeds ``saturation``);
  :math:`\rho` is the growth factor per period (< 1: stable).
* **multipliers** (docs/design.md, hazard 7).  The period map is only piecewise smooth: where
  several nodes touch the plate (nearly) together, a perturbation changes the
  *order* of their impacts, and the coupling makes the result depend on that
  order.  Multipliers are therefore reported only where the map is shown to be
  differentiable:

  - the **uniform mode** of a flat layer (all nodes perturbed alike keep hitting
    the plate as one set (54)) is always differentiable; its 2x2 Jacobian is
    obtained by central differences of the lattice period map and its
    eigenvalues must equal :meth:`FlatLayer.floquet_multipliers`;
  - the **full** period-map Jacobian is computed (``jacobian=True``) by forward
    *and* backward differences along every coordinate.  The map is declared
    differentiable only if the two one-sided Jacobians agree to
    ``jacobian_rtol`` (relative to the largest entry); then the eigenvalues of
    their mean are reported (``multipliers_kind = "full period map"``).  If they
    disagree the map has a kink at the orbit; ``differentiable = False`` and only
    the uniform-mode multipliers (flat layers) are reported.

* **verdict** -- ``verdict`` is ``"stable"`` when the measured growth factor is below 1
  and the last defect is below ``defect_tol``, ``"unstable"`` when the growth factor is 1 or
  more, and ``"unknown"`` otherwise, with the reason in ``verdict_reason`` and the message:
  interrupted, or the run does not stay on the orbit (a continuum TPS orbit is not an orbit of
  the lattice: its defect decays while the run settles onto a nearby lattice orbit), or the
  verdict would disagree with the multipliers the orbit carries (a shooting orbit's, an
  impact-and-stick solution's) or with the full period map's (``jacobian=True``).  The growth
  is fitted on the periods above round-off (a perturbation of a strongly contracting orbit
  reaches round-off, or exactly 0 on sticking nodes, within a few periods; fitting there gave
  ``nan`` or a growth of 1 that says nothing).  ``stable`` is ``verdict == "stable"``.  The
  message states the lattice cut-off in force (docs/design.md, hazard 8): a verdict on a lattice with point impacts is a
  verdict for that lattice spacing, not a converged statement.  When a flat layer
  that is stable by its own Floquet multipliers is found "not stable" with point
  impacts, the message *starts* by saying that this is the grid-scale instability
  of point impacts (``grid_instability = True``) and points to the soft contact.

Every periodic result of the package is accepted (``PeriodicSolution``, ``LatticeCycle``,
``ShootingOrbit``, ``StickSolution``; the last three on their own lattice).  Only periodic orbits
are checked: a result with ``converged = False`` is refused
(``ValueError``), since its fields are not a periodic orbit of anything.

Cost and interrupts: ``callback(state)`` receives a
:class:`~tps_solver.core.progress.ProgressState` with ``stage``, ``fraction`` (of the whole check) and ``periods_done``; a
``KeyboardInterrupt`` returns what was measured so far with ``interrupted = True``.
The small dense kernels run on one BLAS thread (:func:`tps_solver.core.costs.blas_threads`).
"""

import math

import numpy as np

from tps_solver.core import archive as io
from tps_solver.core.bunch import Bunch
from tps_solver.core.progress import progress_state
from tps_solver.solvers.shooting.floquet import fit_growth
from tps_solver.solvers.shooting.period_map import PeriodMap
from tps_solver.solvers.shooting.floquet import multipliers as floquet_multipliers
from tps_solver.core.checks import check_choice, check_int, check_positive
from tps_solver.core.costs import blas_threads, check_cost, simulate_cost, small_dense
from tps_solver.solvers.fda import Lattice, flat_state, simulate
from tps_solver.solvers.shooting.soft_monodromy import soft_monodromy

__all__ = ["check_stability", "StabilityResult"]


class StabilityResult(Bunch):
    """Result of :func:`check_stability`.

    Attributes
    ----------
    defects : ndarray of float, shape (periods, 2)
        Per period: max |zeta(t+T) - zeta(t)| and max |w(t+T) - w(t)| on the lattice.
    initial_defect : ndarray of float, shape (2,)
        The same after one period, measured against the sampled limit cycle itself.
    growth_factor : float
        Measured per-period amplification of a small random perturbation.
    growth_history : ndarray of float, shape (periods + 1,)
        Distance between the perturbed and the reference run at each section time.
    growth_window : tuple of int
        First and last period of the fit.
    multipliers : ndarray of complex
        Period-map multipliers where the map is differentiable, by decreasing modulus.
    multipliers_kind : str
        ``"full period map"``, ``"uniform mode"`` or ``"none"``.  With ``method="soft"`` both come
        from the exact monodromy (:class:`~tps_solver.solvers.shooting.soft_monodromy.SoftMonodromy`: matrix
        exponentials and saltation matrices, no finite differences; the message says so).
    uniform_multipliers : ndarray of complex, shape (2,) or (0,)
        Multipliers of the uniform (flat) mode, for flat layers.
    differentiable : bool or None
        Outcome of the one-sided Jacobian test (None if not run).
    stable : bool
        ``verdict == "stable"``.
    verdict : str
        ``"stable"`` (the perturbation decays and the run stays on the orbit), ``"unstable"``
        (the perturbation grows) or ``"unknown"`` (interrupted, the run is not on an orbit of
        this lattice, or the measurement disagrees with the multipliers); never a verdict that
        disagrees with the orbit's own multipliers (``orbit_multipliers``) or with the full
        period map's.
    verdict_reason : str
        Why the verdict is "unknown", or which multipliers it agrees with ('' otherwise).
    orbit_multipliers : ndarray of complex
        The multipliers the checked orbit carries (a shooting orbit, an impact-and-stick
        solution), by decreasing modulus; empty when it carries none.
    message : str
    events_per_period : ndarray of int, shape (periods,)
    sticking_nodes : ndarray of int
        Nodes that stuck to the plate during the last period or are stuck at its end.
    cutoff : dict
        Regularisation length in force.
    cutoff_limited : bool
        True when the verdict depends on the grid: point impacts (whose flat-layer growth
        factor scales like 1/dx), a rule without a declared length, or a lattice spacing
        larger than a quarter of the cut-off length.
    grid_instability : bool
        True when a flat layer that is stable by its Floquet multipliers is found not
        stable with point impacts: the grid-scale instability of the point-impact
        lattice (its growth scales like 1/dx), not a property of the flat layer.
    interrupted : bool
        True when a ``KeyboardInterrupt`` stopped the check; the fields hold what was
        measured so far and ``stable`` is False.
    lattice, method, period, section_time

    Examples
    --------
    A stable flat layer: its uniform-mode multipliers have modulus e (the default model,
    e = 0.45), and point impacts make the verdict hold for this spacing only.

    >>> import numpy as np
    >>> from tps_solver import FlatLayer, check_stability
    >>> chk = check_stability(FlatLayer(Gamma=2.5, M=2, e=0.45), periods=3, n_nodes=4)
    >>> chk.stable, chk.multipliers_kind, np.round(np.abs(chk.uniform_multipliers), 6).tolist()
    (True, 'uniform mode', [0.45, 0.45])
    >>> chk.defects.shape, chk.cutoff_limited, chk.interrupted
    ((3, 2), True, False)
    """

    def save(self, path):
        """Write the result to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return io.save(self, path)


def _is_flat(obj):
    return hasattr(obj, "floquet_multipliers") and hasattr(obj, "W0")


def _section_time(sol, T, n=256):
    """Time in [0, T) at which the smallest height over the nodes is largest."""
    ts = np.linspace(0.0, T, n, endpoint=False)
    zmin = np.min(np.asarray(sol.height(ts)), axis=1)
    return float(ts[int(np.argmax(zmin))])


def _lattice_for_solution(sol, n_nodes, boundary, geometry):
    nodes = np.asarray(sol.nodes, dtype=float)
    if geometry == "planar":
        if n_nodes is None:
            h = np.diff(nodes)
            if np.allclose(h, h[0], rtol=1e-9, atol=0.0):
                return Lattice(nodes, "planar", boundary, grid="uniform")
            n_nodes = nodes.size
        return Lattice.planar(n_nodes=n_nodes, length=nodes[-1] - nodes[0],
                              center=0.5 * (nodes[0] + nodes[-1]), boundary=boundary)
    if geometry == "axisymmetric":
        if n_nodes is None:
            return Lattice(nodes, "axisymmetric", "neumann", grid="custom")
        return Lattice.axisymmetric(n_nodes=n_nodes, r_max=nodes[-1], grid="quasilog")
    raise ValueError(f"solution.geometry must be 'planar' or 'axisymmetric', got {geometry!r}")


def _sample_solution(sol, lattice, t):
    nodes = np.asarray(sol.nodes, dtype=float)
    w = np.asarray(sol.velocity(np.array([t])), dtype=float)[0]
    z = np.asarray(sol.height(np.array([t])), dtype=float)[0]
    if lattice.n_nodes != nodes.size or not np.allclose(lattice.nodes, nodes):
        w = np.interp(lattice.nodes, nodes, w)
        z = np.interp(lattice.nodes, nodes, z)
    return w, z


def _period_map(lattice, Gamma, e, t_s, T, method, kw):
    """The one period map (:class:`~tps_solver.solvers.shooting.period_map.PeriodMap`) of a free orbit."""
    return PeriodMap(lattice, Gamma, e, T, t_s, method=method, require_free=True, **kw)


def _uniform_multipliers(lattice, Gamma, e, w, z, t_s, T, method, kw, h=1e-6, tick=None):
    """Central-difference Jacobian of the period map restricted to uniform states (w, zeta)."""
    pm = _period_map(lattice, Gamma, e, t_s, T, method, kw)
    n = lattice.n_nodes
    J = np.empty((2, 2))
    for col in range(2):
        out = []
        for sign in (1.0, -1.0):
            dw = sign * h if col == 0 else 0.0
            dz = sign * h if col == 1 else 0.0
            y = pm(pm.pack(w + dw, z + dz))[0]
            if tick is not None:
                tick()
            out.append(np.array([np.mean(y[:n]), np.mean(y[n:])]))
        J[:, col] = (out[0] - out[1]) / (2.0 * h)
    return floquet_multipliers(J)


#: Lower bound of the exact method's time per period and squared node count when the contacts are
#: separate (a perturbed flat layer: measured 2.2e-5 to 4.1e-5 s at 201-801 nodes, divided by ten).
_EXACT_SECONDS_PER_NODE2_PERIOD = 2.0e-6
_FLOP_RATE = 5.0e9           # dense flops per second, as in tps_solver.core.costs


def _full_jacobian(lattice, Gamma, e, w, z, t_s, T, method, kw, h, tick=None):
    """One-sided (forward, backward) Jacobians of the period map in (w, zeta), absolute step h
    (perturbed heights clipped at 0)."""
    pm = _period_map(lattice, Gamma, e, t_s, T, method, kw)
    return pm.matrix(pm.pack(w, z), h, scheme="one-sided", relative=False, heights="clip", tick=tick)


#: The perturbation's distance is round-off below this many units of eps times the state's size.
ROUNDOFF = 1e3 * np.finfo(float).eps


def _growth_above_floor(dist, saturation, floor):
    """The growth fit on the periods whose distance is above the round-off ``floor``.

    A strongly contracting orbit (|mu| = 0.03, or a sticking node whose perturbation is erased)
    brings the perturbed run onto the reference within a few periods, after which the distance
    is round-off (or exactly 0): fitting there gives ``nan`` or a growth near 1 that says nothing.
    Returns ``(growth, window, note)``; ``note`` is None when the floor was not reached, and
    ``growth`` is the upper bound ``(floor / d_0)^(1/k)`` when the floor is reached at period 1.
    """
    dist = np.asarray(dist, dtype=float)
    low = np.flatnonzero(~(dist > floor))
    if low.size == 0 or low[0] == 0:
        growth, window = fit_growth(dist, saturation)
        return growth, window, None
    k = int(low[0])
    if k >= 2:
        growth, window = fit_growth(dist[:k], saturation)
        return growth, window, (f"the perturbation reached round-off ({floor:.2g}) after {k} periods; growth "
                                f"fitted on periods {window[0]}..{window[1]} above it")
    bound = float((floor / dist[0]) ** (1.0 / k))
    return bound, (0, k), (f"the perturbation fell below round-off ({floor:.2g}) within one period: growth "
                           f"factor <= {bound:.3g} (an upper bound)")


def _decide(interrupted, ref, growth, defects, final_defect, defect_tol, own, full):
    """The verdict ("stable", "unstable", "unknown") and why, checked against the multipliers.

    ``own``: the multipliers the orbit carries (a shooting orbit's, an impact-and-stick
    solution's); ``full``: those of the full period map measured here.  A verdict that disagrees
    with them is "unknown", and the reason names both.
    """
    if interrupted:
        return "unknown", "interrupted"
    if not ref.success:
        return "unknown", f"the reference run stopped (status {ref.status})"
    if not np.isfinite(growth):
        return "unknown", "no growth factor measured (fewer than two periods below saturation)"
    if growth >= 1.0:
        decided, reason = "unstable", ""
    elif final_defect <= defect_tol:
        decided, reason = "stable", ""
    else:
        first = float(np.max(defects[0])) if defects.size else float("nan")
        settling = defects.shape[0] >= 2 and final_defect < 0.1 * first
        if settling:
            rate = float((final_defect / first) ** (1.0 / (defects.shape[0] - 1)))
            more = int(math.ceil(math.log(defect_tol / final_defect) / math.log(rate))) if rate < 1.0 else -1
            reason = (f"not a periodic orbit of this lattice: the defect falls from {first:.3g} to "
                      f"{final_defect:.3g} (> defect_tol = {defect_tol:g}), by {rate:.3g} per period, while a "
                      f"perturbation decays by {growth:.3g} per period: the run is settling onto a nearby "
                      f"orbit of the lattice" + (f" (about {more} more periods to reach defect_tol)" if more > 0
                                                 else "") + "; solve the orbit on this lattice (solve_lattice, "
                      "solve_lattice_cycle, find_periodic_orbit) for a check without that mismatch")
        else:
            reason = (f"a perturbation decays ({growth:.3g} per period) but the run does not return to the "
                      f"orbit (final defect {final_defect:.3g} > defect_tol = {defect_tol:g})")
        decided = "unknown"
    for name, mu in (("the orbit's multipliers", own), ("the full period map's multipliers", full)):
        if mu is None or decided == "unknown":
            continue
        rho = float(np.max(np.abs(mu)))
        if (rho < 1.0) != (decided == "stable"):
            return "unknown", (f"the measured growth {growth:.3g} per period says {decided}, {name} say "
                               f"max|mu| = {rho:.3g}: they disagree (an impact-order kink of the period map, "
                               "docs/design.md, hazard 7, or a perturbation that missed the leading mode)")
        reason = (reason + "; " if reason else "") + f"agrees with {name}, max|mu| = {rho:.3g}"
    return decided, reason


def check_stability(solution, periods=20, n_nodes=None, method="exact", *, length=8.0,
                    boundary=None, perturbation=1e-8, seed=0, jacobian=False, jacobian_step=1e-7,
                    jacobian_rtol=1e-3, defect_tol=1e-6, saturation=1e-3, impact="point", rho_c=None,
                    cutoff=None, callback=None, **simulate_kw):
    r"""Hand a limit cycle to the FDA and measure its stability (see the module docstring).

    Parameters
    ----------
    solution : FlatLayer or PeriodicSolution
        A flat layer, or a TPS solution (duck-typed: ``geometry``, ``nodes``,
        ``Gamma``, ``e``, ``period``, ``flat``, ``velocity(t)``, ``height(t)``).
        A solution carrying its own ``lattice`` (from
        :func:`~tps_solver.solve_lattice` or :func:`~tps_solver.solve_lattice_cycle`)
        is checked on that lattice unless ``n_nodes`` or another ``boundary`` is given.
    periods : int
        Number of periods integrated, >= 2.
    n_nodes : int, optional
        Lattice size.  Flat layer: default 21.  TPS solution: default the
        solution's own nodes; otherwise the solution is interpolated.
    method : {"exact", "ode", "soft"}
    length : float
        Length of the flat planar lattice (flat layers only).
    boundary : {"neumann", "pinned"}, optional
        Planar boundary; default ``"neumann"`` for flat layers, ``"pinned"`` for kinks.
    perturbation : float
        Size of the random zero-mean perturbation relative to max(1, |w|, zeta), > 0 and below
        ``saturation`` (a larger one is outside the linear regime and is refused).  It must
        exceed the simultaneity window ``time_tol`` times the impact speed by a wide margin, or
        the perturbed contacts are merged into one set and the impact-order effect of hazard 7 of docs/design.md
        is regularised away (a note is added to the message).
    seed : int
        Seed of the perturbation.
    jacobian : bool
        Also compute the full one-sided period-map Jacobians (``4 n_nodes`` extra periods).
    jacobian_step : float
        Finite-difference step of the full Jacobian.
    jacobian_rtol : float
        Agreement required of the one-sided Jacobians for differentiability.
    defect_tol : float
        Largest final periodicity defect accepted for a stable verdict.
    saturation : float
        Distance beyond which the perturbation is no longer small; the growth
        factor is fitted on the periods before it is reached.
    impact, rho_c
        Impact rule passed to :func:`simulate` (the cut-off in force).
    cutoff : float, optional
        Soft-contact length for ``method="soft"`` (required there); a flat layer is then
        compared with the soft model's own flat orbit.
    callback : callable, optional
        ``callback(state)`` during the check, ``state`` a :class:`~tps_solver.core.progress.ProgressState` with ``stage``
        (``"reference"``, ``"perturbed"``, ``"uniform mode"``, ``"jacobian"``), ``fraction``
        (of the whole check, in [0, 1]) and ``periods_done``.
    **simulate_kw
        Further keywords for :func:`simulate` (e.g. ``stick_velocity``, ``rtol``).

    Returns
    -------
    StabilityResult

    Raises
    ------
    ValueError
        For bad input, and for a TPS result that did not converge (not a periodic orbit).

    Examples
    --------
    >>> from tps_solver import FlatLayer
    >>> chk = check_stability(FlatLayer(Gamma=2.5, M=2, e=0.45), periods=4, n_nodes=6)
    >>> bool(abs(chk.uniform_multipliers[0] - FlatLayer(Gamma=2.5, M=2, e=0.45).floquet_multipliers()[0]) < 1e-7)
    True
    """
    periods = check_int(periods, "periods", minimum=2)
    method = check_choice(method, "method", ("exact", "ode", "soft"))
    perturbation = check_positive(perturbation, "perturbation")
    jacobian_step = check_positive(jacobian_step, "jacobian_step")
    jacobian_rtol = check_positive(jacobian_rtol, "jacobian_rtol")
    defect_tol = check_positive(defect_tol, "defect_tol")
    saturation = check_positive(saturation, "saturation")
    if not perturbation < saturation:
        raise ValueError(f"perturbation must be < saturation = {saturation:g} (the distance where the linear "
                         f"regime ends: a larger kick measures a nonlinear response, not the multipliers), got "
                         f"{perturbation!r}; lower perturbation (default 1e-8) or raise saturation")
    if boundary is not None:
        boundary = check_choice(boundary, "boundary", ("neumann", "pinned"))
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable or None, got {type(callback).__name__}")
    kw = dict(simulate_kw, impact=impact, rho_c=rho_c)
    if method == "soft":
        cutoff = check_positive(cutoff, "cutoff") if cutoff is not None else None
        if cutoff is None:
            raise ValueError("cutoff must be a finite number > 0 when method='soft', got None")
        kw = dict(simulate_kw, cutoff=cutoff)
    elif cutoff is not None:
        raise ValueError(f"cutoff is only used with method='soft', got method={method!r}")
    notes = []
    if _is_flat(solution):
        fl = solution
        n = 21 if n_nodes is None else check_int(n_nodes, "n_nodes", minimum=3)
        lattice = Lattice.planar(n_nodes=n, length=check_positive(length, "length"),
                                 boundary=boundary or "neumann")
        Gamma, e, T = fl.Gamma, fl.e, fl.period
        if method == "soft":
            # the soft model's own flat orbit (it differs from (17)-(19) by O(cutoff^2))
            from tps_solver.model.soft_flat import SoftFlatOrbit

            orb = SoftFlatOrbit(fl.Gamma, fl.M, fl.e, cutoff, branch=fl.branch)
            t_s = orb.t_exit + 0.5 * orb.flight
            w_s, z_s = orb.state(t_s)
            w0, z0 = np.full(n, float(w_s)), np.full(n, float(z_s))
        else:
            t_s = fl.t0 + 0.5 * T
            w0, z0 = flat_state(lattice, fl, t_s)
        flat = fl
    elif all(hasattr(solution, a) for a in ("nodes", "velocity", "height", "period")) and (
            hasattr(solution, "geometry") or getattr(solution, "lattice", None) is not None):
        sol = solution
        if not bool(getattr(sol, "converged", True)):
            raise ValueError(
                f"solution must be a periodic orbit, but it did not converge (converged=False, status "
                f"{getattr(sol, 'status', '?')}), so its fields are not a periodic orbit and there is "
                f"nothing to check; converge it first. Its message: {getattr(sol, 'message', '')}")
        if n_nodes is not None:
            n_nodes = check_int(n_nodes, "n_nodes", minimum=3)
        own = getattr(sol, "lattice", None)
        if own is not None and n_nodes is None and boundary in (None, own.boundary):
            lattice = own              # a TPS orbit of this very lattice: no discretisation mismatch
        else:
            lattice = _lattice_for_solution(sol, n_nodes, boundary or "pinned",
                                            getattr(sol, "geometry", None) or own.geometry)
        Gamma, e, T = float(sol.Gamma), float(sol.e), float(sol.period)
        t_s = _section_time(sol, T)
        w0, z0 = _sample_solution(sol, lattice, t_s)
        if np.any(z0 < 0.0):
            notes.append(f"the solution has zeta < 0 at the section time (min {z0.min():.3g}); clipped to 0")
            z0 = np.maximum(z0, 0.0)
        flat = getattr(sol, "flat", None)
    else:
        raise ValueError("solution must be a FlatLayer or a periodic result (PeriodicSolution, LatticeCycle, "
                         "ShootingOrbit, StickSolution: nodes, velocity, height, period and a geometry or a "
                         f"lattice), got {type(solution).__name__}")

    n_cycles = periods * T / (2.0 * math.pi)
    n = lattice.n_nodes
    nbytes, seconds = simulate_cost(n, n_cycles, periods + 1, method=method)
    if method == "exact":
        # the perturbed run separates the contacts: n events per period at O(n) work each at least
        seconds = max(seconds, periods * _EXACT_SECONDS_PER_NODE2_PERIOD * n * n)
    check_cost("check_stability", "periods", periods, 2 * nbytes, 2 * seconds,
               hint=f"two runs of {periods} periods on {n} nodes")
    if jacobian:
        period_seconds = seconds / periods
        jac_seconds = (4 * n + 1) * period_seconds + 10.0 * (2 * n) ** 3 / _FLOP_RATE
        check_cost("check_stability", "n_nodes (with jacobian=True)", n, 2 * nbytes + 4 * 8.0 * (2 * n) ** 2,
                   2 * seconds + jac_seconds,
                   hint=f"the full Jacobian costs 4 n_nodes + 1 = {4 * n + 1} more periods and a dense "
                        f"{2 * n} x {2 * n} eigenproblem; use fewer nodes, or jacobian=False")
    with blas_threads(1, enabled=small_dense(lattice.n_nodes)):
        return _measure(solution, flat, lattice, Gamma, e, T, t_s, w0, z0, periods, method, kw, notes,
                        perturbation, seed, jacobian, jacobian_step, jacobian_rtol, defect_tol,
                        saturation, simulate_kw, callback)


def _measure(solution, flat, lattice, Gamma, e, T, t_s, w0, z0, periods, method, kw, notes, perturbation,
             seed, jacobian, jacobian_step, jacobian_rtol, defect_tol, saturation, simulate_kw, callback):
    """The runs of :func:`check_stability` (reference, perturbed, multipliers) and the verdict."""
    flat_input = _is_flat(solution)
    stages = [("reference", periods), ("perturbed", periods)]
    if flat is not None and flat_input:
        stages.append(("uniform mode", 4))
    if jacobian:
        stages.append(("jacobian", 4 * lattice.n_nodes + 1))
    total = float(sum(p for _, p in stages))
    done = {"periods": 0.0}

    def report(stage, within=0.0):
        if callback is not None:
            at = done["periods"] + within
            callback(progress_state(stage, at, fraction=min(1.0, at / total), periods_done=at))

    def runner(stage, length):
        def cb(progress):
            report(stage, progress.fraction * length)
        return cb if callback is not None else None

    def finish_stage(length):
        done["periods"] += length

    interrupted = False
    t_eval = t_s + T * np.arange(periods + 1)
    ref = simulate(lattice, Gamma, e, w0, z0, t_start=t_s, t_end=t_eval[-1], method=method,
                   t_eval=t_eval, callback=runner("reference", periods), **kw)
    interrupted = ref.status == 5
    Z, W = ref.zeta_eval, ref.w_eval
    k_done = Z.shape[0]
    finish_stage(max(k_done - 1, 0) if interrupted else periods)
    defects = np.column_stack((np.max(np.abs(np.diff(Z, axis=0)), axis=1),
                               np.max(np.abs(np.diff(W, axis=0)), axis=1))) if k_done > 1 else np.empty((0, 2))
    initial_defect = defects[0] if defects.size else np.array([np.nan, np.nan])
    ev = ref.events
    per = np.floor((ev.t - t_s) / T).astype(int) if ev.size else np.empty(0, int)
    events_per_period = np.bincount(per, minlength=periods)[:periods]
    last = ev[per == periods - 1] if ev.size else ev
    sticking = np.union1d(np.unique(last.node[last.kind == "stick"]) if ev.size else [],
                          np.flatnonzero(ref.stuck)).astype(int)

    # growth of a small random zero-mean perturbation
    rng = np.random.default_rng(seed)
    scale = perturbation * max(1.0, float(np.max(np.abs(w0))), float(np.max(z0)))
    dw = rng.standard_normal(lattice.n_nodes)
    dz = rng.standard_normal(lattice.n_nodes)
    dw -= dw.mean()
    dz -= dz.mean()
    dw *= scale / np.max(np.abs(dw))
    dz *= scale / np.max(np.abs(dz))
    window = simulate_kw.get("time_tol") or (1e-12 if method == "exact" else 1e-9)
    if scale < 10.0 * window * max(1.0, float(np.max(np.abs(w0)))):
        notes.append(f"perturbation {scale:.3g} is within 10x of the simultaneity window time_tol = {window:g} "
                     "times the velocity: nearly simultaneous contacts are merged into sets (a time cut-off)")
    if interrupted:
        pert = ref                                   # nothing more is run after an interrupt
    else:
        pert = simulate(lattice, Gamma, e, w0 + dw, np.maximum(z0 + dz, 0.0), t_start=t_s,
                        t_end=t_eval[-1], method=method, t_eval=t_eval, callback=runner("perturbed", periods),
                        **kw)
        interrupted = pert.status == 5
        finish_stage(max(pert.zeta_eval.shape[0] - 1, 0) if interrupted else periods)
    k = min(pert.zeta_eval.shape[0], k_done)
    dist = np.maximum(np.max(np.abs(pert.zeta_eval[:k] - Z[:k]), axis=1),
                      np.max(np.abs(pert.w_eval[:k] - W[:k]), axis=1))
    floor = ROUNDOFF * max(1.0, float(np.max(np.abs(w0))), float(np.max(z0)))
    growth, window, below = _growth_above_floor(dist, saturation, floor)
    if below is not None:
        notes.append(below)
    if window[1] < k - 1 and below is None:
        notes.append(f"the perturbation reached {np.max(dist):.3g} (> saturation {saturation:g}) after "
                     f"{window[1] + 1} periods; growth fitted on periods {window[0]}..{window[1]} only")

    uniform = np.empty(0, complex)
    multipliers, kind, differentiable = np.empty(0, complex), "none", None

    def tick(stage):
        def step():
            finish_stage(1)
            report(stage)
        return step

    lin = None
    if method == "soft" and not interrupted and (jacobian or (flat is not None and flat_input)):
        try:        # the exact linearisation (tps_solver.solvers.shooting.soft_monodromy): no finite differences
            lin = soft_monodromy(lattice, Gamma, e, w0=w0, zeta0=z0, t_start=t_s, period=T, **kw)
            finish_stage(sum(p for name, p in stages if name in ("uniform mode", "jacobian")))
            report("jacobian" if jacobian else "uniform mode")
            notes.append("multipliers from the exact soft monodromy (matrix exponentials and saltation matrices)")
        except KeyboardInterrupt:
            interrupted = True
    if flat is not None and flat_input and not interrupted:
        try:
            uniform = (lin.uniform_multipliers() if lin is not None else
                       _uniform_multipliers(lattice, Gamma, e, w0, z0, t_s, T, method, kw, tick=tick("uniform mode")))
            multipliers, kind = uniform, "uniform mode"
        except KeyboardInterrupt:
            interrupted = True
    Jp = None
    if jacobian and not interrupted:
        try:
            Jp, Jm = ((lin.matrix(), lin.matrix()) if lin is not None else
                      _full_jacobian(lattice, Gamma, e, w0, z0, t_s, T, method, kw, jacobian_step,
                                     tick=tick("jacobian")))
        except KeyboardInterrupt:
            interrupted = True
    if Jp is not None:
        gap = float(np.max(np.abs(Jp - Jm)))
        big = float(np.max(np.abs(Jp) + np.abs(Jm)))
        differentiable = gap <= jacobian_rtol * big
        if differentiable:
            multipliers, kind = floquet_multipliers(0.5 * (Jp + Jm)), "full period map"
        else:
            notes.append(f"period map not differentiable at the orbit: one-sided Jacobians differ by "
                         f"{gap:.3g} (largest entry {big:.3g}); impact order matters (docs/design.md, hazard 7)")

    cutoff = dict(ref.cutoff)
    if cutoff["kind"] == "lattice spacing":
        limited, why = True, ("point impacts: the flat-layer growth factor scales like 1/dx under refinement "
                              "(validation/sections/cutoff.md), so this verdict holds for this spacing only")
    elif cutoff.get("length") is None:
        limited, why = True, "custom impact rule without a declared cut-off length"
    else:
        limited = bool(lattice.spacing > 0.25 * cutoff["length"])
        why = (f"lattice spacing {lattice.spacing:.3g} does not resolve the cut-off {cutoff['length']:.3g} "
               "(need spacing <= cutoff/4)")
    if limited:
        notes.append("verdict is cut-off-limited: " + why)
    final_defect = float(np.max(defects[-1])) if defects.size else float("nan")
    if not ref.success and ref.status != 5:
        notes.insert(0, f"reference run stopped: {ref.message}")
    own = None if flat_input else solution.get("multipliers") if hasattr(solution, "get") else None
    own = None if own is None or len(own) == 0 else np.asarray(own, dtype=complex)
    decided, reason = _decide(interrupted, ref, growth, defects, final_defect, defect_tol, own,
                              multipliers if kind == "full period map" else None)
    stable = decided == "stable"
    grid = bool(decided == "unstable" and flat_input and cutoff["kind"] == "lattice spacing"
                and flat is not None and getattr(flat, "is_stable", False) and ref.success)
    verdict = {"stable": "stable", "unstable": "not stable", "unknown": "stability unknown"}[decided]
    if reason:
        verdict += f" ({reason})"
    if interrupted:
        verdict = (f"interrupted (KeyboardInterrupt) after {done['periods']:.0f} of {total:.0f} periods; "
                   f"no verdict (stable=False only because nothing was decided); the fields hold what "
                   f"was measured so far; measured")
    elif grid:
        mu = float(np.max(np.abs(flat.floquet_multipliers())))
        verdict = (f"not stable, by the grid-scale instability of point impacts, not of the flat layer "
                   f"(its Floquet multipliers have |mu| = {mu:.3g} < 1; the growth of point impacts scales "
                   f"like 1/dx under refinement, docs/design.md, hazard 8); for a verdict that converges "
                   f"under refinement use the soft contact, check_stability(..., method='soft', "
                   f"cutoff=0.3) with lattice spacing <= cutoff/4. Measured: not stable")
    msg = (f"{verdict} on this lattice ({lattice.geometry}, {lattice.n_nodes} nodes, "
           f"cut-off: {cutoff['kind']} = {cutoff['length'] if cutoff['length'] is None else format(cutoff['length'], '.4g')}): "
           f"growth factor {growth:.4g} per period, "
           f"final defect {final_defect:.3g}, {events_per_period[-1] if events_per_period.size else 0} "
           f"events in the last period, {sticking.size} sticking nodes")
    if notes:
        msg += "; " + "; ".join(notes)
    return StabilityResult(
        defects=defects, initial_defect=initial_defect, growth_factor=growth, growth_history=dist,
        growth_window=window,
        multipliers=multipliers, multipliers_kind=kind, uniform_multipliers=uniform,
        differentiable=differentiable, stable=stable, verdict=decided, verdict_reason=reason,
        orbit_multipliers=np.empty(0, complex) if own is None else own, message=msg,
        events_per_period=events_per_period,
        sticking_nodes=sticking, cutoff=cutoff, cutoff_limited=limited, lattice=lattice, method=method, period=T,
        section_time=t_s, periods=periods, success=bool(ref.success), grid_instability=grid,
        interrupted=bool(interrupted))


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_stability(f):
    f.instance("lattice", Lattice)
    periods = f.int("periods", minimum=2)
    f.array("defects", "f", shape=(None, 2))
    f.array("multipliers", "c", ndim=1)
    growth = f.float("growth_factor", finite=False)
    stable, success = f.bool("stable"), f.bool("success")
    if stable and not (success and growth < 1.0):
        f.fail(f"inconsistent: stable = True with growth factor {growth!r} and success = {success}")
    f.array("events_per_period", "iu", shape=(periods,))


io.register("StabilityResult", StabilityResult, validate=_validate_stability)
