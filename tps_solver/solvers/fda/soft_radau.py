r"""The soft contact integrated by scipy's ``Radau`` (the reference integrator of the soft model).

The model (a spring-dashpot acting while :math:`\zeta < 0`, cut-off length
:math:`\ell = \sqrt{\nu\tau_c}`) is stated in :mod:`tps_solver.model.soft_flat`.
Every contact entry is a discontinuity of the right-hand side that Radau
resolves by step rejection: accurate, but slow (near a flat layer 1-3 s per
period for 9-17 nodes; a 33-node kink about 1900 steps per time unit once
contacts repeat at the front).  It is kept as the reference that faster soft
integrators are tested against.
"""
import math

import numpy as np
import scipy.integrate
import scipy.optimize
import scipy.sparse

from tps_solver.core.checks import check_positive
from tps_solver.model.soft_flat import soft_contact_parameters
from tps_solver.solvers.fda.base import Integrator, Step

__all__ = ["RadauSoftIntegrator"]


class RadauSoftIntegrator(Integrator):
    r"""The soft contact by ``scipy.integrate.Radau`` with a sparse analytic Jacobian.

    Options
    -------
    cutoff : float
        :math:`\ell = \sqrt{\nu\tau_c} > 0` (required).
    rtol, atol : float
        Radau tolerances (``rtol`` is floored at 1e-10, below which Radau's
        Newton iteration stalls on the contact switches).
    max_step : float, optional
        Largest step; default ``tau_c / 4`` so that no contact is stepped over.

    Events are one ``"impact"`` record per contact entry (:math:`\zeta`
    crossing 0 downwards, located on the dense output) with the entry velocity;
    ``stuck`` marks the nodes in contact.

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver import Lattice, simulate
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> run = simulate(lat, 2.5, 0.45, np.full(5, -1.0), np.full(5, 0.01), t_end=0.2,
    ...                method="soft-radau", cutoff=0.3)
    >>> bool(run.events.size == 5 and np.ptp(run.w) < 1e-12)
    True
    """

    name = "soft-radau"
    impulsive = False
    OPTIONS = {"cutoff": None, "rtol": 1e-10, "atol": 1e-12, "max_step": None}

    def __init__(self, lattice, Gamma, e, **options):
        super().__init__(lattice, Gamma, e, **options)
        opts = self.options
        if opts["cutoff"] is None:
            raise ValueError(f"cutoff must be a finite number > 0 when method={self.name!r}, got None")
        self.cutoff = check_positive(opts["cutoff"], "cutoff")
        self.tau_c, self.omega0_sq, self.beta = soft_contact_parameters(e, self.cutoff)
        self.rtol = max(check_positive(opts["rtol"], "rtol"), 1e-10)
        self.atol = check_positive(opts["atol"], "atol")
        self.max_step = (0.25 * self.tau_c if opts["max_step"] is None
                         else check_positive(opts["max_step"], "max_step"))
        self.cutoff_info = {"kind": "soft contact", "length": self.cutoff, "tau_c": self.tau_c}
        n = lattice.n_nodes
        L = scipy.sparse.csr_matrix(lattice.operator)
        inv_G = 1.0 / Gamma
        om2, beta = self.omega0_sq, self.beta
        eye = scipy.sparse.identity(n, format="csr")

        def fun(t, y):
            wv, zv = y[:n], y[n:]
            g = math.sin(t) - inv_G
            dw = L @ wv + g
            c = zv < 0.0
            dw[c] -= g + om2 * zv[c] + 2.0 * beta * wv[c]
            return np.concatenate((dw, wv))

        def jac(t, y):
            C = scipy.sparse.diags((y[n:] < 0.0).astype(float))
            return scipy.sparse.bmat([[L - 2.0 * beta * C, -om2 * C], [eye, None]], format="csc")

        self._fun, self._jac = fun, jac
        self._solver = None

    def _start(self, t, w, zeta, t_stop):
        self._solver = scipy.integrate.Radau(self._fun, t, np.concatenate((w, zeta)), t_stop,
                                             rtol=self.rtol, atol=self.atol, jac=self._jac,
                                             max_step=self.max_step)
        self._t_stop = t_stop

    def advance(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """One Radau step (see :meth:`Integrator.advance`); contact entries are logged as events."""
        n = w.size
        solver = self._solver
        if solver is None or solver.t != t or self._t_stop != t_stop:
            self._start(t, w, zeta, t_stop)
            solver = self._solver
        ta, ya = solver.t, solver.y.copy()
        failure = solver.step()
        self.n_steps += 1
        if solver.status == "failed":
            raise RuntimeError(f"Radau failed at t = {solver.t:.15g}: {failure}")
        tb, yb = solver.t, solver.y
        dense = solver.dense_output()
        events = []
        for j in np.flatnonzero((ya[n:] >= 0.0) & (yb[n:] < 0.0)):
            tc = scipy.optimize.brentq(lambda s, j=j: dense(s)[n + j], ta, tb, xtol=1e-14)
            events.append((tc, int(j), "impact", float(dense(tc)[j])))
        events.sort()
        t_eval = np.asarray(t_eval, dtype=float)
        samples = []
        for te in t_eval[(t_eval > ta) & (t_eval <= tb)]:
            y = dense(te) if te < tb else yb
            samples.append((float(te), y[:n].copy(), y[n:].copy()))
        return Step(t=float(tb), w=yb[:n].copy(), zeta=yb[n:].copy(), samples=samples, events=events,
                    stuck=yb[n:] < 0.0)
