r"""The event layer shared by both integrators: impacts (54), sticking, lift-off.

Rules (stated once, used by ``method="exact"`` and ``method="ode"``):

* **Contact set (54).**  All free nodes that reach :math:`\zeta = 0` within the
  integrator's simultaneity window of the earliest contact are one set
  :math:`\mathscr P` and are processed together: :math:`\zeta = 0` and the
  impact rule is applied to the pre-impact velocities of the whole set.
* **Impact rule.**  A small replaceable function
  ``rule(w_minus, contact, e, lattice, free) -> w_plus`` (full arrays).
  ``"point"``: restitution (11)/(54), :math:`w^+ = -e\,w^-` on the set only.
  ``"diffused"``: the paper's (67) taken literally (unnormalised),
  :math:`w^+(r) = w^-(r) - (1+e)\sum_{c\in\mathscr P} w^-(r_c)\,e^{-|r-r_c|/\rho_c}`
  on the free nodes (stuck nodes stay stuck).  This is the extension point for
  a regularised impact model with a physical cut-off length.
* **Sticking (docs/design.md, hazard 4).**  A contact node whose impact speed is at most
  ``stick_velocity`` (a chattering sequence: the remaining bounces of the
  geometric series have heights below ``stick_velocity**2 / (2|a|)``), or whose
  rebound velocity is not positive (``e = 0``), is set to :math:`w = \zeta = 0`;
  it *sticks* if its free acceleration :math:`a = g + (\underline L\underline w)_i`
  is :math:`\le 0`, otherwise it stays free at rest and lifts off at once.
* **Lift-off.**  A stuck node is released (:math:`w = \zeta = 0`, free) when its
  free acceleration becomes positive (Sec. 4 after (37): :math:`g \to H(\zeta)g`),
  including at once when an impact next to it makes it jump positive.
* **Event bound.**  More than ``max_events_per_cycle`` events within one forcing
  cycle :math:`2\pi` end the run with ``status = 6`` and the state so far.

Every event is logged as a record ``(t, node, kind, w_before)`` with ``kind`` in
``{"impact", "stick", "liftoff"}``; an impact that ends in sticking is logged
once, as ``"stick"``, with its impact velocity.
"""
import math
import weakref

import numpy as np

from tps_solver.core.checks import check_choice, check_nonnegative, check_positive
from tps_solver.model.restitution import RestitutionLaw
from tps_solver.solvers.fda.runs import Tridiagonal

__all__ = ["EVENT_DTYPE", "point_impact", "diffused_impact", "make_impact_rule", "EventLog",
           "event_sets", "apply_contacts", "apply_liftoff", "pulled_off", "tridiagonal"]

EVENT_DTYPE = np.dtype([("t", float), ("node", np.int64), ("kind", "U7"), ("w_before", float)])
IMPACTS = ("point", "diffused")
_EPS = np.finfo(float).eps
_EPS64 = float(64 * _EPS)


def restitution_at(e, w_contact):
    """The restitution of each landing: ``e`` itself (float), or a law at the impact speeds ``-w_contact``.

    Parameters
    ----------
    e : float or RestitutionLaw
    w_contact : ndarray of float
        Pre-impact velocities of the landing nodes (<= 0).

    Returns
    -------
    e : float or ndarray of float, shape of ``w_contact``

    Examples
    --------
    >>> from tps_solver.model.restitution import PowerLawRestitution
    >>> restitution_at(PowerLawRestitution(0.5, 4.0), np.array([-4.0, -0.0])).tolist()
    [0.5, 1.0]
    """
    if isinstance(e, RestitutionLaw):
        return e(np.maximum(-np.asarray(w_contact, dtype=float), 0.0))
    return e


def point_impact(w_minus, contact, e, lattice, free):
    """Restitution (54): ``w+ = -e w-`` on the contact set, other nodes unchanged.

    Parameters
    ----------
    w_minus : ndarray of float, shape (n_nodes,)
    contact : ndarray of int
    e : float or RestitutionLaw
        A law is evaluated at each node's impact speed ``-w_minus``.
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)

    Returns
    -------
    w_plus : ndarray of float, shape (n_nodes,)

    Examples
    --------
    >>> point_impact(np.array([-1.0, -2.0]), np.array([1]), 0.5, None, None)
    array([-1.,  1.])
    """
    w = w_minus.copy()
    w[contact] = -restitution_at(e, w_minus[contact]) * w_minus[contact]
    return w


