r"""The event-driven FDA: :func:`simulate` and :class:`SimulationResult`, eqs. (51)-(54).

The run alternates between an integrator's search for the next event
(:class:`~.exact.ExactPropagator` or :class:`~.ode.OdePropagator`) and the
shared event layer (:mod:`.events`).
"""

import numpy as np

from .._result import Bunch
from .._validation import (check_array, check_choice, check_int, check_nonnegative, check_positive,
                           check_real, check_restitution)
from .events import EventLog, apply_contacts, apply_liftoff, make_impact_rule, pulled_off
from .exact import ExactPropagator
from .lattice import Lattice
from .ode import OdePropagator

__all__ = ["simulate", "SimulationResult"]

METHODS = ("exact", "ode", "soft")


class SimulationResult(Bunch):
    """Result of :func:`simulate`.

    Attributes
    ----------
    t : float
        Final time (``t_end``, or the time the run stopped).
    w, zeta : ndarray of float, shape (n_nodes,)
        Final state.
    stuck : ndarray of bool, shape (n_nodes,)
        Nodes stuck to the plate at ``t``.
    events : numpy.recarray
        Time-ordered records with fields ``t``, ``node``, ``kind``
        (``"impact"``, ``"stick"``, ``"liftoff"``) and ``w_before``.
    n_events : int
    success : bool
    status : int
        0: reached ``t_end``; 2: event bound exceeded (chattering); 3: contact search stalled.
    message : str
    t_eval : ndarray of float, shape (k,)
    w_eval, zeta_eval : ndarray of float, shape (k, n_nodes)
        States at the requested output times (pre-event values at event instants).
    cutoff : dict
        The regularisation length in force (hazard 8): ``{"kind", "length"}``.
    method : str
    n_steps : int
        Search steps (exact) or solver steps (ode).
    """


def check_time_window(t_start, t_end, t_eval):
    """Validate the integration interval and the output times; returns them as floats/array."""
    t_start = check_real(t_start, "t_start")
    if t_end is None:
        raise ValueError("t_end must be given (a finite number > t_start)")
    t_end = check_real(t_end, "t_end")
    if t_end <= t_start:
        raise ValueError(f"t_end must be > t_start = {t_start}, got {t_end}")
    if t_eval is None:
        return t_start, t_end, np.empty(0)
    t_eval = np.sort(check_array(t_eval, "t_eval", ndim=1))
    if t_eval.size and (t_eval[0] < t_start or t_eval[-1] > t_end):
        raise ValueError(f"t_eval must lie in [t_start, t_end] = [{t_start}, {t_end}]")
    return t_start, t_end, t_eval


def stack_samples(samples, n):
    """Stack ``(t, w, zeta)`` output samples into arrays of shapes (k,), (k, n), (k, n)."""
    if not samples:
        return np.empty(0), np.empty((0, n)), np.empty((0, n))
    return (np.array([s[0] for s in samples]), np.array([s[1] for s in samples]),
            np.array([s[2] for s in samples]))


def _check_state(value, name, n):
    return check_array(value, name, shape=(n,))


