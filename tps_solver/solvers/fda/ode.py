r"""The paper's Method (2): a scipy ODE solver stepped by hand with event detection.

The free nodes obey (53), :math:`\dot{\underline w}_F = \underline L_{FF}\underline w_F + g\underline\sigma_F`,
:math:`\dot{\underline\zeta}_F = \underline w_F`.  A scipy ``OdeSolver``
(``DOP853`` by default) is advanced one step at a time; on each step its dense
output is sampled at ``samples + 1`` points and *all* event functions -- the
heights of the free nodes and minus the free accelerations of the stuck nodes
-- are scanned for a sign change from ``>= 0`` to ``< 0`` at once (vectorised).
The earliest sampled sub-interval with a sign change is refined by ``brentq``
on the minimum of the crossing functions, the simultaneous sets are formed by
the shared rule :func:`~.events.event_sets`, and the solver is restarted after
the event.  Unlike :mod:`.exact`, a double crossing inside one sample
sub-interval can be missed; this is the method's documented weakness.
"""
import math

import numpy as np
import scipy.integrate
from scipy.optimize import brentq

from tps_solver.core.checks import check_choice, check_int, check_positive
from tps_solver.solvers.fda.base import Integrator, Step
from tps_solver.solvers.fda.events import event_sets

__all__ = ["OdePropagator"]

SOLVERS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
_IMPLICIT = ("Radau", "BDF", "LSODA")


