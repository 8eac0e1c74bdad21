r"""Dense output of an impulsive FDA run, kept apart from the result: :class:`PiecewiseFlow`.

Between two event sets the free nodes of the FDA (53) follow one linear flow with the
stuck nodes held at :math:`w = \zeta = 0`; :class:`~tps_solver.solvers.fda.exact.Segment`
writes it in closed form, eqs. (55)-(56), from the state just after the events.  The
record ``simulate(..., record_segments=True).segments`` (the state after every event
set) therefore determines the run at every instant, exactly; :class:`PiecewiseFlow`
evaluates it without integrating again.  This holds for every impulsive method
(``"exact"``, ``"point"``, ``"ode"``: one model, three integrators); the soft contact's
flow between switches is another one and is not covered.
"""
from collections import OrderedDict

import numpy as np

from tps_solver.solvers.fda.exact import Modes, Segment

__all__ = ["PiecewiseFlow"]


class PiecewiseFlow:
    r"""Exact evaluation of an impulsive FDA run from its segment record.

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
    segments : Bunch
        ``t`` (k,), ``w``, ``zeta`` (k, n_nodes) and ``stuck`` (k, n_nodes) bool: the state
        after each event set, as recorded by ``simulate(..., record_segments=True)``.
    t_end : float
        End of the recorded interval.

    Notes
    -----
    At an event instant the value *before* the events is returned (the convention of
    ``simulate``'s ``t_eval``), except at the first record, whose state is returned as is.
    Free-set decompositions are cached (at most 64).

    Examples
    --------
    A perturbed flat layer on five nodes: the flow evaluated from the record agrees with
    the samples of the run itself.

    >>> import numpy as np
    >>> from tps_solver import FlatLayer, Lattice, simulate
    >>> fl = FlatLayer(2.5, 2, e=0.45)
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> t0 = fl.t0 + 1.0
    >>> w0 = np.full(5, fl.velocity(t0)) + 1e-3 * np.arange(5)
    >>> te = t0 + np.linspace(0.0, fl.period, 9)[1:]
    >>> run = simulate(lat, 2.5, 0.45, w0, np.full(5, fl.height(t0)), t_start=t0, t_end=t0 + fl.period,
    ...                t_eval=te, record_segments=True)
    >>> flow = PiecewiseFlow(lat, 2.5, run.segments, run.t)
    >>> w, z = flow(te)
    >>> bool(np.max(np.abs(z - run.zeta_eval)) < 1e-13 and np.max(np.abs(w - run.w_eval)) < 1e-13)
    True
    """

    def __init__(self, lattice, Gamma, segments, t_end):
        self.lattice = lattice
        self.Gamma = float(Gamma)
        self.t = np.asarray(segments.t, dtype=float)
        self.w = np.asarray(segments.w, dtype=float)
        self.zeta = np.asarray(segments.zeta, dtype=float)
        self.stuck = np.asarray(segments.stuck, dtype=bool)
        self.t_end = float(t_end)
        if self.t.size == 0:
            raise ValueError("segments must hold at least the initial state")
        self._modes = OrderedDict()

    def _modes_of(self, free):
        key = np.packbits(free).tobytes()
        md = self._modes.get(key)
        if md is None:
            md = Modes(self.lattice, free)
            self._modes[key] = md
            if len(self._modes) > 64:
                self._modes.popitem(last=False)
        return md

    def __call__(self, t):
        """Velocity and height at times ``t``: two arrays of shape (len(t), n_nodes).

        Raises ``ValueError`` for a time outside the recorded interval.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.size and (t.min() < self.t[0] or t.max() > self.t_end):
            raise ValueError(f"t must lie in the recorded interval [{self.t[0]}, {self.t_end}]")
        n = self.lattice.n_nodes
        w = np.zeros((t.size, n))
        z = np.zeros((t.size, n))
        k = np.maximum(np.searchsorted(self.t, t, side="left") - 1, 0)
        for i in np.unique(k):
            rows = np.flatnonzero(k == i)
            free = ~self.stuck[i]
            if not np.any(free):
                continue
            md = self._modes_of(free)
            seg = Segment(md, self.t[i], self.w[i, free], self.zeta[i, free], self.Gamma)
            for r in rows:
                wf, zf = seg.state(t[r] - self.t[i])
                w[r, free] = wf
                z[r, free] = zf
        return w, z
