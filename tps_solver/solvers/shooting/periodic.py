r"""Periodic orbits of any contact pattern by Newton--Krylov shooting: :func:`find_periodic_orbit`.

The FDA (53) with impacts (54), sticking and lift-off -- or the soft contact of
cut-off length :math:`\ell` -- defines a period map

.. math::  P:\ (\underline w, \underline\zeta)(t_s) \mapsto (\underline w, \underline\zeta)(t_s + T),
           \qquad T = 2\pi M ,

evaluated by :func:`~tps_solver.simulate`.  The forcing :math:`g(t) = \sin t - 1/\Gamma`
fixes the phase, so a periodic orbit is a root of :math:`F(x) = P(x) - x` with no
phase condition.  Nothing is assumed about the contact pattern: several contacts
per node and period, touch-and-go contacts and sticking intervals are whatever the
time stepper does between :math:`t_s` and :math:`t_s + T`.

Unknowns and section
--------------------
:math:`x = (\underline w, \underline\zeta)` of the nodes that are *free* at the
section :math:`t_s`; nodes stuck to the plate there have :math:`w = \zeta = 0` and are
no unknowns (their multipliers are 0).  The section is moved (``section="auto"``) to
the time within one period of the guess that has the fewest stuck nodes and the
largest distance to every event, so that small changes of the state do not move an
event across it.

Newton--GMRES
-------------
Each Newton step solves :math:`(J - I)\,\delta = -F` by GMRES (modified Gram--Schmidt
Arnoldi, no restart) with the matrix-free product
:math:`Jv \approx [P(x + hv) - P(x)]/h`, :math:`h\,\|v\|_\infty = ` ``fd_step``
:math:`\cdot\max(1, \|x\|_\infty)`, followed by a backtracking line search on
:math:`\|F\|_2`.  The soft contact (piecewise linear) uses the exact product instead: matrix
exponentials between switches and saltation matrices at them
(:class:`~tps_solver.solvers.shooting.soft_monodromy.SoftMonodromy`, one period map per Newton step for the
switch sequence); its multipliers come from the same product (``multipliers_kind``
``"all (exact)"`` / ``"leading (exact)"``), not from differences.
A multiplier 0 (sticking erases a direction) is harmless:
:math:`I - J` stays invertible.  A multiplier near 1 (the front position of a kink,
a nearly neutral translation) makes :math:`I - J` ill-conditioned: the Newton step
along that mode is the residual divided by :math:`1 - \mu`, far outside the range where
the map is linear, and the line search shortens it (factors 0.1--0.3) until the
iterate reaches the quadratic regime -- tens of steps for a kink whose front mode has
:math:`\mu \approx 0.999`.  GMRES itself still converges in a few products (the rest
of the spectrum is clustered near 0).  The result reports the neutral multiplier
(``neutral``) and the step lengths taken.

Floquet multipliers
-------------------
Eigenvalues of the monodromy :math:`J = \partial P/\partial x` at the converged orbit:
all of them from a central-difference Jacobian when there are at most ``dense_max``
unknowns, otherwise the ``n_multipliers`` leading ones as Ritz values of an Arnoldi
factorisation of fixed dimension with the matrix-free product (no implicit restarts:
the cost is known in advance, whereas restarts to a tolerance have no useful bound
when the spectrum is clustered near 0 and the products carry finite-difference noise).  A kink
centred on a mirror-symmetric lattice is a fixed point of the mirrored half-period map
:math:`G = S\circ P_{T/2}` as well, and :math:`DP_T = DG^2` there: its multipliers are the
squares of DG's eigenvalues, from central differences of G (two half periods a product, as
much as one one-sided product of P and about 100 times more accurate) and an Arnoldi
factorisation that stops when the leading ones have converged
(:func:`~tps_solver.solvers.shooting.symmetric.mirrored_multipliers`; ``multiplier_map``).  With point impacts
the map is only piecewise smooth where several nodes touch the plate (nearly)
together: the post-impact state depends on the order of the impacts
(docs/design.md, hazard 7).  Before computing multipliers, forward and backward
differences along random directions are compared; if they disagree the result says
so, ``multipliers`` is empty, and the stability is measured instead by the growth of a
small random perturbation over ``growth_periods`` periods (as
:func:`~tps_solver.check_stability` does).
"""
import math
import time

import numpy as np

from tps_solver.core import archive
from tps_solver.core.orbit import STATUS, PeriodicOrbit
from tps_solver.core.checks import check_array, check_bool, check_choice, check_int, check_positive, check_real, check_restitution
from tps_solver.core.costs import check_cost, period_map_seconds, shooting_maps
from tps_solver.model.restitution import as_restitution
from tps_solver.core.newton import newton
from tps_solver.core.progress import progress_state
from tps_solver.solvers.shooting.period_map import PeriodMap, PeriodMapError
from tps_solver.solvers.shooting.soft_monodromy import SoftMonodromy
from tps_solver.solvers.fda.dense import PiecewiseFlow
from tps_solver.solvers.shooting.floquet import fit_growth, multipliers as floquet_multipliers, ritz_multipliers
from tps_solver.solvers.shooting.symmetric import MirroredHalfPeriodMap, mirror_symmetric, mirrored_multipliers

__all__ = ["find_periodic_orbit", "ShootingOrbit"]