def diffused_impact(w_minus, contact, e, lattice, free, rho_c):
    r"""The diffused Stosslet (67), literal and unnormalised, on the free nodes.

    :math:`w^+(r) = w^-(r) - (1+e)\sum_{c} w^-(r_c)\exp(-|r - r_c|/\rho_c)`.

    Examples
    --------
    The contact node gets the point rule's :math:`-e w^-`, its neighbours at distance 1
    a kick :math:`(1 + e)e^{-1}`:

    >>> from tps_solver import Lattice
    >>> lat = Lattice.planar(n_nodes=3, length=2.0)
    >>> w = diffused_impact(-np.ones(3), np.array([1]), 0.5, lat, np.ones(3, dtype=bool), 1.0)
    >>> bool(np.allclose(w, [-1 + 1.5 / np.e, 0.5, -1 + 1.5 / np.e]))
    True
    """
    d = np.abs(lattice.nodes[:, None] - lattice.nodes[contact][None, :])
    wc = w_minus[contact]
    kick = -(np.exp(-d / rho_c) @ ((1.0 + restitution_at(e, wc)) * wc))
    w = w_minus.copy()
    w[free] += kick[free]
    return w


def make_impact_rule(impact="point", rho_c=None):
    """Return the impact rule for ``impact`` ("point" | "diffused" with ``rho_c``) or a callable.

    Returns
    -------
    rule : callable
        ``rule(w_minus, contact, e, lattice, free) -> w_plus``.
    cutoff : dict
        ``{"kind": ..., "length": ...}``: the cut-off length in force (docs/design.md, hazard 8);
        for point impacts it is the lattice spacing (filled in by the caller).

    Examples
    --------
    >>> rule, cutoff = make_impact_rule("point")
    >>> rule is point_impact, cutoff
    (True, {'kind': 'lattice spacing', 'length': None})
    >>> make_impact_rule("diffused", rho_c=0.5)[1]
    {'kind': 'diffused Stosslet (67)', 'length': 0.5}
    >>> make_impact_rule("diffused")
    Traceback (most recent call last):
    ...
    ValueError: rho_c must be a finite number > 0 when impact='diffused', got None
    """
    if callable(impact):
        declared = getattr(impact, "cutoff", None)
        if isinstance(declared, dict) and "length" in declared:
            return impact, dict(declared)
        return impact, {"kind": "custom", "length": None}
    impact = check_choice(impact, "impact", IMPACTS)
    if impact == "point":
        if rho_c is not None:
            check_nonnegative(rho_c, "rho_c")
        return point_impact, {"kind": "lattice spacing", "length": None}
    rho_c = check_positive(rho_c, "rho_c") if rho_c is not None else None
    if rho_c is None:
        raise ValueError("rho_c must be a finite number > 0 when impact='diffused', got None")

    def rule(w_minus, contact, e, lattice, free):
        return diffused_impact(w_minus, contact, e, lattice, free, rho_c)
    return rule, {"kind": "diffused Stosslet (67)", "length": rho_c}


