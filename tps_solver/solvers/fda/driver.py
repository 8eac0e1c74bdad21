r"""The event-driven FDA: :func:`simulate`, the one driver loop for every method, eqs. (51)-(54).

:data:`METHODS` maps a method name to its :class:`~.base.Integrator`.  The
loop alternates between the integrator's :meth:`~.base.Integrator.advance`
(propagate to the next event) and, for the impulsive methods, the shared event
layer of :mod:`.events` (impacts (54), sticking, lift-off).
"""
import math

import numpy as np

from tps_solver.core.checks import check_array, check_choice, check_int, check_nonnegative, check_positive, check_restitution
from tps_solver.core.bunch import Bunch
from tps_solver.core.progress import progress_state
from tps_solver.core.checks import check_state_scale
from tps_solver.core.costs import blas_threads, check_cost, simulate_cost, small_dense
from tps_solver.operators.lattice import Lattice
from tps_solver.solvers.fda.common import SimulationResult, check_time_window, stack_samples
from tps_solver.model.restitution import as_restitution
from tps_solver.solvers.fda.events import EventLog, apply_contacts, apply_liftoff, make_impact_rule, pulled_off
from tps_solver.solvers.fda.exact import ExactPropagator
from tps_solver.solvers.fda.ode import OdePropagator
from tps_solver.solvers.fda.point import PointIntegrator
from tps_solver.solvers.fda.soft import SoftIntegrator
from tps_solver.solvers.fda.soft_radau import RadauSoftIntegrator

__all__ = ["simulate", "METHODS"]

#: method name -> :class:`~.base.Integrator` subclass
METHODS = {"exact": ExactPropagator, "point": PointIntegrator, "ode": OdePropagator,
           "soft": SoftIntegrator, "soft-radau": RadauSoftIntegrator}


