r"""The FDA period map as a problem: :class:`PeriodMap`, the one period map of the package.

.. math::  P:\ x = (\underline w, \underline\zeta)(t_s) \mapsto (\underline w, \underline\zeta)(t_s + T),
           \qquad F(x) = P(x) - x ,

over the nodes that are free at the section :math:`t_s` (nodes stuck to the plate there
have :math:`w = \zeta = 0` and are no unknowns), evaluated by :func:`~tps_solver.simulate`
with any of its methods.  :class:`PeriodMap` implements the problem protocol
(:mod:`tps_solver.core.problem`), so the one Newton
(:func:`tps_solver.core.newton.newton`) finds its fixed points and the continuation
follows them; shooting (:func:`~tps_solver.find_periodic_orbit`), the stability check
(:func:`~tps_solver.check_stability`) and the continuation of shooting orbits all use it.

Derivatives
-----------
* :meth:`PeriodMap.monodromy` -- the action :math:`v \mapsto \partial P/\partial x\, v`: for
  point impacts a one-sided difference :math:`[P(x + hv) - P(x)]/h` with
  :math:`h\,\|v\|_\infty =` ``fd_step`` :math:`\cdot\max(1, \|x\|_\infty)` (backwards when a
  height would become negative); for the soft contact the exact product
  (:class:`~tps_solver.solvers.shooting.soft_monodromy.SoftMonodromy`);
* :meth:`PeriodMap.jacobian` -- that action minus the identity (Newton's operator);
* :meth:`PeriodMap.matrix` -- the dense monodromy by central differences, or the forward
  and backward one-sided ones (their gap tests differentiability; docs/design.md, hazard 7).
"""
import numpy as np
from scipy.sparse.linalg import LinearOperator

from tps_solver.core.checks import check_array
from tps_solver.core.problem import Problem
from tps_solver.model.restitution import RestitutionLaw
from tps_solver.solvers.shooting.soft_monodromy import SoftMonodromy

__all__ = ["PeriodMap", "PeriodMapError"]


class PeriodMapError(RuntimeError):
    """A period map that cannot be evaluated: ``status`` 6 (event bound) or 3 (the run failed).

    Examples
    --------
    >>> PeriodMapError(6, "event bound exceeded").status
    6
    """

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status
        self.message = message