class ShootingOrbit(PeriodicOrbit):
    r"""Result of :func:`find_periodic_orbit`: a periodic orbit of the FDA, any contact pattern.

    A :class:`~tps_solver.core.orbit.PeriodicOrbit`; its ``velocity`` and ``height`` integrate the
    orbit from its state at ``t_start``.

    Attributes
    ----------
    converged, success : bool
    status : int
        A code of :data:`tps_solver.core.orbit.STATUS`: 0 converged; 1 iteration limit; 2 Newton
        stagnated (line search failed); 3 the period map failed (contact search stalled / stiff
        solver failed); 5 interrupted (KeyboardInterrupt); 6 event bound exceeded
        (``max_events_per_period``); 7 converged on the free nodes but a node stuck at the
        section is free after one period.
    status_text : str
    message : str
        What happened and, if not converged, what to try.
    residual : float
        :math:`\max|P(x) - x|` at the returned state.
    residual_history : ndarray of float, shape (nit + 1,)
    step_lengths, gmres_residuals : ndarray of float, shape (nit,)
        Per Newton step: the accepted line-search factor (0: none accepted) and the relative
        residual GMRES reached.
    gmres_products : ndarray of int, shape (nit,)
        Jacobian--vector products (period maps) of each GMRES solve.
    nit : int
        Newton steps taken.
    n_period_maps : int
        Period maps evaluated (the cost unit: one :func:`~tps_solver.simulate` run over T).
    w0, zeta0 : ndarray of float, shape (n_nodes,)
        A state on the orbit at ``t_start`` (the last iterate if not converged).
    stuck0 : ndarray of bool, shape (n_nodes,)
        Nodes stuck to the plate at ``t_start`` (``w0 = zeta0 = 0`` there).
    t_start : float
        Section time.
    period : float
        :math:`T = 2\pi M`.
    multipliers : ndarray of complex
        Leading Floquet multipliers by decreasing modulus; empty where undefined (not
        converged, not computed, or the map is not differentiable at the orbit).  They are
        those of the free coordinates at the section; each node stuck there adds two
        multipliers 0, which are not listed.
    multipliers_kind : str
        ``"all (dense)"``, ``"leading (Arnoldi)"`` or ``"none"``; the reason is in ``message``.
        Soft contact: ``"all (exact)"`` or ``"leading (exact)"`` -- the product of matrix
        exponentials and saltation matrices of :class:`~tps_solver.solvers.shooting.soft_monodromy.SoftMonodromy`
        (ARPACK for the leading ones), no finite differences; Newton uses its exact product too.
    multipliers_map : str
        Which map they come from: ``"mirrored"`` (the squares of the eigenvalues of the mirrored
        half-period map :math:`G = S\circ P_{T/2}`, a kink centred on a mirror-symmetric
        lattice's mirror point; ``multiplier_map`` of :func:`find_periodic_orbit`), ``"period"``
        (the period map) or ``"none"``.
    half_period_multipliers : ndarray of complex
        ``"mirrored"`` only: the eigenvalues :math:`\lambda` of :math:`DG` whose squares are
        ``multipliers`` (same order); the front's translation has :math:`\lambda \approx -1`.
    multiplier_periods : float
        Periods of the FDA spent on the multipliers (the differentiability test included).
    multiplier_time : float
        Wall-clock seconds of that stage.
    multiplier_residuals : ndarray of float or None
        Arnoldi only: Ritz residual estimates of the reported multipliers (of :math:`\lambda`
        for ``"mirrored"``).
    arnoldi_dim : int
        Arnoldi only: Krylov dimension used (period maps spent on the multipliers).
    differentiable : bool or None
        Outcome of the one-sided difference test (None: not run).
    growth_factor : float
        Per-period growth of a small random perturbation (measured when the map is not
        differentiable, NaN otherwise).
    neutral : bool
        A multiplier within ``neutral_tol`` of 1 (e.g. the front position of a kink).
    contacts_per_node : ndarray of int, shape (n_nodes,)
        Contacts (impacts, and landings that end in sticking) per node in one period.
    contact_times : list of ndarray of float
        Per node, the contact instants in ``[t_start, t_start + T)``.
    sticking_intervals : list of (int, float, float)
        ``(node, t_stick, t_liftoff)`` within ``[t_start, t_start + T]``; an interval
        that contains the section is cut there.  Soft contact: the contact intervals
        (entry, entry + contact time).
    events : numpy.recarray
        The events of one period from ``t_start`` (see :class:`~tps_solver.SimulationResult`).
    segments : Bunch or None
        Impulsive methods: the state after every event set of that period (``t``, ``w``,
        ``zeta``, ``stuck``), from which ``velocity`` and ``height`` are evaluated exactly.
    events_per_period : int
    simultaneous_contacts : bool
        Two contacts at different nodes closer in time than ``simultaneity``.
    lattice, Gamma, M, e, method, cutoff, time

    Examples
    --------
    >>> import numpy as np, tps_solver as tps
    >>> coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    >>> cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    >>> orb = tps.find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=cyc, multipliers=False)
    >>> isinstance(orb, ShootingOrbit), orb.status, orb.multipliers_kind
    (True, 0, 'none')
    >>> z = orb.height(orb.t_start + orb.period * np.arange(4) / 4)     # shape (4, n_nodes)
    >>> z.shape, bool(np.max(np.abs(orb.height(orb.t_start + orb.period) - orb.zeta0)) < 1e-10)
    ((4, 8), True)
    >>> bool(abs(orb.t0 - orb.flat.t0) == 0.0), type(orb.flat).__name__
    (True, 'FlatLayer')
    """

    @property
    def nodes(self):
        """Node coordinates, shape (n_nodes,)."""
        return self.lattice.nodes

    @property
    def contacts(self):
        """The contact pattern of the stored period (:class:`~tps_solver.core.pattern.ContactPattern`).

        Read from ``events`` (impulsive methods): impacts that end at rest are ``"stick"``
        with their lift-off (``"triggered"`` where a lattice neighbour lands at that instant),
        the other impacts ``"bounce"`` (e > 0) or ``"touch"`` (e = 0).
        """
        from tps_solver.solvers.fda.patterns import pattern_from_events

        if self.method == "soft":
            raise AttributeError("the contact pattern of a soft-contact orbit is its contact intervals "
                                 "(sticking_intervals); contacts needs an impulsive method")
        return pattern_from_events(self.events, self.lattice, self.period, self.t_start, stuck0=self.stuck0,
                                   e=self.e)

    @property
    def tc(self):
        """Contact time of each node, shape (n_nodes,), for a single-contact orbit (else ValueError)."""
        return self.contacts.tc

    @property
    def geometry(self):
        """Geometry of the lattice."""
        return self.lattice.geometry

    @property
    def flat(self):
        """The far-field flat layer: :class:`~tps_solver.FlatLayer` with point impacts (e = 0: the
        impact-and-stick orbit), :class:`~tps_solver.SoftFlatOrbit` with the soft contact."""
        from tps_solver.model.flat import FlatLayer
        from tps_solver.model.soft_flat import SoftFlatOrbit

        if self.method == "soft":
            return SoftFlatOrbit(self.Gamma, self.M, self.e, self.cutoff)
        return FlatLayer(self.Gamma, self.M, e=self.e)

    @property
    def t0(self):
        """Launch phase of the far-field flat layer (the exit phase ``t_exit`` for the soft contact)."""
        flat = self.flat
        return float(flat.t_exit if self.method == "soft" else flat.t0)

    def _sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        tau = np.mod(t - self.t_start, self.period)
        segments = self.get("segments")
        if segments is not None and self.method != "soft":
            # exact dense output of the stored period (no time stepping)
            flow = PiecewiseFlow(self.lattice, self.Gamma, segments, self.t_start + self.period)
            return flow(self.t_start + tau)
        from tps_solver.solvers.fda import simulate

        # soft contact (or no stored period): integrate the period from the state at t_start,
        # one sample per distinct phase (simulate wants strictly increasing output times)
        phases, where = np.unique(tau, return_inverse=True)
        kw = dict(self._sim_kw)
        if self.method != "soft":
            kw["stuck0"] = self.stuck0
        run = simulate(self.lattice, self.Gamma, self.e, self.w0, self.zeta0, t_start=self.t_start,
                       t_end=self.t_start + self.period, method=self.method,
                       t_eval=self.t_start + phases, **kw)
        where = where.reshape(-1)
        return run.w_eval[where], run.zeta_eval[where]

    def save(self, path):
        """Write the orbit to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return archive.save(self, path)

    def velocity(self, t):
        """Node velocities on the orbit at times ``t``.

        Impulsive methods evaluate the stored period exactly (``segments``, the state after
        every event set, propagated in closed form by
        :class:`~tps_solver.solvers.fda.dense.PiecewiseFlow`); the soft contact integrates one
        period from ``t_start``.

        Parameters
        ----------
        t : array_like of float, shape (n_times,)

        Returns
        -------
        ndarray of float, shape (n_times, n_nodes)
        """
        return self._sample(t)[0]

    def height(self, t):
        """Node heights on the orbit at times ``t``, shape (n_times, n_nodes)."""
        return self._sample(t)[1]


#: FDA methods the period map may use ("soft-radau", the Radau reference, is left out: too slow).
METHODS = ("exact", "point", "ode", "soft")


def _same_lattice(a, b):
    return (a is b) or (a.n_nodes == b.n_nodes and a.geometry == b.geometry and a.boundary == b.boundary
                        and np.allclose(a.nodes, b.nodes, rtol=1e-12, atol=1e-12))


def _guess_state(guess, lattice, Gamma, M, e, t_start, method):
    """(w, zeta, stuck, t) at the guess time, and notes."""
    from tps_solver.model.flat import FlatLayer
    from tps_solver.solvers.fda import SimulationResult

    n = lattice.n_nodes
    T = 2.0 * math.pi * M
    notes = []
    if guess is None:
        guess = FlatLayer(Gamma, M, e=e)
    if isinstance(guess, (tuple, list)):
        if len(guess) not in (2, 3):
            raise ValueError(f"guess must be (w0, zeta0) or (w0, zeta0, stuck0), got a sequence of {len(guess)}")
        w = check_array(guess[0], "guess w0", shape=(n,))
        z = check_array(guess[1], "guess zeta0", shape=(n,))
        stuck = (np.zeros(n, bool) if len(guess) == 2
                 else check_array(guess[2], "guess stuck0", shape=(n,), dtype=bool))
        if t_start is None:
            raise ValueError("t_start must be given (a finite time) with a (w0, zeta0) guess: "
                             "it is the time of that state")
        return w, z, stuck, check_real(t_start, "t_start"), notes
    if isinstance(guess, SimulationResult):
        own = guess.get("lattice")
        if own is not None and not _same_lattice(own, lattice):
            raise ValueError(f"guess comes from another lattice ({own!r}), not {lattice!r}")
        w = check_array(guess.w, "guess w", shape=(n,))
        z = check_array(guess.zeta, "guess zeta", shape=(n,))
        stuck = np.asarray(guess.stuck, dtype=bool) if guess.get("method") != "soft" else np.zeros(n, bool)
        if t_start is not None:
            notes.append("t_start ignored: a SimulationResult guess is taken at its final time")
        return w, z, stuck.copy(), float(guess.t), notes
    if isinstance(guess, ShootingOrbit):
        if not _same_lattice(guess.lattice, lattice):
            raise ValueError(f"guess comes from another lattice ({guess.lattice!r}), not {lattice!r}")
        return guess.w0.copy(), guess.zeta0.copy(), guess.stuck0.copy(), float(guess.t_start), notes
    if hasattr(guess, "velocity") and hasattr(guess, "height"):
        nodes = getattr(guess, "nodes", None)
        own = getattr(guess, "lattice", None)
        if own is not None and not _same_lattice(own, lattice):
            raise ValueError(f"guess comes from another lattice ({own!r}), not {lattice!r}")
        if nodes is not None:
            nodes = np.asarray(nodes, dtype=float)
            if nodes.shape != (n,) or not np.allclose(nodes, lattice.nodes, rtol=1e-9, atol=1e-9):
                raise ValueError(f"guess nodes (shape {nodes.shape}) differ from the lattice's {n} nodes: "
                                 "a guess from another lattice")
        if t_start is None:
            ts = np.linspace(0.0, T, 256, endpoint=False)
            h = np.asarray(guess.height(ts), dtype=float).reshape(ts.size, -1)
            t_start = float(ts[int(np.argmax(h.min(axis=1)))])
        t_start = check_real(t_start, "t_start")
        w = np.asarray(guess.velocity(np.array([t_start])), dtype=float).reshape(-1)
        z = np.asarray(guess.height(np.array([t_start])), dtype=float).reshape(-1)
        if w.size == 1:                       # a flat layer: one value for every node
            w, z = np.full(n, w[0]), np.full(n, z[0])
        w = check_array(w, "guess velocity", shape=(n,))
        z = check_array(z, "guess height", shape=(n,))
        if method != "soft" and np.any(z < 0.0):
            notes.append(f"the guess has zeta < 0 at t_start (min {z.min():.3g}); clipped to 0")
            z = np.maximum(z, 0.0)
        return w, z, np.zeros(n, bool), t_start, notes
    raise ValueError("guess must be (w0, zeta0), a SimulationResult, a PeriodicSolution, a LatticeCycle, "
                     f"a FlatLayer or a ShootingOrbit, got {type(guess).__name__}")


def _intervals(events, stuck0, t0, t1, method, tau_c=None):
    """Sticking (or soft contact) intervals (node, begin, end) within [t0, t1]."""
    out = []
    if method == "soft":
        for t, j in zip(events.t, events.node):
            out.append((int(j), float(t), float(min(t + tau_c, t1))))
        return out
    begin = {int(j): t0 for j in np.flatnonzero(stuck0)}
    for t, j, kind in zip(events.t, events.node, events.kind):
        j = int(j)
        if kind == "stick":
            begin[j] = float(t)
        elif kind == "liftoff" and j in begin:
            out.append((j, begin.pop(j), float(t)))
    for j, b in begin.items():
        out.append((j, b, t1))
    out.sort(key=lambda r: (r[1], r[0]))
    return out


def _choose_section(pmap_factory, w, z, stuck, t_g, T, method, n_grid=512):
    """Move the section within one period to the time with the fewest stuck nodes and the
    largest distance to any event.  Returns (w, z, stuck, t_s, clearance, period maps used)."""
    pm = pmap_factory(t_g, stuck)
    ts = t_g + T * np.arange(1, n_grid) / n_grid
    x = pm.pack(w, z)
    run = pm.run(x, t_eval=ts)
    ev = run.events
    tau_c = run.cutoff.get("tau_c") if method == "soft" else None
    ivs = _intervals(ev, stuck, t_g, t_g + T, method, tau_c)
    times = np.asarray(ev.t, dtype=float)
    if method == "soft":
        times = np.concatenate((times, times + tau_c))
    n_stuck = np.zeros(ts.size, int)
    for _, b, e_ in ivs:
        n_stuck += (ts >= b) & (ts <= e_)
    clear = np.min(np.abs(ts[:, None] - times[None, :]), axis=1) if times.size else np.full(ts.size, T)
    clear = np.minimum(clear, np.minimum(ts - t_g, t_g + T - ts))
    k = int(np.lexsort((-clear, n_stuck))[0])
    st = np.zeros(w.size, bool)
    for j, b, e_ in ivs:
        if b <= ts[k] <= e_:
            st[j] = True
    if method == "soft":
        st[:] = False
    wk, zk = run.w_eval[k].copy(), run.zeta_eval[k].copy()
    wk[st] = 0.0
    zk[st] = 0.0
    return wk, zk, st, float(ts[k]), float(clear[k]), pm.count


def find_periodic_orbit(lattice, Gamma=2.5, M=2, e=0.45, cutoff=None, guess=None, t_start=None, *,
                        method=None, tol=None, max_iter=30, section="auto", fd_step=None,
                        krylov_dim=None, gmres_rtol=1e-4, multipliers=True, n_multipliers=6,
                        dense_max=64, jacobian_step=None, differentiability_rtol=1e-3,
                        neutral_tol=1e-2, simultaneity=1e-6, growth_periods=10,
                        max_events_per_period=None, callback=None, multiplier_map="auto", **simulate_kw):
    r"""Periodic orbit of the FDA period map by Newton--Krylov shooting (see the module docstring).

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
        Plate acceleration, > 0.
    M : int
        Period :math:`T = 2\pi M` of the orbit, >= 1.
    e : float or RestitutionLaw
        Restitution in [0, 1) (in (0, 1) for the soft contact), or a speed-dependent law
        (:mod:`tps_solver.model.restitution`; point impacts only).
    cutoff : float, optional
        Soft-contact length :math:`\ell > 0`; selects ``method="soft"``.  None: point impacts (54).
    guess : tuple, SimulationResult, PeriodicSolution, LatticeCycle, FlatLayer or ShootingOrbit, optional
        Starting state.  ``(w0, zeta0)`` or ``(w0, zeta0, stuck0)`` (arrays of shape
        (n_nodes,)) at time ``t_start``; a time-stepped run (its final state); anything with
        ``velocity(t)``/``height(t)`` and the lattice's ``nodes`` (sampled at ``t_start``,
        default the time where the smallest height is largest).  Default: the flat layer.
    t_start : float, optional
        Time of a ``(w0, zeta0)`` guess (required then), or the sampling time of a periodic guess.
    method : {"exact", "point", "ode", "soft"}, optional
        Integrator of the period map; default ``"soft"`` if ``cutoff`` is given, else ``"exact"``.
    tol : float, optional
        Convergence when :math:`\max|P(x) - x| \le` ``tol``; default 1e-11 (exact), 1e-9 (ode),
        1e-10 (soft: Newton's Jacobian--vector products are the exact soft monodromy, and the
        period map's noise is far below this).
    max_iter : int
        Newton steps, >= 0.
    section : {"auto", "fixed"}
        ``"auto"``: move the section within one period of the guess to the time with the
        fewest stuck nodes and the largest distance to every event (costs one period);
        ``"fixed"``: keep the guess time.
    fd_step : float, optional
        Relative size of the finite-difference perturbation of the Jacobian--vector product;
        default 1e-7 (exact), 1e-6 (ode), 1e-5 (soft).
    krylov_dim : int, optional
        Largest Krylov space per Newton step (period maps per step); default
        ``min(n_unknowns, 100)``.
    gmres_rtol : float
        Relative residual of the inner GMRES solve.
    multipliers : bool
        Compute the Floquet multipliers of a converged orbit.
    n_multipliers : int
        Number of leading multipliers by Arnoldi (more than ``dense_max`` unknowns): the Ritz
        values of a fixed-size Arnoldi factorisation of dimension ``max(2 n_multipliers + 1, 20)``
        of the matrix-free monodromy, with their residual estimates.
    dense_max : int
        Up to this many unknowns all multipliers are computed from a central-difference Jacobian.
    jacobian_step : float, optional
        Relative step of the central differences and of the one-sided test; default ``fd_step``
        (1e-4 for the soft contact, whose stiff solver leaves noise of about 1e-9 in the map).
        It must stay below the smallest gap between contact times of different nodes (times the
        impact speed), or the differences straddle a change of impact order.
    differentiability_rtol : float
        Forward and backward differences along random directions must agree to this
        (relative) for the map to count as differentiable.
    neutral_tol : float
        A multiplier with :math:`|\mu - 1|` below this is reported as neutral.
    simultaneity : float
        Contacts of different nodes closer in time than this count as simultaneous.
    growth_periods : int
        Periods of the perturbation-growth measurement (used when the map is not differentiable).
    max_events_per_period : int, optional
        Event bound of one period map; default ``100 * n_nodes``.  Exceeding it stops with status 3.
    multiplier_map : {"auto", "mirrored", "period"}
        Which map the multipliers come from.  ``"mirrored"``: on a mirror-symmetric lattice
        with ``M`` even and point impacts, an orbit that is also a fixed point of the mirrored
        half-period map :math:`G = S\circ P_{T/2}` (e.g. a kink centred on the mirror point) has
        :math:`DP_T = DG^2`, so its multipliers are the squares of DG's eigenvalues
        (point impacts: :func:`~tps_solver.solvers.shooting.symmetric.mirrored_multipliers`,
        central differences of relative step ``jacobian_step``, default 1e-5 and, where the
        differentiability test fails at that step (a switch of the map within it), the
        default ``jacobian_step`` of the method; two half periods a product, Arnoldi stopped when the leading ones have converged, the differentiability
        test from its first two products; the soft contact: the exact half-period monodromy,
        mirrored); an orbit that is not such a fixed point (to
        ``max(1e-9, 100 tol)``) falls back to the period map, and the message says so.
        ``"period"``: the period map itself (the reference).  ``"auto"`` (default):
        ``"mirrored"`` where it applies, else ``"period"``.
    callback : callable, optional
        ``callback(state)`` after every Newton step and once for the start (a
        :class:`~tps_solver.core.progress.ProgressState`: stage ``"shooting"``, ``iteration``,
        ``residual`` max|P(x) - x|, ``x``).
        Raising ``KeyboardInterrupt`` there (or pressing Ctrl-C) returns the state so far.
    **simulate_kw
        Further keywords of :func:`~tps_solver.simulate` (``stick_velocity``, ``time_tol``,
        ``rtol``, ``atol``, ``ode_solver``, ...).

    Returns
    -------
    ShootingOrbit

    Raises
    ------
    ValueError
        Bad input: wrong lattice, parameters out of range, a guess of the wrong shape, with
        NaN, negative heights (point impacts) or from another lattice, ``cutoff <= 0``.

    Examples
    --------
    >>> import tps_solver as tps
    >>> coarse = tps.Lattice.planar(n_nodes=8, length=140.0)
    >>> cyc = tps.solve_lattice_cycle(coarse, Gamma=2.5, M=2, e=0.45, t0=None)
    >>> orb = find_periodic_orbit(coarse, Gamma=2.5, M=2, e=0.45, guess=cyc)
    >>> orb.converged, orb.contacts_per_node.tolist()
    (True, [1, 1, 1, 1, 1, 1, 1, 1])
    >>> bool(abs(abs(orb.multipliers[0]) - 0.457) < 1e-3)
    True
    """
    from tps_solver.operators.lattice import Lattice

    start_clock = time.perf_counter()
    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    law = as_restitution(e)
    e = check_restitution(law.e, "e") if law.constant else law
    if cutoff is not None:
        cutoff = check_positive(cutoff, "cutoff")
    if method is None:
        method = "soft" if cutoff is not None else "exact"
    method = check_choice(method, "method", METHODS)
    if method == "soft" and cutoff is None:
        raise ValueError("cutoff must be a finite number > 0 when method='soft', got None")
    if method != "soft" and cutoff is not None:
        raise ValueError(f"cutoff is only used with method='soft', got method={method!r}")
    section = check_choice(section, "section", ("auto", "fixed"))
    multipliers = check_bool(multipliers, "multipliers")
    multiplier_map = check_choice(multiplier_map, "multiplier_map", ("auto", "mirrored", "period"))
    if multiplier_map == "mirrored" and (M % 2 or not mirror_symmetric(lattice)):
        raise ValueError("multiplier_map='mirrored' needs an even M and a lattice symmetric under x -> -x "
                         f"(got M = {M}); use multiplier_map='period' or 'auto'")
    mirror_steps = None if jacobian_step is None else (check_positive(jacobian_step, "jacobian_step"),)
    defaults = {"exact": (1e-11, 1e-7, 1e-7), "point": (1e-11, 1e-7, 1e-7), "ode": (1e-9, 1e-6, 1e-6),
                "soft": (1e-10, 1e-5, 1e-4)}[method]
    tol = defaults[0] if tol is None else check_positive(tol, "tol")
    fd_step = defaults[1] if fd_step is None else check_positive(fd_step, "fd_step")
    jacobian_step = defaults[2] if jacobian_step is None else check_positive(jacobian_step, "jacobian_step")
    mirror_steps = mirror_steps or (1e-5, jacobian_step)
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    gmres_rtol = check_positive(gmres_rtol, "gmres_rtol")
    n_multipliers = check_int(n_multipliers, "n_multipliers", minimum=1)
    dense_max = check_int(dense_max, "dense_max", minimum=0)
    differentiability_rtol = check_positive(differentiability_rtol, "differentiability_rtol")
    neutral_tol = check_positive(neutral_tol, "neutral_tol")
    simultaneity = check_positive(simultaneity, "simultaneity")
    growth_periods = check_int(growth_periods, "growth_periods", minimum=2)
    n = lattice.n_nodes
    if max_events_per_period is None:
        max_events_per_period = 100 * n
    max_events_per_period = check_int(max_events_per_period, "max_events_per_period", minimum=1)
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable, got {type(callback).__name__}")
    T = 2.0 * math.pi * M
    # a priori (before any period map): one Newton step, and the dense multipliers' Jacobian
    krylov_dim = None if krylov_dim is None else check_int(krylov_dim, "krylov_dim", minimum=1)
    maps = shooting_maps(n, krylov_dim, max_iter) + (2 * n + 1 if multipliers and 2 * n <= dense_max else 0)
    check_cost("find_periodic_orbit", "lattice.n_nodes", n, 8.0 * (maps + 4 * n) * 2 * n + 1e6,
               maps * period_map_seconds(n, T, method, e if law.constant else None),
               hint=f"at least {maps} period maps of separate contacts at O(n_nodes**2) each; use a coarser "
                    "lattice, a smaller krylov_dim or dense_max, or the soft contact")
    kw = dict(simulate_kw)
    if method == "soft":
        kw["cutoff"] = cutoff

    w, z, stuck, t_g, notes = _guess_state(guess, lattice, Gamma, M, e, t_start, method)
    if method != "soft" and np.any(z < 0.0):
        raise ValueError("guess zeta0 must be >= 0 at every node with point impacts (the layer cannot "
                         f"be below the plate), got min {z.min():.3g}")
    if np.any(stuck & ((w != 0.0) | (z != 0.0))):
        raise ValueError("guess stuck0 nodes must have w0 = zeta0 = 0")
    if method == "soft":
        stuck = np.zeros(n, bool)

    def factory(t_s, st):
        return PeriodMap(lattice, Gamma, e, T, t_s, stuck=st, method=method,
                         max_events_per_period=max_events_per_period, fd_step=fd_step, **kw)

    history = []
    steps = []                      # (line-search step length, GMRES relative residual, products)
    n_maps = 0
    clearance = float("nan")
    status, message = None, ""
    t_s = t_g

    def result(x=None, pm=None, F_res=float("nan"), nit=0):
        out = ShootingOrbit(converged=status == 0, success=status == 0, status=status,
                            status_text=STATUS[status], message=message, residual=float(F_res),
                            residual_history=np.asarray(history, dtype=float), nit=nit,
                            step_lengths=np.array([r[0] for r in steps], dtype=float),
                            gmres_residuals=np.array([r[1] for r in steps], dtype=float),
                            gmres_products=np.array([r[2] for r in steps], dtype=int),
                            n_period_maps=n_maps + (pm.count if pm is not None else 0),
                            t_start=float(t_s), period=T, lattice=lattice, Gamma=Gamma, M=M, e=e,
                            method=method, cutoff=cutoff, section_clearance=clearance,
                            multipliers=np.empty(0, complex), multipliers_kind="none", differentiable=None,
                            multiplier_residuals=None, arnoldi_dim=0, multipliers_map="none",
                            half_period_multipliers=np.empty(0, complex), multiplier_periods=0.0,
                            multiplier_time=0.0,
                            growth_factor=float("nan"), neutral=False,
                            contacts_per_node=np.zeros(n, int), contact_times=[np.empty(0)] * n,
                            sticking_intervals=[], events=None, events_per_period=0,
                            simultaneous_contacts=False)
        if pm is not None and x is not None:
            wx, zx = pm.state(x)
            out.update(w0=wx, zeta0=zx, stuck0=pm.stuck.copy())
        else:
            out.update(w0=w.copy(), zeta0=z.copy(), stuck0=stuck.copy())
        out._sim_kw = kw
        return out

    try:
        if section == "auto":
            # the section run samples the period on a grid; should a grid time fall on a switch to
            # round-off and the contact search fail there, try a second grid, then keep the guess time
            for n_grid in (512, 509, None):
                if n_grid is None:
                    notes.append("section='auto' failed on two sampling grids; the guess time is the section")
                    break
                try:
                    w, z, stuck, t_s, clearance, used = _choose_section(factory, w, z, stuck, t_g, T, method,
                                                                        n_grid=n_grid)
                    n_maps += used
                    break
                except PeriodMapError as exc:
                    n_maps += 1
                    if exc.status != 3:
                        raise
    except PeriodMapError as exc:
        status, message = exc.status, exc.message + " (while choosing the section from the guess)"
        return _finish(result(), notes, start_clock)
    except KeyboardInterrupt:
        status, message = 5, "interrupted while choosing the section; the guess is returned"
        return _finish(result(), notes, start_clock)

    pm = factory(t_s, stuck)
    m = pm.m
    if krylov_dim is None:
        krylov_dim = min(2 * m, 100)
    krylov_dim = check_int(krylov_dim, "krylov_dim", minimum=1)
    x = pm.pack(w, z)
    nit = 0
    res = float("nan")
    Px = None
    last = {"nit": 0, "x": x}

    def progress(state):
        last.update(nit=state.iteration, x=state.x)
        history.append(state.residual)
        steps.append((state.step, float("nan"), 0))
        if callback is not None:
            callback(progress_state("shooting", state.iteration, residual=state.residual, x=state.x))

    try:
        tic = time.perf_counter()
        F0, Px0, extra0 = pm.residual(x)
        if max_iter > 0 and method != "soft":
            # the first period map is the probe of the cost: one Newton step needs up to
            # krylov_dim + 1 more of them (and the line search one); refuse if that is out of reach
            per_map = time.perf_counter() - tic
            products = min(krylov_dim, 2 * m) + 2
            check_cost("find_periodic_orbit", "lattice.n_nodes", n, 8.0 * (krylov_dim + 2) * 2 * m + 1e6,
                       products * per_map,
                       hint=f"one period map took {per_map:.3g} s, a Newton step takes up to {products} of "
                            f"them; use a coarser lattice, a smaller krylov_dim, or the soft contact")
        history.append(pm.error(F0, (Px0, extra0)))
        if callback is not None:
            callback(progress_state("shooting", 0, residual=history[-1], x=x))
        # Newton--GMRES (one Krylov space of krylov_dim, no restart), backtracking on |F|_2 with
        # the quadratic model (the one engine, tps_solver.core.newton)
        sol = newton(pm, x, first=(F0, Px0, extra0), tol=tol, max_iter=max_iter, linear="gmres",
                     line_search="quadratic", merit="2", gmres_rtol=gmres_rtol, gmres_restart=krylov_dim,
                     gmres_maxiter=1, callback=progress)
        x, nit, res = sol.x, sol.nit, sol.residual
        Px, extra = sol.data
        steps[:] = [(lam, rel, int(used)) for lam, rel, used in
                    zip(sol.step_lengths, sol.linear_residuals, sol.linear_products)]
        status, message = sol.status, sol.message
        if status == 0 and extra != 0.0:
            status = 7
    except PeriodMapError as exc:
        x, nit = last["x"], last["nit"]
        res = history[-1] if history else float("nan")
        status, message = exc.status, exc.message + f" (at Newton step {nit})"
    except KeyboardInterrupt:
        x, nit = last["x"], last["nit"]
        res = history[-1] if history else float("nan")
        status = 5
    if status == 5:
        message = f"interrupted at Newton step {nit}: the last iterate is returned"
    out = result(x, pm, res, nit)
    if status == 0:
        out.message = f"converged: max|P(x) - x| = {res:.3g} after {nit} Newton steps"
    elif status == 1:
        out.message = (f"iteration limit: max|P(x) - x| = {res:.3g} after {nit} Newton steps; raise max_iter, "
                       "time-step the guess for more periods, or raise krylov_dim")
    elif status == 2:
        out.message = message + ("; try a guess closer to the orbit (time-step more periods first), another "
                                 "section, or a larger krylov_dim; a multiplier near 1 (a neutral mode such as "
                                 "a front position) makes I - J ill-conditioned")
    elif status == 7:
        out.message = (f"the free nodes are periodic to {res:.3g}, but a node stuck at t_start is free after "
                       "one period; use section='auto' or another t_start")
    elif status == 6:
        out.message = message
    elif status == 3:
        out.message = message + "; try another method, a smaller time_tol or a guess closer to the orbit"
    def interrupted(where):
        # Ctrl-C after Newton: the iterate is kept, but the call was stopped (status 5, never 0)
        out.update(status=5, status_text=STATUS[5], converged=False, success=False,
                   message=f"interrupted {where} (KeyboardInterrupt); the last Newton iterate is kept "
                           f"(max|P(x) - x| = {res:.3g}; pass the orbit as guess= to finish)")

    try:
        _pattern(out, pm, x, simultaneity)
    except PeriodMapError as exc:
        notes.append(f"contact pattern not evaluated ({type(exc).__name__})")
    except KeyboardInterrupt:
        interrupted("while reading the contact pattern")
        notes.append("contact pattern not evaluated (KeyboardInterrupt)")
    half = [0]                      # half periods of the mirrored map (multiplier stage)
    if out.status == 0 and multipliers:
        try:
            if Px is None:
                Px = pm(x)[0]
            before, symmetric, clock = pm.count, False, time.perf_counter()
            if multiplier_map != "period" and M % 2 == 0 and mirror_symmetric(lattice):
                G, Gx, symmetric = _mirrored_fixed_point(pm, x, T, max(1e-9, 100.0 * tol), notes)
                half[0] += G.count
            if symmetric:
                half[0] += _multipliers_mirrored(out, G, x, Gx, mirror_steps, dense_max, n_multipliers,
                                                 differentiability_rtol, neutral_tol, growth_periods, notes)
            else:
                _multipliers(out, pm, x, Px, m, jacobian_step, dense_max, n_multipliers,
                             differentiability_rtol, neutral_tol, growth_periods, notes)
                out.multipliers_map = "period" if out.multipliers.size else "none"
            out.multiplier_periods = float(pm.count - before) + 0.5 * half[0]
            out.multiplier_time = time.perf_counter() - clock
        except PeriodMapError as exc:
            notes.append(f"multipliers not computed: {exc.message}")
        except KeyboardInterrupt:
            interrupted("while computing the multipliers")
            notes.append("multipliers not computed")
    out.n_period_maps = n_maps + pm.count + int(math.ceil(0.5 * half[0]))
    return _finish(out, notes, start_clock)


def _finish(out, notes, start_clock):
    if notes:
        out.message = out.message + "; " + "; ".join(notes)
    out.time = time.perf_counter() - start_clock
    return out


def _pattern(out, pm, x, simultaneity):
    """Contact pattern of one period from x (events, contacts per node, sticking intervals)."""
    run = pm.run(x, record=pm.method != "soft")
    ev = run.events
    out.segments = run.segments
    n = pm.lattice.n_nodes
    contact = (ev.kind == "impact") | (ev.kind == "stick")
    times = [np.asarray(ev.t[contact & (ev.node == j)], dtype=float) for j in range(n)]
    tau_c = run.cutoff.get("tau_c") if pm.method == "soft" else None
    out.update(events=ev, events_per_period=int(ev.size),
               contacts_per_node=np.array([t.size for t in times], dtype=int), contact_times=times,
               sticking_intervals=_intervals(ev, pm.stuck, pm.t_s, pm.t_s + pm.T, pm.method, tau_c))
    ct = np.asarray(ev.t[contact], dtype=float)
    cn = np.asarray(ev.node[contact])
    order = np.argsort(ct, kind="stable")
    ct, cn = ct[order], cn[order]
    simultaneous = False
    for i in range(ct.size):
        j = i + 1
        while j < ct.size and ct[j] - ct[i] <= simultaneity:
            if cn[j] != cn[i]:
                simultaneous = True
                break
            j += 1
        if simultaneous:
            break
    out.simultaneous_contacts = simultaneous


def _multipliers(out, pm, x, Px, m, jacobian_step, dense_max, n_mult, drtol, neutral_tol,
                 growth_periods, notes):
    """Floquet multipliers (dense or Arnoldi) after a one-sided differentiability test."""
    scale = max(1.0, float(np.max(np.abs(x), initial=0.0)))
    soft = pm.method == "soft"
    rng = np.random.default_rng(12345)
    # one-sided test along random directions (positive zeta perturbations are always admissible)
    h = jacobian_step * scale
    gap = 0.0
    size = 0.0
    # the soft contact's map is differentiable by construction (transversal switching, see
    # tps_solver.solvers.fda.regularised); its solver noise would fail the one-sided test
    for _ in range(0 if soft else 2):
        v = rng.standard_normal(2 * m)
        v /= np.max(np.abs(v))
        if not soft:
            zmin = float(np.min(x[m:], initial=np.inf))
            hh = min(h, 0.5 * zmin) if zmin > 0 else h
        else:
            hh = h
        fp = (pm(x + hh * v)[0] - Px) / hh
        fm = (Px - pm(x - hh * v)[0]) / hh
        gap = max(gap, float(np.max(np.abs(fp - fm))))
        size = max(size, float(np.max(np.abs(fp) + np.abs(fm))))
    differentiable = gap <= drtol * max(size, 1.0)
    out.differentiable = None if soft else bool(differentiable)
    if not differentiable:
        reason = ("the period map is not differentiable at the orbit: forward and backward differences "
                  f"differ by {gap:.3g} (size {size:.3g})")
        if out.simultaneous_contacts:
            reason += "; simultaneous contacts: the impact order matters (docs/design.md, hazard 7)"
        out.growth_factor = _growth(pm, x, growth_periods)
        notes.append(reason + f"; no multipliers; perturbation growth {out.growth_factor:.4g} per period "
                     f"over {growth_periods} periods instead")
        return
    if soft:        # exact: matrix exponentials and saltation matrices (tps_solver.solvers.shooting.soft_monodromy)
        lin = SoftMonodromy(pm.lattice, pm.Gamma, pm.e, pm.kw["cutoff"], pm.t_s, pm.t_s + pm.T, pm.state(x)[1],
                            pm.run(x).events if out.events is None else out.events, dense_max=max(dense_max, 400))
        mu = lin.multipliers(None if 2 * m <= dense_max else min(n_mult, 2 * m))
        kind = "all (exact)" if 2 * m <= dense_max else "leading (exact)"
    elif 2 * m <= dense_max:
        mu = floquet_multipliers(pm.matrix(x, jacobian_step))
        kind = "all (dense)"
    else:
        jv = pm.monodromy(x, (Px, 0.0)).matvec       # the map's one-sided difference action

        # Arnoldi of fixed dimension (one product per step, cost known in advance); ARPACK's
        # implicit restarts have no useful bound on the number of products when the spectrum
        # is clustered near 0 (sticking) and the products carry finite-difference noise.
        k = min(n_mult, 2 * m)
        dim = min(2 * m, max(2 * k + 1, 20))
        mu, out.multiplier_residuals, out.arnoldi_dim = ritz_multipliers(jv, 2 * m, k, dim,
                                                                          rng.standard_normal(2 * m))
        kind = "leading (Arnoldi)"
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    out.multipliers, out.multipliers_kind = mu, kind
    near = np.abs(mu - 1.0) < neutral_tol
    out.neutral = bool(np.any(near))
    if out.neutral:
        notes.append(f"neutral multiplier {mu[near][0]:.6g} (|mu - 1| < {neutral_tol:g}): a nearly neutral "
                     "mode (e.g. the front position); I - J is ill-conditioned along it")


def _mirrored_fixed_point(pm, x, T, sym_tol, notes):
    """``(G, G(x), symmetric)``: the mirrored half-period map G at the section of ``pm``, its image of
    ``x`` and whether ``x`` is a fixed point of G to ``sym_tol``."""
    G = MirroredHalfPeriodMap(pm.lattice, pm.Gamma, pm.e, T, pm.t_s, stuck=pm.stuck, method=pm.method,
                              max_events_per_period=pm.max_events, fd_step=pm.fd_step, **pm.kw)
    Gx, extra = G(x)
    defect = max(float(np.max(np.abs(Gx - x), initial=0.0)), extra)
    if defect > sym_tol:
        notes.append(f"the orbit is not a fixed point of the mirrored half-period map (max|G(x) - x| = "
                     f"{defect:.2e} > {sym_tol:.1e}): multipliers from the period map")
    return G, Gx, defect <= sym_tol


def _multipliers_mirrored(out, G, x, Gx, steps, dense_max, n_mult, drtol, neutral_tol, growth_periods, notes):
    """Floquet multipliers of P_T = G^2 from the mirrored half-period map G (central differences of the
    first of ``steps`` at which P_T passes the differentiability test); returns the half periods spent."""
    m = G.m
    start = G.count
    if G.method == "soft":          # exact: the mirrored half-period soft monodromy
        if 2 * m <= max(dense_max, 400):
            lam, kind = floquet_multipliers(G.monodromy_matrix(x)), "all (exact)"
        else:
            lam, kind = floquet_multipliers(G.monodromy(x), min(n_mult, 2 * m - 2)), "leading (exact)"
        out.multipliers, out.half_period_multipliers = lam ** 2, lam
        out.multipliers_kind, out.multipliers_map = kind, "mirrored"
        _neutral(out, neutral_tol, notes)
        return G.count - start
    for i, step in enumerate(steps):
        res = mirrored_multipliers(G, x, min(n_mult, 2 * m), step=step, dense=2 * m <= dense_max, Gx=Gx,
                                   drtol=drtol)
        if res.mu is not None:
            break
        if i + 1 < len(steps):
            notes.append(f"central differences of relative step {step:g} straddle a switch of the map (forward "
                         f"and backward differences differ by {res.gap:.3g}, size {res.size:.3g}); step "
                         f"{steps[i + 1]:g} used")
    out.differentiable = res.mu is not None
    if res.mu is None:
        reason = ("the period map is not differentiable at the orbit: forward and backward differences "
                  f"differ by {res.gap:.3g} (size {res.size:.3g})")
        if out.simultaneous_contacts:
            reason += "; simultaneous contacts: the impact order matters (docs/design.md, hazard 7)"
        pm = PeriodMap(G.lattice, G.Gamma, G.e, G.full_period, G.t_s, stuck=G.stuck, method=G.method,
                       max_events_per_period=G.max_events, **G.kw)
        out.growth_factor = _growth(pm, x, growth_periods)
        notes.append(reason + f"; no multipliers; perturbation growth {out.growth_factor:.4g} per period "
                     f"over {growth_periods} periods instead")
        return G.count - start + 2 * pm.count
    if res.dim:
        out.multiplier_residuals, out.arnoldi_dim = res.residuals, res.dim
    out.multipliers, out.half_period_multipliers = res.mu, res.half
    out.multipliers_kind = "leading (Arnoldi)" if res.dim else "all (dense)"
    out.multipliers_map = "mirrored"
    _neutral(out, neutral_tol, notes)
    return G.count - start


def _neutral(out, neutral_tol, notes):
    mu, lam = out.multipliers, out.half_period_multipliers
    near = np.abs(mu - 1.0) < neutral_tol
    out.neutral = bool(np.any(near))
    if out.neutral:
        notes.append(f"neutral multiplier {mu[near][0]:.6g} (|mu - 1| < {neutral_tol:g}; the mirrored map has "
                     f"{lam[near][0]:.6g}): a nearly neutral mode (e.g. the front position); I - J is "
                     "ill-conditioned along it")


def _growth(pm, x, periods, size=1e-8, saturation=1e-3, seed=0):
    """Growth per period of a random zero-mean perturbation of relative size ``size``.

    The protocol of :func:`~tps_solver.check_stability`: zero-mean normal perturbations of the
    free nodes' w and zeta, each scaled to ``size * max(1, max|w|, max zeta)``, followed next to
    the reference run; the distance is fitted on the linear window.
    """
    rng = np.random.default_rng(seed)
    m = pm.m
    scale = size * max(1.0, float(np.max(np.abs(x[:m]), initial=0.0)), float(np.max(x[m:], initial=0.0)))
    dw = rng.standard_normal(m)
    dz = rng.standard_normal(m)
    dw -= dw.mean()
    dz -= dz.mean()
    dw *= scale / np.max(np.abs(dw))
    dz *= scale / np.max(np.abs(dz))
    t_eval = pm.t_s + pm.T * np.arange(periods + 1)
    ref = pm.run(x, periods=periods, t_eval=t_eval)
    per = pm.run(x + np.concatenate((dw, dz)), periods=periods, t_eval=t_eval)
    k = min(ref.w_eval.shape[0], per.w_eval.shape[0])
    dist = np.maximum(np.max(np.abs(per.zeta_eval[:k] - ref.zeta_eval[:k]), axis=1),
                      np.max(np.abs(per.w_eval[:k] - ref.w_eval[:k]), axis=1))
    return fit_growth(dist, saturation)[0]


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_orbit(f):
    from tps_solver.operators.lattice import Lattice

    n = f.instance("lattice", Lattice).n_nodes
    f.status(STATUS)
    f.array("w0", "f", shape=(n,), finite=True)
    f.array("zeta0", "f", shape=(n,), finite=True)
    f.array("stuck0", "b", shape=(n,))
    f.float("t_start")
    f.float("period")


archive.register("ShootingOrbit", ShootingOrbit, validate=_validate_orbit)