class EventLog:
    """Time-ordered event records with a per-cycle budget (docs/design.md, hazard 4).

    The records are stored one block per :meth:`add` call (one contact set: arrays of nodes
    and velocities) and expanded to one row per node only by :meth:`to_array`.

    Parameters
    ----------
    t_start : float
        Start of the run; forcing cycles :math:`2\\pi` are counted from it.
    max_events_per_cycle : int
        :attr:`exceeded` turns True once one cycle holds more events.

    Examples
    --------
    >>> log = EventLog(0.0, max_events_per_cycle=2)
    >>> log.add(1.0, np.array([0, 2]), "impact", np.array([-0.5, -0.4]))
    >>> log.exceeded
    False
    >>> log.add(2.0, 1, "stick", -0.01)          # a third event in the first cycle
    >>> log.exceeded, log.to_array().node.tolist(), len(log)
    (True, [0, 2, 1], 3)
    >>> log.add(7.0, 1, "liftoff", 0.0)          # the next cycle starts a new count
    >>> log.exceeded
    False
    >>> log.records[:2]
    [(1.0, 0, 'impact', -0.5), (1.0, 2, 'impact', -0.4)]
    """

    def __init__(self, t_start, max_events_per_cycle):
        self.t_start = t_start
        self.max_per_cycle = max_events_per_cycle
        self._cycle = 0
        self._count = 0
        self._n = 0
        self._t, self._nodes, self._kinds, self._w = [], [], [], []

    def add(self, t, nodes, kind, w_before):
        """Log the events of ``nodes`` (int or ndarray of int) at time ``t``, all of one ``kind``.

        ``w_before`` (float or ndarray of float) holds one velocity per node, or one for all.
        """
        cycle = int(math.floor((t - self.t_start) / (2.0 * math.pi)))
        if cycle != self._cycle:
            self._cycle, self._count = cycle, 0
        nodes = np.array(nodes, dtype=np.int64).reshape(-1)
        k = nodes.size
        self._count += k
        if k == 0:
            return
        wb = np.array(w_before, dtype=float).reshape(-1)
        if wb.size != k:
            if wb.size != 1:
                raise ValueError(f"w_before must hold one value per node ({k}) or one value, "
                                 f"got {wb.size}")
            wb = np.full(k, wb[0])
        self._t.append(float(t))
        self._nodes.append(nodes)
        self._kinds.append(kind)
        self._w.append(wb)
        self._n += k

    def __len__(self):
        return self._n

    @property
    def exceeded(self):
        """True once a forcing cycle holds more events than allowed."""
        return self._count > self.max_per_cycle

    @property
    def records(self):
        """The records as a list of tuples ``(t, node, kind, w_before)``, in time order."""
        return [(t, j, kind, wb) for t, nodes, kind, w in zip(self._t, self._nodes, self._kinds, self._w)
                for j, wb in zip(nodes.tolist(), w.tolist())]

    def to_array(self):
        """The records as a ``numpy.recarray`` with fields t, node, kind, w_before (:data:`EVENT_DTYPE`)."""
        arr = np.empty(self._n, dtype=EVENT_DTYPE)
        if self._n:
            sizes = [a.size for a in self._nodes]
            arr["t"] = np.repeat(np.array(self._t, dtype=float), sizes)
            arr["node"] = np.concatenate(self._nodes)
            arr["kind"] = np.repeat(np.array(self._kinds, dtype=EVENT_DTYPE["kind"]), sizes)
            arr["w_before"] = np.concatenate(self._w)
        return arr.view(np.recarray)


