r"""The contact pattern of one period of an FDA run, in the package's one alphabet.

:func:`pattern_from_events` reads the event log of ``simulate`` (records ``t``, ``node``,
``kind`` in {"impact", "stick", "liftoff"}) over one period and returns a
:class:`~tps_solver.core.pattern.ContactPattern`:

* an ``"impact"`` followed at the same instant by a ``"stick"`` of the node, or a lone
  ``"stick"``, is a landing to rest, ``"stick"``, whose lift-off is the node's next
  ``"liftoff"`` (for a node stuck at the section, its first lift-off of the period, one
  period later);
* an ``"impact"`` followed at the same instant by a ``"liftoff"`` (e = 0: the node lands with
  :math:`w^+ = 0` and its free acceleration is positive), or any impact at e = 0 that does
  not end at rest, is a touch-and-go, ``"touch"``;
* every other impact is a rebound, ``"bounce"`` (the FDA resolves each bounce of a chatter
  sequence, so its tail appears as bounces and a final stick, not as ``"chatter"``);
* a lift-off is ``"triggered"`` when a lattice neighbour (a node coupled to it by the
  lattice operator) lands within ``trigger_tol`` of it (mod the period), else ``"smooth"``.
"""
import numpy as np

from tps_solver.core.pattern import ContactPattern

__all__ = ["pattern_from_events"]

_SAME = 1e-12          # events of one node closer than this are one instant


def _neighbours(lattice):
    A = np.asarray(lattice.operator)
    off = (A != 0.0) & ~np.eye(A.shape[0], dtype=bool)
    return [np.flatnonzero(off[j] | off[:, j]) for j in range(A.shape[0])]


def pattern_from_events(events, lattice, period, t_start, stuck0=None, e=0.0, trigger_tol=1e-9):
    """The :class:`~tps_solver.core.pattern.ContactPattern` of one period of FDA events.

    Parameters
    ----------
    events : numpy.recarray
        Events of one period ``[t_start, t_start + period]`` with fields ``t`` (float),
        ``node`` (int) and ``kind`` (str), e.g. ``ShootingOrbit.events`` or a
        :class:`~tps_solver.SimulationResult`'s ``events``.
    lattice : Lattice
        The lattice of the run (its operator says which nodes are neighbours).
    period : float
    t_start : float
    stuck0 : array_like of bool, shape (n_nodes,), optional
        Nodes stuck to the plate at ``t_start``.
    e : float
        Restitution of the run (an impact at e = 0 that does not end at rest is a touch-and-go).
    trigger_tol : float
        A lift-off within this time of a neighbour's landing is triggered.

    Returns
    -------
    ContactPattern

    Raises
    ------
    ValueError
        If a lift-off has no landing to rest before it and its node was not stuck at the section.

    Examples
    --------
    Three nodes: node 1 lands to rest at t = 2, which pulls node 0 off the plate (a
    triggered lift-off of the rest node 0 had across the section); node 0 then touches and
    goes at t = 3 and lands to rest at t = 4; node 1 lifts off smoothly at t = 5; node 2
    rebounds at t = 6 (e > 0).

    >>> import numpy as np, tps_solver as tps
    >>> ev = np.rec.fromrecords([(2.0, 1, "impact"), (2.0, 1, "stick"), (2.0, 0, "liftoff"),
    ...                          (3.0, 0, "impact"), (3.0, 0, "liftoff"), (4.0, 0, "impact"),
    ...                          (4.0, 0, "stick"), (5.0, 1, "liftoff"), (6.0, 2, "impact")],
    ...                         names="t,node,kind")
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> p = pattern_from_events(ev, lat, 12.0, 0.0, stuck0=[True, False, False], e=0.3)
    >>> p.sequences(), p.liftoff.tolist()
    (['TS', 'S', 'B'], [nan, 14.0, 5.0, nan])
    >>> [str(c) for c in p.ended_by], p.trigger.tolist()
    (['', 'triggered', 'smooth', ''], [-1, 1, -1, -1])
    """
    n = lattice.n_nodes
    T = float(period)
    t_start = float(t_start)
    t = np.asarray(events.t, dtype=float)
    node = np.asarray(events.node, dtype=int)
    kind = np.asarray(events.kind).astype(str)
    stuck0 = np.zeros(n, dtype=bool) if stuck0 is None else np.asarray(stuck0, dtype=bool)
    landing = (kind == "impact") | (kind == "stick")
    nbrs = _neighbours(lattice)

    def cause(j, tl):
        others = landing & np.isin(node, nbrs[j])
        if np.any(others):
            d = np.mod(t[others] - tl, T)
            d = np.minimum(d, T - d)
            k = int(np.argmin(d))
            if d[k] < trigger_tol:
                return "triggered", int(node[others][k])
        return "smooth", -1

    c_node, c_t, c_kind, c_lift, c_end, c_trig = [], [], [], [], [], []
    for j in range(n):
        idx = np.flatnonzero(node == j)
        idx = idx[np.argsort(t[idx], kind="stable")]
        tj, kj = t[idx], kind[idx]
        first_lift = None                   # a rest across the section ends at this lift-off
        open_rest = None                    # index into c_* of the rest waiting for its lift-off
        i = 0
        while i < idx.size:
            same = i + 1 < idx.size and tj[i + 1] - tj[i] <= _SAME
            if kj[i] == "impact" and same and kj[i + 1] == "stick" or kj[i] == "stick":
                c_node.append(j); c_t.append(tj[i]); c_kind.append("stick")
                c_lift.append(np.nan); c_end.append("smooth"); c_trig.append(-1)
                open_rest = len(c_t) - 1
                i += 2 if kj[i] == "impact" else 1
            elif kj[i] == "impact":
                touch = same and kj[i + 1] == "liftoff"
                c_node.append(j); c_t.append(tj[i])
                c_kind.append("touch" if (touch or e == 0.0) else "bounce")
                c_lift.append(np.nan); c_end.append(""); c_trig.append(-1)
                i += 2 if touch else 1
            else:                           # a lift-off from rest
                if open_rest is not None:
                    c_lift[open_rest] = tj[i]
                    c_end[open_rest], c_trig[open_rest] = cause(j, tj[i])
                    open_rest = None
                elif first_lift is None and stuck0[j]:
                    first_lift = tj[i]
                else:
                    raise ValueError(f"events: node {j} lifts off at t = {tj[i]:.12g} with no landing to "
                                     "rest before it (and it was not stuck at the section)")
                i += 1
        if open_rest is not None:           # at rest across the end of the window
            if first_lift is None:
                raise ValueError(f"events: node {j} lands to rest at t = {c_t[open_rest]:.12g} and never "
                                 "lifts off within the period (pass stuck0, or a whole period of events)")
            c_lift[open_rest] = first_lift + T
            c_end[open_rest], c_trig[open_rest] = cause(j, first_lift)
    return ContactPattern.from_contacts(c_node, c_t, c_kind, n, T, t_start=t_start, liftoff=c_lift,
                                        ended_by=c_end, trigger=c_trig)