def simulate(lattice, Gamma, e, w0, zeta0, t_start=0.0, t_end=None, method="exact", *,
             stuck0=None, impact="point", rho_c=None, stick_velocity=None,
             max_events_per_cycle=None, t_eval=None, callback=None, record_segments=False, **options):
    r"""Integrate the FDA (53) with impacts (54), sticking and lift-off.

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
        Plate acceleration, > 0.
    e : float or RestitutionLaw
        Restitution in [0, 1), or a speed-dependent law (:mod:`tps_solver.model.restitution`),
        evaluated at each landing's impact speed (impulsive methods only).  An impact slower
        than ``stick_velocity`` ends at rest; with a law whose e tends to 1 at low speed that
        drops a chatter tail of duration ``law.chatter_tail(stick_velocity, |g|)[0]`` (about
        8e-6 for the viscoelastic law with b = 5 at |g| = 1, 6e-5 with b = 0.6; of order 1 for
        Bizon's power law, whose e tends to 1 like 1 - c v^(3/4); the lift-off is unaffected).
    w0, zeta0 : array_like of float, shape (n_nodes,)
        Initial velocity and height (``zeta0 >= 0`` for the impulsive methods; a soft
        contact may start compressed, ``zeta0 < 0``).
    t_start, t_end : float
        Time interval, ``t_end > t_start``.
    method : str
        A key of :data:`METHODS`.  ``"exact"``: modal closed form (55)-(56) with a
        certified contact search; ``"ode"``: the paper's Method (2), a scipy
        ``OdeSolver`` stepped by hand with vectorised sign-change detection on its
        dense output; ``"soft"``: the soft contact of cut-off length ``cutoff``.
    stuck0 : array_like of bool, shape (n_nodes,), optional
        Impulsive methods: nodes initially stuck (they must have ``w0 = zeta0 = 0``).
    impact : {"point", "diffused"} or callable
        Impulsive methods: the impact rule, see :mod:`.events`; ``"diffused"`` needs ``rho_c``.
    rho_c : float, optional
        Length of the diffused Stosslet (67), > 0.
    stick_velocity : float, optional
        Impulsive methods: impact speeds at or below this turn into sticking
        (chatter; docs/design.md, hazard 4).  Default 1e-6.
    max_events_per_cycle : int, optional
        Event bound per forcing cycle :math:`2\pi`; default ``100 * n_nodes``.
    t_eval : array_like of float, optional
        Output times in ``[t_start, t_end]``.
    callback : callable, optional
        ``callback(state)`` once per forcing cycle :math:`2\pi` of simulated time and at the
        end, ``state`` a :class:`~tps_solver.core.progress.ProgressState` (stage ``"simulate"``, ``iteration`` the forcing
        cycles done, ``fraction`` of the interval done, ``t``, ``t_start``, ``t_end``,
        ``n_events``).  A
        ``KeyboardInterrupt`` returns ``status=5`` with the state reached.
    record_segments : bool, keyword-only
        Keep the state after every event set (and at ``t_start``) in ``segments``: between two
        records the motion is one smooth flow with a fixed contact set, so the record is the
        exact dense output of an impulsive run (:class:`~tps_solver.solvers.fda.dense.PiecewiseFlow`
        evaluates it).  Default False (``segments`` is None).
    **options
        Options of the chosen method (an option that does not apply to it raises
        ``ValueError`` naming it):

        * ``"exact"`` (:class:`~.exact.ExactPropagator`): ``time_tol`` (simultaneity window of a
          contact set, default 1e-12), ``max_steps``, ``cache_size``, ``modes`` (``"runs"``, the
          default: the free set decomposed run by run, closed-form modes on uniform planar
          lattices, see :mod:`.runs`; ``"free_set"``: one dense eigendecomposition per free set,
          the reference), ``compiled`` (compiled kernels of the run path; default: with numba);
        * ``"point"`` (:class:`~.point.PointIntegrator`): the same model and options as
          ``"exact"``, with the modal amplitudes carried across events by rank-k updates
          (2-3x faster; the same events);
        * ``"ode"`` (:class:`~.ode.OdePropagator`): ``time_tol`` (default 1e-9), ``rtol``,
          ``atol`` (default 1e-12), ``ode_solver`` (a scipy ``OdeSolver`` with dense output,
          default ``"DOP853"``), ``samples_per_step`` (default 8);
        * ``"soft"`` (:class:`~.soft.SoftIntegrator`): ``cutoff`` (required: the physical
          cut-off length of the soft contact, see :mod:`tps_solver.model.soft_flat`; its results
          converge under grid refinement at fixed ``cutoff``), ``rtol``, ``atol``, ``stages``,
          ``stick_speed`` (the sticking rule of docs/design.md, hazard 10), ``time_tol``,
          ``max_step``, ``max_events``: Radau IIA collocation with O(n) tridiagonal stage
          solves and located switches, about 60x faster than the reference;
        * ``"soft-radau"`` (:class:`~.soft_radau.RadauSoftIntegrator`): the same model without
          a sticking rule by scipy's Radau, the reference: ``cutoff``, ``rtol`` (floored at
          1e-10), ``atol``, ``max_step``.

    Returns
    -------
    SimulationResult

    Notes
    -----
    On lattices of at most :data:`tps_solver.core.costs.SMALL_DENSE` nodes the integration runs
    with one BLAS thread (:func:`tps_solver.core.costs.blas_threads`, through threadpoolctl when it
    is installed): the dense kernels are small and a second thread only costs (measured on a
    2-core machine: the 200-node radial flat-layer benchmark, 0.018 s per period on one thread
    against 0.036 s on two; see :mod:`tps_solver.core.costs`).

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver import FlatLayer
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> t0 = fl.t0 + 1.0
    >>> run = simulate(lat, 2.5, 0.45, np.full(5, fl.velocity(t0)), np.full(5, fl.height(t0)),
    ...                t_start=t0, t_end=t0 + fl.period)
    >>> bool(np.allclose(run.zeta, fl.height(t0), atol=1e-12))
    True
    """
    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    method = check_choice(method, "method", tuple(METHODS))
    cls = METHODS[method]
    Gamma = check_positive(Gamma, "Gamma")
    law = as_restitution(e)
    e = check_restitution(law.e, "e") if law.constant else law
    if not law.constant and not cls.impulsive:
        raise ValueError(f"e must be a constant restitution with method={method!r} (the soft contact's "
                         f"restitution is a property of its damped oscillator, not of the impact speed), "
                         f"got {law!r}; use method='point' or 'exact' for a speed-dependent law")
    n = lattice.n_nodes
    w = check_array(w0, "w0", shape=(n,))
    zeta = check_array(zeta0, "zeta0", shape=(n,))
    check_state_scale(w, "w0")
    check_state_scale(zeta, "zeta0")
    t_start, t_end, t_eval = check_time_window(t_start, t_end, t_eval)
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable or None, got {type(callback).__name__}")
    if max_events_per_cycle is None:
        max_events_per_cycle = 100 * n
    max_events_per_cycle = check_int(max_events_per_cycle, "max_events_per_cycle", minimum=1)
    rule, cutoff = None, None
    if cls.impulsive:
        if np.any(zeta < 0.0):
            raise ValueError("zeta0 must be >= 0 at every node (the layer cannot be below the plate)")
        if stuck0 is None:
            stuck = np.zeros(n, dtype=bool)
        else:
            stuck = check_array(stuck0, "stuck0", shape=(n,), dtype=bool)
            if np.any(w[stuck] != 0.0) or np.any(zeta[stuck] != 0.0):
                raise ValueError("stuck0 nodes must have w0 = zeta0 = 0")
        stick_velocity = check_nonnegative(1e-6 if stick_velocity is None else stick_velocity,
                                           "stick_velocity")
        rule, cutoff = make_impact_rule(impact, rho_c)
        if cutoff["length"] is None and cutoff["kind"] == "lattice spacing":
            cutoff["length"] = lattice.spacing
        if "cutoff" in options:
            raise ValueError(f"cutoff is only used with method='soft', got cutoff={options['cutoff']!r} "
                             f"with method={method!r}")
    else:
        if not (isinstance(impact, str) and impact == "point"):
            raise ValueError(f"impact must be 'point' with method={method!r} (the soft contact replaces "
                             f"the impact rule), got {impact!r}")
        for name, value in (("rho_c", rho_c), ("stuck0", stuck0), ("stick_velocity", stick_velocity)):
            if value is not None:
                raise ValueError(f"{name} does not apply to method={method!r} (the soft contact resolves "
                                 f"contacts itself), got {name}={value!r}")
        stuck = zeta < 0.0
    if not cls.impulsive and "cutoff" in options and options["cutoff"] is not None:
        tau_c = float(options["cutoff"]) ** 2
        resolution = 1e3 * np.finfo(float).eps * max(abs(t_start), abs(t_end), 2.0 * math.pi)
        if not tau_c > resolution:
            raise ValueError(
                f"cutoff = {options['cutoff']!r} gives a contact of duration tau_c = cutoff**2 = {tau_c:.3g}, "
                f"below the time resolution 1e3 eps max|t| = {resolution:.3g} of this run (the contacts "
                f"could not be resolved); use cutoff > {math.sqrt(resolution):.3g}")
    n_cycles = (t_end - t_start) / (2.0 * math.pi)
    check_cost("simulate", "t_end", t_end, *simulate_cost(n, n_cycles, 0 if t_eval is None else len(t_eval),
                                                          method=method, record_segments=bool(record_segments)),
               hint=f"{n_cycles:.3g} forcing cycles on {n} nodes with method={method!r}"
                    + (" and record_segments=True" if record_segments else "") + "; simulate fewer periods")
    with blas_threads(1, enabled=small_dense(n)):
        return _integrate(cls, lattice, Gamma, e, w, zeta, stuck, t_start, t_end, t_eval, method, options,
                          cutoff, rule, stick_velocity, max_events_per_cycle, callback,
                          bool(record_segments))