def simulate(lattice, Gamma, e, w0, zeta0, t_start=0.0, t_end=None, method="exact", *,
             stuck0=None, impact="point", rho_c=None, stick_velocity=1e-6,
             max_events_per_cycle=None, t_eval=None, time_tol=None,
             rtol=1e-12, atol=1e-12, ode_solver="DOP853", samples_per_step=8, cutoff=None):
    r"""Integrate the FDA (53) with impacts (54), sticking and lift-off.

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in [0, 1).
    w0, zeta0 : array_like of float, shape (n_nodes,)
        Initial velocity and height (``zeta0 >= 0``).
    t_start, t_end : float
        Time interval, ``t_end > t_start``.
    method : {"exact", "ode", "soft"}
        ``"exact"``: modal closed form (55)-(56) with a certified contact
        search; ``"ode"``: the paper's Method (2), a scipy ``OdeSolver``
        stepped by hand with vectorised sign-change detection on its dense output.
    stuck0 : array_like of bool, shape (n_nodes,), optional
        Nodes initially stuck (they must have ``w0 = zeta0 = 0``).
    impact : {"point", "diffused"} or callable
        Impact rule, see :mod:`.events`; ``"diffused"`` needs ``rho_c``.
    rho_c : float, optional
        Length of the diffused Stosslet (67), > 0.
    stick_velocity : float
        Impact speeds at or below this turn into sticking (chatter, hazard 4).
    max_events_per_cycle : int, optional
        Event bound per forcing cycle :math:`2\pi`; default ``100 * n_nodes``.
    t_eval : array_like of float, optional
        Output times in ``[t_start, t_end]``.
    time_tol : float, optional
        Simultaneity window of a contact set; default ``1e-12`` (exact), ``1e-9`` (ode).
    rtol, atol : float
        Tolerances of the ODE solver (``method="ode"``).
    ode_solver : str
        Name of a scipy ``OdeSolver`` with dense output (``"DOP853"``, ``"RK45"``, ``"Radau"``, ...).
    samples_per_step : int
        Dense-output samples per solver step for the sign-change scan (``method="ode"``).
    cutoff : float, optional
        Physical cut-off length of the soft contact (``method="soft"``, required there):
        :func:`~tps_solver.fda.regularised.simulate_soft`, the regularised impact model of
        issue 6 whose results converge under grid refinement at fixed ``cutoff``.  Its stiff
        integrator runs with ``max(rtol, 1e-10)``.

    Returns
    -------
    SimulationResult

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
    if method == "soft":
        if cutoff is None:
            raise ValueError("cutoff must be a finite number > 0 when method='soft', got None")
        if impact != "point":
            raise ValueError(f"impact must be 'point' with method='soft' (the soft contact replaces the "
                             f"impact rule), got {impact!r}")
        from .regularised import simulate_soft

        return simulate_soft(lattice, Gamma, e, w0, zeta0, t_start, t_end, cutoff=check_positive(cutoff, "cutoff"),
                             t_eval=t_eval, rtol=max(rtol, 1e-10), atol=atol)
    if cutoff is not None:
        raise ValueError(f"cutoff is only used with method='soft', got cutoff={cutoff!r} with method={method!r}")
    Gamma = check_positive(Gamma, "Gamma")
    e = check_restitution(e, "e")
    n = lattice.n_nodes
    w = _check_state(w0, "w0", n)
    zeta = _check_state(zeta0, "zeta0", n)
    if np.any(zeta < 0.0):
        raise ValueError("zeta0 must be >= 0 at every node (the layer cannot be below the plate)")
    t_start, t_end, t_eval = check_time_window(t_start, t_end, t_eval)
    method = check_choice(method, "method", METHODS)
    if stuck0 is None:
        stuck = np.zeros(n, dtype=bool)
    else:
        stuck = check_array(stuck0, "stuck0", shape=(n,), dtype=bool)
        if np.any(w[stuck] != 0.0) or np.any(zeta[stuck] != 0.0):
            raise ValueError("stuck0 nodes must have w0 = zeta0 = 0")
    stick_velocity = check_nonnegative(stick_velocity, "stick_velocity")
    if max_events_per_cycle is None:
        max_events_per_cycle = 100 * n
    max_events_per_cycle = check_int(max_events_per_cycle, "max_events_per_cycle", minimum=1)
    rule, cutoff = make_impact_rule(impact, rho_c)
    if cutoff["length"] is None and cutoff["kind"] == "lattice spacing":
        cutoff["length"] = lattice.spacing
    if time_tol is None:
        time_tol = 1e-12 if method == "exact" else 1e-9
    time_tol = check_positive(time_tol, "time_tol")
    if method == "exact":
        prop = ExactPropagator(lattice, Gamma, time_tol=time_tol)
    else:
        prop = OdePropagator(lattice, Gamma, time_tol=time_tol, rtol=check_positive(rtol, "rtol"),
                             atol=check_positive(atol, "atol"), solver=ode_solver,
                             samples=check_int(samples_per_step, "samples_per_step", minimum=2))

    log = EventLog(t_start, max_events_per_cycle)
    samples = [(t_start, w.copy(), zeta.copy())] if t_eval.size and t_eval[0] == t_start else []
    t = t_start
    status, message = 0, "reached t_end"
    while t < t_end:
        try:
            t, w, zeta, contact, liftoff, got = prop.advance(t, w, zeta, stuck, t_end, t_eval)
        except RuntimeError as exc:
            status, message = 3, f"contact search stalled: {exc}"
            break
        samples.extend(got)
        if contact.size:
            apply_contacts(t, w, zeta, stuck, contact, lattice, Gamma, e, rule, stick_velocity, log)
            liftoff = np.union1d(liftoff, pulled_off(t, w, stuck, lattice, Gamma))
        if liftoff.size:
            liftoff = liftoff[stuck[liftoff]]
            apply_liftoff(t, w, zeta, stuck, liftoff, log)
        if log.exceeded:
            status = 2
            message = (f"event bound exceeded: more than {max_events_per_cycle} events in the forcing "
                       f"cycle containing t = {t:.12g} (chattering or Zeno behaviour); state so far returned")
            break
    events = log.to_array()
    te, we, ze = stack_samples(samples, n)
    return SimulationResult(
        t=float(t), w=w, zeta=zeta, stuck=stuck.copy(), events=events, n_events=int(events.size),
        success=status == 0, status=status, message=message, t_eval=te, w_eval=we, zeta_eval=ze,
        cutoff=cutoff, method=method, n_steps=int(prop.n_steps), lattice=lattice, Gamma=Gamma, e=e)