class PeriodMap(Problem):
    r"""The period map of the FDA from the section ``t_start`` (module docstring).

    Parameters
    ----------
    lattice : Lattice
    Gamma, e : float
    period : float
        :math:`T = 2\pi M`.
    t_start : float
        The section :math:`t_s`.
    stuck : ndarray of bool, shape (n_nodes,), optional
        Nodes stuck to the plate at the section (no unknowns); default none.
    method : {"exact", "point", "ode", "soft"}
    max_events_per_period : int, optional
        Event bound of one period (default: that of :func:`~tps_solver.simulate`); beyond it the
        map raises :class:`PeriodMapError` (status 6).
    fd_step : float
        Relative step of the finite-difference monodromy action (point impacts).
    require_free : bool
        Raise :class:`PeriodMapError` (status 3) when a node is stuck to the plate at the end
        of the period (where the map is not a smooth map of (w, zeta): continuation and the
        stability check of free orbits).
    **simulate_kw
        Further keywords of :func:`~tps_solver.simulate` (``cutoff`` for the soft contact).

    Attributes
    ----------
    m : int
        Free nodes (``x`` has 2 m entries: their w, then their zeta).
    count : int
        Periods integrated so far (the cost).

    Examples
    --------
    The flat layer on a coarse lattice is a fixed point to round-off; its monodromy (central
    differences) has the flat layer's multipliers among its eigenvalues:

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=4, length=60.0)
    >>> flat = tps.FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> pm = PeriodMap(lat, 2.5, 0.45, flat.period, 1.0)
    >>> w, z = flat.velocity(1.0), flat.height(1.0)
    >>> x = pm.pack(np.full(4, w), np.full(4, z))
    >>> F, Px, extra = pm.residual(x)
    >>> bool(pm.error(F, (Px, extra)) < 1e-12), pm.count
    (True, 1)
    >>> from tps_solver.solvers.shooting.floquet import multipliers
    >>> mu = multipliers(pm.matrix(x, 1e-7))
    >>> bool(np.min(np.abs(mu - flat.floquet_multipliers()[0])) < 1e-7)
    True
    """

    def __init__(self, lattice, Gamma, e, period, t_start, *, stuck=None, method="exact",
                 max_events_per_period=None, fd_step=1e-7, require_free=False, **simulate_kw):
        n = lattice.n_nodes
        self.lattice, self.Gamma, self.T, self.t_s = lattice, float(Gamma), float(period), float(t_start)
        self.e = e if isinstance(e, RestitutionLaw) else float(e)
        self.stuck = np.zeros(n, bool) if stuck is None else check_array(stuck, "stuck", shape=(n,),
                                                                          dtype=bool).copy()
        self.free = ~self.stuck
        self.m = int(np.count_nonzero(self.free))
        self.method = method
        self.kw = dict(simulate_kw)
        self.max_events = None if max_events_per_period is None else int(max_events_per_period)
        self.fd_step = float(fd_step)
        self.require_free = bool(require_free)
        self.count = 0

    # ------------------------------------------------------------ parameters
    @property
    def parameters(self):
        """``Gamma``, ``e`` (or a speed-dependent law's own parameters) and, for the soft contact, ``cutoff``."""
        if isinstance(self.e, RestitutionLaw):
            return {"Gamma": self.Gamma, **self.e.parameters}
        out = {"Gamma": self.Gamma, "e": self.e}
        if self.method == "soft":
            out["cutoff"] = float(self.kw["cutoff"])
        return out

    def at(self, **values):
        """The period map at other parameter values (the count restarts at 0)."""
        unknown = sorted(set(values) - set(self.parameters))
        if unknown:
            raise ValueError(f"parameter must be one of {sorted(self.parameters)}, got {unknown[0]!r}")
        kw = dict(self.kw)
        if "cutoff" in values:
            kw["cutoff"] = float(values["cutoff"])
        if isinstance(self.e, RestitutionLaw):
            changed = {k: v for k, v in values.items() if k != "Gamma"}
            e = self.e.at(**changed) if changed else self.e
        else:
            e = values.get("e", self.e)
        return PeriodMap(self.lattice, values.get("Gamma", self.Gamma), e, self.T,
                         self.t_s, stuck=self.stuck, method=self.method, max_events_per_period=self.max_events,
                         fd_step=self.fd_step, require_free=self.require_free, **kw)

    # ------------------------------------------------------------ the map
    def state(self, x):
        """``(w, zeta)`` of all nodes, shape (n_nodes,) each, from the unknowns ``x``."""
        n = self.lattice.n_nodes
        w, z = np.zeros(n), np.zeros(n)
        w[self.free] = x[:self.m]
        z[self.free] = x[self.m:]
        if self.method != "soft":
            z = np.maximum(z, 0.0)
        return w, z

    def pack(self, w, z):
        """The unknowns ``x`` (free nodes' w, then zeta) of a full state."""
        return np.concatenate((np.asarray(w, float)[self.free], np.asarray(z, float)[self.free]))

    def run(self, x, periods=1, t_eval=None, record=False):
        """The :func:`~tps_solver.simulate` run of ``periods`` periods from ``x``.

        Raises
        ------
        PeriodMapError
            Status 6 (event bound exceeded) or 3 (the run failed).
        """
        from tps_solver.solvers.fda import simulate

        w, z = self.state(x)
        kw = dict(self.kw)
        if self.method != "soft":
            kw["stuck0"] = self.stuck
            if self.max_events is not None:
                kw["max_events_per_cycle"] = self.max_events
        self.count += periods
        run = simulate(self.lattice, self.Gamma, self.e, w, z, t_start=self.t_s,
                       t_end=self.t_s + periods * self.T, method=self.method, t_eval=t_eval,
                       record_segments=record, **kw)
        if run.status == 5:
            raise KeyboardInterrupt
        if run.status == 6:
            raise PeriodMapError(6, f"event bound exceeded in the period map: {run.message}; raise "
                                    "max_events_per_period, raise stick_velocity (chatter turns into sticking "
                                    "sooner) or start closer to a periodic orbit")
        if not run.success:
            raise PeriodMapError(3, f"the period map failed: {run.message}")
        if self.require_free and np.any(run.stuck):
            raise PeriodMapError(3, f"{int(np.sum(run.stuck))} node(s) stuck to the plate at the end of the "
                                    "period: the period map is not a smooth map of (w, zeta) there")
        per = run.n_events / periods
        if self.max_events is not None and per > self.max_events:
            raise PeriodMapError(6, f"event bound exceeded: {per:.0f} events per period > "
                                    f"max_events_per_period = {self.max_events}; raise max_events_per_period "
                                    "or stick_velocity")
        return run

    def __call__(self, x):
        """``(P(x), extra)``: the image of the free nodes and the largest |w|, zeta after one
        period of a node stuck at the section (1e-300 if such a node is free then)."""
        run = self.run(x)
        y = self.pack(run.w, run.zeta)
        extra = 0.0
        if self.method != "soft" and np.any(self.stuck):
            extra = float(np.max(np.abs(np.concatenate((run.w[self.stuck], run.zeta[self.stuck])))))
            if np.any(~run.stuck[self.stuck]):
                extra = max(extra, 1e-300)     # a node stuck at the section is free after one period
        return y, extra

    # ------------------------------------------------------------ the problem protocol
    def residual(self, x):
        """``(P(x) - x, P(x), extra)``."""
        Px, extra = self(x)
        return Px - x, Px, extra

    def error(self, F, data):
        """max|P(x) - x| over the free nodes and the stuck nodes' departure (``extra``)."""
        return max(float(np.max(np.abs(F), initial=0.0)), data[1])

    def project(self, x):
        """Heights clipped at 0 (point impacts: the layer cannot be below the plate)."""
        if self.method == "soft":
            return x
        x = x.copy()
        x[self.m:] = np.maximum(x[self.m:], 0.0)
        return x

    def monodromy(self, x, data=None):
        """The action of dP/dx at ``x`` as a ``LinearOperator`` (module docstring).

        ``data`` is what :meth:`residual` returned with ``F`` (its ``P(x)`` is reused).
        """
        size = 2 * self.m
        if self.method == "soft":
            lin = SoftMonodromy.from_run(self.run(x), *self.state(x), self.t_s)
            return LinearOperator((size, size), matvec=lin.jv, dtype=float)
        Px = self(x)[0] if data is None else data[0]
        scale = max(1.0, float(np.max(np.abs(x), initial=0.0)))
        m, h0 = self.m, self.fd_step

        def jv(v):
            v = np.asarray(v, dtype=float).ravel()
            nv = float(np.max(np.abs(v), initial=0.0))
            if nv == 0.0:
                return np.zeros_like(v)
            h = h0 * scale / nv
            if np.any(x[m:] + h * v[m:] < 0.0):
                h = -h
            return (self(x + h * v)[0] - Px) / h

        return LinearOperator((size, size), matvec=jv, dtype=float)

    def jacobian(self, x, F, data):
        """Newton's operator ``dP/dx - I`` (a ``LinearOperator``)."""
        mono = self.monodromy(x, data)
        return LinearOperator(mono.shape, matvec=lambda v: mono.matvec(v) - np.asarray(v).ravel(), dtype=float)

    def monodromy_matrix(self, x, step=1e-6):
        """The dense monodromy: exact for the soft contact (central differences at a grazing
        switch, where the map is not differentiable), central differences of relative ``step``
        for point impacts."""
        if self.method == "soft":
            try:
                return SoftMonodromy.from_run(self.run(x), *self.state(x), self.t_s).matrix()
            except ValueError as exc:
                if "grazing" not in str(exc):
                    raise
        return self.matrix(x, step, heights="free")

    def matrix(self, x, step, scheme="central", relative=True, heights="halve", tick=None):
        """The dense monodromy dP/dx at ``x`` by differences.

        Parameters
        ----------
        x : ndarray of float, shape (2 m,)
        step : float
            The step; relative (times ``max(1, max|x|)``) unless ``relative=False``.
        scheme : {"central", "one-sided"}
            ``"central"``: one matrix (2 maps per column); ``"one-sided"``: the forward and the
            backward difference matrices (``(Jf, Jb)``, 1 + 2 maps per column).
        relative : bool
        heights : {"halve", "clip", "free"}
            Point impacts: a height step is at most half the height (``"halve"``), or the
            perturbed height is clipped at 0 and the difference divided by the step actually
            taken (``"clip"``), or heights are stepped like velocities (``"free"``).
        tick : callable, optional
            Called without arguments after every perturbed period map (progress).

        Returns
        -------
        ndarray of float, shape (2 m, 2 m), or a tuple of two
        """
        if scheme not in ("central", "one-sided"):
            raise ValueError(f"scheme must be 'central' or 'one-sided', got {scheme!r}")
        if heights not in ("halve", "clip", "free"):
            raise ValueError(f"heights must be 'halve', 'clip' or 'free', got {heights!r}")
        h = step * max(1.0, float(np.max(np.abs(x), initial=0.0))) if relative else float(step)
        size = x.size
        base = self(x)[0] if scheme == "one-sided" else None
        Jc, Jf, Jb = (np.empty((size, size)) for _ in range(3))
        for k in range(size):
            height = self.method != "soft" and k >= self.m
            hp = hm = h
            if height and heights == "halve":
                hp = hm = min(h, 0.5 * x[k]) if x[k] > 0 else h
            elif height and heights == "clip":
                hm = x[k] - max(x[k] - h, 0.0)
            xp, xm = x.copy(), x.copy()
            xp[k] += hp
            xm[k] -= hm
            fp = self(xp)[0]
            if tick is not None:
                tick()
            fm = self(xm)[0]
            if tick is not None:
                tick()
            if scheme == "central":
                Jc[:, k] = (fp - fm) / (hp + hm)
            else:
                Jf[:, k] = (fp - base) / hp
                Jb[:, k] = (base - fm) / hm
        return Jc if scheme == "central" else (Jf, Jb)