def event_sets(t, wF, zF, F, S, L_FF, L_SF, Gamma, time_tol, eps_z, eps_a, *, absL_FF=None):
    r"""The simultaneous contact set (54) and lift-off set at an event time ``t``.

    A free node belongs to the contact set if it is approaching the plate
    (:math:`w < 0`, or :math:`w = 0` with :math:`a \le 0`) and its height is at most
    ``max(time_tol * |w|, eps_z)``, i.e. it reaches the plate within ``time_tol``
    of ``t`` (or is at the plate to round-off).  A stuck node lifts off if its
    free acceleration :math:`a` is positive beyond round-off ``eps_a``, or is within
    ``time_tol`` of turning positive with :math:`\dot a > 0`.

    Parameters
    ----------
    t : float
    wF, zF : ndarray of float, shape (n_free,)
        Velocities and heights of the free nodes ``F``.
    F, S : ndarray of int, shape (n_free,), (n_stuck,)
        Free and stuck node indices.
    L_FF, L_SF : ndarray of float, shape (n_free, n_free), (n_stuck, n_free)
        Blocks of the lattice operator.
    Gamma, time_tol : float
    eps_z : float or ndarray of float, shape (n_free,)
        Height round-off, >= 0.
    eps_a : float or ndarray of float, shape (n_stuck,)
        Acceleration round-off of the stuck nodes.
    absL_FF : ndarray of float, shape (n_free, n_free), optional
        ``abs(L_FF)``, if the caller holds it (it is formed here otherwise, and only when a
        node on the plate is at rest to round-off).

    Returns
    -------
    contact, liftoff : ndarray of int
        Node indices.

    Examples
    --------
    Nodes 0 and 1 free, node 2 stuck, at :math:`t = \pi/2` (:math:`g = 0.6`): node 0 is on
    the plate moving down (contact); node 2 is pulled up by :math:`g + 2w_1 > 0` (lift-off):

    >>> from tps_solver import Lattice
    >>> L = Lattice.planar(n_nodes=3, length=2.0).operator
    >>> F, S = np.array([0, 1]), np.array([2])
    >>> event_sets(np.pi / 2, np.array([-1.0, 0.5]), np.array([0.0, 1.0]), F, S,
    ...            L[np.ix_(F, F)], L[np.ix_(S, F)], 2.5, 1e-12, 1e-14, 1e-14)
    (array([0]), array([2]))
    """
    g = math.sin(t) - 1.0 / Gamma
    abs_w = np.abs(wF)
    eps_w = _EPS64 * (1.0 + float(abs_w.max(initial=0.0)))
    # on the plate within time_tol (max(time_tol * max(-w, 0), eps_z) = max(-time_tol * w, eps_z)
    # for eps_z >= 0); approaching if w < -eps_w, or |w| <= eps_w with a < -eps_acc
    hit = zF <= np.maximum(wF * -time_tol, eps_z)
    contact = hit & (wF < -eps_w)
    accF = None
    n_hit = np.count_nonzero(hit)
    if n_hit and np.count_nonzero(contact) < n_hit:        # a node on the plate with |w| <= eps_w
        rest = hit & (abs_w <= eps_w)
        accF = L_FF @ wF + g
        if absL_FF is None:
            absL_FF = np.abs(L_FF)
        eps_acc = _EPS64 * (1.0 + abs(g) + absL_FF @ abs_w)
        contact |= rest & (accF < -eps_acc)
    contact = F[contact]
    if S.size == 0:
        return contact, S[:0]
    if accF is None:
        accF = L_FF @ wF + g
    accS = g + L_SF @ wF
    daccS = math.cos(t) + L_SF @ accF
    near = accS >= -np.maximum(time_tol * np.maximum(daccS, 0.0), eps_a)
    liftoff = S[(accS > eps_a) | (near & (daccS > 0.0))]
    return contact, liftoff


def apply_contacts(t, w, zeta, stuck, contact, lattice, Gamma, e, rule, stick_velocity, log):
    """Process one simultaneous contact set in place (restitution, sticking). Returns the stuck nodes.

    Examples
    --------
    At :math:`t = 0` (:math:`g = -0.4`) node 1 lands at a speed below ``stick_velocity``;
    its free acceleration is negative, so it sticks (logged once, as ``"stick"``):

    >>> from tps_solver import Lattice
    >>> lat = Lattice.planar(n_nodes=3, length=2.0)
    >>> w, zeta, stuck = np.array([-1.0, -0.05, -1.0]), np.array([0.3, 0.0, 0.3]), np.zeros(3, dtype=bool)
    >>> log = EventLog(0.0, 100)
    >>> apply_contacts(0.0, w, zeta, stuck, np.array([1]), lat, 2.5, 0.5, point_impact, 0.1, log)
    array([1])
    >>> w.tolist(), stuck.tolist(), log.records
    ([-1.0, 0.0, -1.0], [False, True, False], [(0.0, 1, 'stick', -0.05)])

    A faster landing rebounds with :math:`w^+ = -e w^-`:

    >>> w = np.array([-1.0, -2.0, -1.0])
    >>> apply_contacts(0.0, w, zeta, np.zeros(3, dtype=bool), np.array([1]), lat, 2.5, 0.5, point_impact, 0.1, log).size
    0
    >>> w.tolist(), log.records[-1]
    ([-1.0, 1.0, -1.0], (0.0, 1, 'impact', -2.0))
    """
    w_minus = w[contact]
    w_new = rule(w, contact, e, lattice, ~stuck)
    w_new[stuck] = 0.0
    zeta[contact] = 0.0
    slow = (np.abs(w_minus) <= stick_velocity) | (w_new[contact] <= 0.0)
    if not np.count_nonzero(slow):
        w[:] = w_new
        if contact.size:
            log.add(t, contact, "impact", w_minus)
        return np.empty(0, dtype=int)
    cand = contact[slow]
    w_new[cand] = 0.0
    acc = math.sin(t) - 1.0 / Gamma + lattice.operator[cand] @ w_new
    sticking = acc <= 0.0
    sticks = cand[sticking]
    stuck[sticks] = True
    w[:] = w_new
    is_stick = slow.copy()
    is_stick[slow] = sticking
    if not is_stick.all():
        log.add(t, contact[~is_stick], "impact", w_minus[~is_stick])
    if sticks.size:
        log.add(t, sticks, "stick", w_minus[is_stick])
    return sticks