class OdePropagator(Integrator):
    """Event search on the dense output of a scipy ``OdeSolver`` (``method="ode"``).

    Options
    -------
    time_tol : float
        Simultaneity window of a contact set (default 1e-9).
    rtol, atol : float
        Solver tolerances (default 1e-12).
    ode_solver : str
        One of ``"DOP853"`` (default), ``"RK45"``, ``"RK23"``, ``"Radau"``, ``"BDF"``, ``"LSODA"``.
    samples_per_step : int
        Dense-output samples per step for the sign-change scan (default 8).

    Examples
    --------
    The landing of a uniformly launched flat layer, one period ``T = 4 pi`` later
    (the exact value of :class:`~tps_solver.solvers.fda.exact.ExactPropagator`):

    >>> import numpy as np
    >>> from tps_solver import FlatLayer, Lattice
    >>> fl = FlatLayer(2.5, 2, e=0.45)
    >>> prop = OdePropagator(Lattice.planar(n_nodes=3, length=2.0), 2.5, 0.45)
    >>> step = prop.advance(fl.t0, np.full(3, fl.velocity(fl.t0)), np.zeros(3), np.zeros(3, dtype=bool),
    ...                     t_stop=fl.t0 + fl.period + 1.0)
    >>> bool(abs(step.t - fl.t0 - 4 * np.pi) < 1e-9), step.contact.tolist()
    (True, [0, 1, 2])
    """

    name = "ode"
    OPTIONS = {"time_tol": 1e-9, "rtol": 1e-12, "atol": 1e-12, "ode_solver": "DOP853",
               "samples_per_step": 8}

    def __init__(self, lattice, Gamma, e, **options):
        super().__init__(lattice, Gamma, e, **options)
        opts = self.options
        self.time_tol = check_positive(opts["time_tol"], "time_tol")
        self.rtol = check_positive(opts["rtol"], "rtol")
        self.atol = check_positive(opts["atol"], "atol")
        solver = check_choice(opts["ode_solver"], "ode_solver", SOLVERS)
        self.solver = getattr(scipy.integrate, solver)
        self.implicit = solver in _IMPLICIT
        self.samples = check_int(opts["samples_per_step"], "samples_per_step", minimum=2)

    def advance(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """Propagate to the next event or ``t_stop`` (see :meth:`Integrator.advance`)."""
        return Step(*self._locate(t, w, zeta, stuck, t_stop, t_eval))

    def _locate(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """The next event as ``(t_new, w, zeta, contact, liftoff, samples)`` (pre-event state)."""
        Gamma = self.Gamma
        L = self.lattice.operator
        F, S = np.flatnonzero(~stuck), np.flatnonzero(stuck)
        nf = F.size
        L_FF = L[np.ix_(F, F)]
        L_SF = L[np.ix_(S, F)]
        t_eval = np.asarray(t_eval, dtype=float)
        n = w.size

        def fun(s, y):
            wf = y[:nf]
            return np.concatenate((L_FF @ wf + (math.sin(s) - 1.0 / Gamma), wf))

        def full(y):
            wn, zn = np.zeros(n), np.zeros(n)
            wn[F], zn[F] = y[:nf], y[nf:]
            return wn, zn

        samples = []
        y0 = np.concatenate((w[F], zeta[F]))
        if nf:
            kwargs = {}
            if self.implicit:
                jac = np.zeros((2 * nf, 2 * nf))
                jac[:nf, :nf] = L_FF
                jac[nf:, :nf] = np.eye(nf)
                kwargs["jac"] = jac
            solver = self.solver(fun, t, y0, t_stop, rtol=self.rtol, atol=self.atol, **kwargs)
        else:
            solver = None
        ta = t
        while True:
            if solver is not None:
                solver.step()
                self.n_steps += 1
                if solver.status == "failed":
                    raise RuntimeError(f"ODE solver failed at t = {solver.t:.15g}: {solver.message}")
                tb = solver.t
                dense = solver.dense_output()
            else:                       # everything stuck: only lift-off can happen
                tb = min(ta + 0.25, t_stop)
                self.n_steps += 1

                def dense(s, _n=2 * nf):
                    return np.zeros((_n,) + np.shape(s))
            ts = np.linspace(ta, tb, self.samples + 1)
            Y = dense(ts)
            Wf, Zf = Y[:nf], Y[nf:]
            gs = np.sin(ts) - 1.0 / Gamma
            f = np.vstack((Zf, -(gs[None, :] + L_SF @ Wf)))
            cross = (f[:, :-1] >= 0.0) & (f[:, 1:] < 0.0)
            cols = np.flatnonzero(np.any(cross, axis=0))
            if cols.size:
                q = int(cols[0])
                rows = np.flatnonzero(cross[:, q])

                def frows(s):
                    y = dense(s)
                    gs = np.sin(s) - 1.0 / Gamma
                    vals = np.concatenate((y[nf:], -(gs + L_SF @ y[:nf])))
                    return vals[rows]
                t_c, lead = self._refine(frows, ts[q], ts[q + 1])
                self._sample(dense, full, ta, t_c, t_eval, samples)
                y = dense(t_c)
                wF, zF = y[:nf], y[nf:]
                eps_z = 10.0 * self.atol
                eps_a = 10.0 * self.atol * (1.0 + np.abs(L_SF).sum(axis=1))
                contact, liftoff = event_sets(t_c, wF, zF, F, S, L_FF, L_SF, Gamma, self.time_tol,
                                              eps_z, eps_a)
                if contact.size == 0 and liftoff.size == 0:
                    # guarantee progress: the detected crossing itself is the event
                    r = int(rows[lead])
                    if r < nf:
                        contact = F[[r]]
                    else:
                        liftoff = S[[r - nf]]
                return (float(t_c),) + full(y) + (contact, liftoff, samples)
            self._sample(dense, full, ta, tb, t_eval, samples)
            if tb >= t_stop:
                return (float(t_stop),) + full(dense(t_stop)) + (np.empty(0, int), np.empty(0, int), samples)
            ta = tb

    @staticmethod
    def _refine(frows, lo, hi, levels=4, k=32):
        """Earliest zero of the crossing rows in [lo, hi]; rows may start at zero (just bounced).

        Sub-samples with ``k`` points per level, looking for a strict ``> 0`` to
        ``< 0`` change, and zooms into the first sub-interval if a row goes
        from 0 straight to negative.  Returns ``(t_c, row)``.
        """
        for _ in range(levels):
            sub = np.linspace(lo, hi, k + 1)
            vals = np.column_stack([frows(s) for s in sub])
            neg = vals[:, 1:] < 0.0
            cols = np.flatnonzero(np.any(neg, axis=0))
            if cols.size == 0:          # round-off: the crossing sits at hi
                return hi, int(np.argmin(frows(hi)))
            c = int(cols[0])
            r = np.flatnonzero(neg[:, c])
            if np.all(vals[r, c] > 0.0):
                a, b = sub[c], sub[c + 1]
                t_c = brentq(lambda s: float(np.min(frows(s)[r])), a, b, xtol=1e-15,
                             rtol=4 * np.finfo(float).eps)
                return t_c, int(r[np.argmin(frows(t_c)[r])])
            lo, hi = sub[c], sub[c + 1]
        return lo, int(np.argmin(frows(lo)))

    @staticmethod
    def _sample(dense, full, ta, tb, t_eval, samples):
        if t_eval.size == 0:
            return
        for te in t_eval[(t_eval > ta) & (t_eval <= tb)]:
            samples.append((float(te),) + full(dense(te)))