def _integrate(cls, lattice, Gamma, e, w, zeta, stuck, t_start, t_end, t_eval, method, options, cutoff,
               rule, stick_velocity, max_events_per_cycle, callback, record=False):
    """The one driver loop (see :func:`simulate`)."""
    n = lattice.n_nodes
    prop = cls(lattice, Gamma, e, **options)
    pull_kernel = getattr(prop, "pulled_off_kernel", None)         # compiled pulled_off, or None: numpy
    if not cls.impulsive:
        cutoff = {"kind": "soft contact", "length": float(prop.options["cutoff"]),
                  "tau_c": float(prop.options["cutoff"]) ** 2}

    log = EventLog(t_start, max_events_per_cycle)
    samples = [(t_start, w.copy(), zeta.copy())] if t_eval.size and t_eval[0] == t_start else []
    records = [(t_start, w.copy(), zeta.copy(), np.array(stuck, dtype=bool))] if record else None
    n_logged = 0
    t = t_start
    status, message = 0, "reached t_end"
    next_report = t_start + 2.0 * math.pi
    try:
        while t < t_end:
            try:
                step = prop.advance(t, w, zeta, stuck, t_end, t_eval)
            except RuntimeError as exc:
                status, message = 3, f"contact search stalled: {exc}"
                break
            t, w, zeta = step.t, step.w, step.zeta
            samples.extend(step.samples)
            if cls.impulsive:
                contact, liftoff = step.contact, step.liftoff
                if contact.size:
                    apply_contacts(t, w, zeta, stuck, contact, lattice, Gamma, e, rule, stick_velocity, log)
                    # with no stuck node (before or after the set) there is nothing to pull off and
                    # ``liftoff`` (a subset of the stuck nodes) is empty
                    if np.count_nonzero(stuck):
                        pulled = pulled_off(t, w, stuck, lattice, Gamma, kernel=pull_kernel)
                        if pulled.size or liftoff.size > 1:
                            liftoff = np.union1d(liftoff, pulled)
                if liftoff.size:
                    liftoff = liftoff[stuck[liftoff]]
                    apply_liftoff(t, w, zeta, stuck, liftoff, log)
            else:
                stuck = step.stuck
                for rec in step.events:
                    log.add(rec[0], rec[1], rec[2], rec[3])
            if record and len(log) != n_logged:
                n_logged = len(log)
                records.append((t, w.copy(), zeta.copy(), np.array(stuck, dtype=bool)))
            if log.exceeded:
                status = 6
                message = (f"event bound exceeded: more than {max_events_per_cycle} events in the forcing "
                           f"cycle containing t = {t:.12g} (chattering or Zeno behaviour); state so far "
                           "returned")
                break
            if callback is not None and t >= next_report:
                next_report = t_start + 2.0 * math.pi * (math.floor((t - t_start) / (2.0 * math.pi)) + 1)
                callback(_progress(t, t_start, t_end, log))
    except KeyboardInterrupt:
        status, message = 5, f"interrupted at t = {t:.12g} (KeyboardInterrupt); the state so far is returned"
    if callback is not None:
        callback(_progress(t, t_start, t_end, log))
    events = log.to_array()
    te, we, ze = stack_samples(samples, n)
    return SimulationResult(
        t=float(t), w=w, zeta=zeta, stuck=np.array(stuck, dtype=bool), events=events,
        n_events=int(events.size), success=status == 0, status=status, message=message, t_eval=te,
        w_eval=we, zeta_eval=ze, cutoff=cutoff, method=method, n_steps=int(prop.n_steps),
        lattice=lattice, Gamma=Gamma, e=e, segments=_segments(records, n))


def _segments(records, n):
    """The ``segments`` record of a run (None when not recorded)."""
    if records is None:
        return None
    return Bunch(t=np.array([r[0] for r in records]), w=np.array([r[1] for r in records]).reshape(-1, n),
                 zeta=np.array([r[2] for r in records]).reshape(-1, n),
                 stuck=np.array([r[3] for r in records]).reshape(-1, n))


def _progress(t, t_start, t_end, log):
    return progress_state("simulate", int((t - t_start) // (2.0 * math.pi)),
                          fraction=float(min(1.0, (t - t_start) / (t_end - t_start))), t=float(t),
                          t_start=t_start, t_end=t_end, n_events=len(log))