def apply_liftoff(t, w, zeta, stuck, nodes, log):
    """Release stuck nodes in place at rest on the plate.

    Examples
    --------
    >>> w, zeta, stuck = np.zeros(3), np.zeros(3), np.array([True, True, False])
    >>> log = EventLog(0.0, 100)
    >>> apply_liftoff(1.0, w, zeta, stuck, np.array([0]), log)
    >>> stuck.tolist(), log.records
    ([False, True, False], [(1.0, 0, 'liftoff', 0.0)])
    """
    stuck[nodes] = False
    w[nodes] = 0.0
    zeta[nodes] = 0.0
    log.add(t, nodes, "liftoff", np.zeros(np.size(nodes)))


_TRIDIAGONAL = weakref.WeakKeyDictionary()


def tridiagonal(lattice):
    """The :class:`~tps_solver.solvers.fda.runs.Tridiagonal` form of ``lattice.operator`` (kept per lattice).

    Examples
    --------
    >>> from tps_solver import Lattice
    >>> lat = Lattice.planar(n_nodes=4, length=3.0)
    >>> tridiagonal(lat) is tridiagonal(lat), tridiagonal(lat).diag.tolist()
    (True, [-2.0, -2.0, -2.0, -2.0])
    """
    tri = _TRIDIAGONAL.get(lattice)
    if tri is None or tri.n != lattice.n_nodes:
        tri = _TRIDIAGONAL[lattice] = Tridiagonal(lattice.operator)
    return tri


def pulled_off(t, w, stuck, lattice, Gamma, kernel=None):
    """Stuck nodes whose free acceleration is positive beyond round-off right now.

    ``kernel``: :func:`~tps_solver.solvers.fda.run_kernels.tri_pulled_off` (the compiled loop, the
    same arithmetic) or None (numpy, the reference).

    Called after a contact set is processed: an impact next to a stuck node
    changes :math:`(\\underline L\\underline w)_i` discontinuously and may pull the node
    off the plate at the same instant.

    Examples
    --------
    Node 1 is stuck at :math:`t = 0` (:math:`g = -0.4`); a neighbour's rebound at
    :math:`w = 1` gives it the free acceleration :math:`g + 1 > 0`:

    >>> from tps_solver import Lattice
    >>> lat = Lattice.planar(n_nodes=3, length=2.0)
    >>> stuck = np.array([False, True, False])
    >>> pulled_off(0.0, np.array([1.0, 0.0, 0.0]), stuck, lat, 2.5)
    array([1])
    >>> pulled_off(0.0, np.array([0.2, 0.0, 0.0]), stuck, lat, 2.5).size       # g + 0.2 < 0
    0
    """
    tri = tridiagonal(lattice)           # O(n): the operator is tridiagonal
    g = math.sin(t) - 1.0 / Gamma
    if kernel is not None:
        out = np.empty(w.size, dtype=np.int64)
        return out[:kernel(g, w, stuck, tri.lower, tri.diag, tri.upper, out)]
    S = np.flatnonzero(stuck)
    if S.size == 0:
        return S
    acc = g + tri.apply(w)[S]
    if not np.count_nonzero(acc > 0.0):       # eps_a > 0: no node is pulled off
        return S[:0]
    eps_a = _EPS64 * (1.0 + abs(g) + tri.apply_abs(np.abs(w))[S])
    return S[acc > eps_a]
