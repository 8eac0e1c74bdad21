r"""The contact pattern of a periodic orbit: one shape and one alphabet for every solver.

A :class:`ContactPattern` lists the contacts of one period, per node in time order.
Each contact has a time, a **kind**, and, if it ends at rest on the plate, a
**lift-off** time and what ended the rest:

==========  ======  ====================================================================
kind        letter  meaning
==========  ======  ====================================================================
"bounce"    ``B``   an impact with restitution, :math:`w^+ = -e\,w^-`, e > 0 (11)
"touch"     ``T``   a touch-and-go: the node lands with :math:`w^+ = 0` and leaves at once
                    (its free acceleration is positive); e = 0, or an impact of a node
                    whose neighbour pulls it off
"stick"     ``S``   a landing to rest, :math:`w^+ = 0`; the node stays on the plate until
                    ``liftoff``
"chatter"   ``C``   a chatter sequence accumulating to rest (e > 0): the first impact of the
                    tail; the node is at rest from the accumulation until ``liftoff``
==========  ======  ====================================================================

The letters are those of :attr:`tps_solver.FlatLayer.contact_sequence`.  A lift-off
is ``"smooth"`` (the plate's reaction falls continuously to zero) or
``"triggered"`` (a neighbour's landing at the same instant makes the reaction jump
tensile; ``trigger`` is that neighbour); a contact without rest has ``liftoff =
nan`` and ``ended_by = ""``.

Times are in one window ``[t_start, t_start + period)``; a lift-off may fall after
the window's end (a rest across the section), i.e. ``liftoff - t`` is the time at
rest.  Every periodic result of the package (:class:`~tps_solver.core.orbit.PeriodicOrbit`)
carries its pattern in this form as ``pattern``.
"""
import numpy as np

from tps_solver.core.bunch import Bunch

__all__ = ["ContactPattern", "KINDS", "LETTERS", "LIFTOFF_CAUSES"]

#: contact kinds, in the one alphabet of the package
KINDS = ("bounce", "touch", "stick", "chatter")
#: kind -> letter of :attr:`tps_solver.FlatLayer.contact_sequence`
LETTERS = {"bounce": "B", "touch": "T", "stick": "S", "chatter": "C"}
#: what ends a rest on the plate
LIFTOFF_CAUSES = ("smooth", "triggered")
_AT_REST = ("stick", "chatter")


class ContactPattern(Bunch):
    r"""The contacts of one period of a periodic orbit, per node in time order.

    Build it with :meth:`from_contacts` (which validates and sorts); the fields are
    read-only arrays of one length C (the number of contacts in the period).

    Attributes
    ----------
    node : ndarray of int, shape (C,)
        Node of each contact; contacts are grouped by node, increasing in time.
    t : ndarray of float, shape (C,)
        Contact (landing) times in ``[t_start, t_start + period)``.
    kind : ndarray of str, shape (C,)
        A word of :data:`KINDS`.
    liftoff : ndarray of float, shape (C,)
        Lift-off time after a ``"stick"`` or ``"chatter"`` contact (``liftoff >= t``), else nan.
    ended_by : ndarray of str, shape (C,)
        ``"smooth"`` or ``"triggered"`` for a contact at rest, else ``""``.
    trigger : ndarray of int, shape (C,)
        The node whose landing triggered the lift-off, else -1.
    n_nodes : int
    period : float
    t_start : float

    Examples
    --------
    The flat completely inelastic layer at Gamma = 4.1 on two nodes: a touch-and-go,
    then a landing to rest with a smooth lift-off, every period T = 4 pi:

    >>> import math
    >>> p = ContactPattern.from_contacts(
    ...     node=[0, 0, 1, 1], t=[3.9, 5.6, 3.9, 5.6], kind=["touch", "stick", "touch", "stick"],
    ...     liftoff=[math.nan, 6.53, math.nan, 6.53], n_nodes=2, period=4 * math.pi, t_start=0.0)
    >>> p.sequence(0), p.counts.tolist(), p.single_contact
    ('TS', [2, 2], False)
    >>> [str(c) for c in p.ended_by], p.of_node(1).t.tolist()
    (['', 'smooth', '', 'smooth'], [3.9, 5.6])
    >>> p.rest_times().tolist()
    [0.0, 0.93..., 0.0, 0.93...]
    """

    @classmethod
    def from_contacts(cls, node, t, kind, n_nodes, period, t_start=0.0, liftoff=None, ended_by=None,
                      trigger=None):
        """Validate, wrap the times into the window and sort the contacts (node, then time).

        Parameters
        ----------
        node : array_like of int, shape (C,)
        t : array_like of float, shape (C,)
        kind : array_like of str, shape (C,)
            Words of :data:`KINDS` (letters of :data:`LETTERS` are accepted too).
        n_nodes : int
        period : float
        t_start : float
        liftoff : array_like of float, shape (C,), optional
            Required (finite) for ``"stick"`` and ``"chatter"``; ignored (nan) otherwise.
        ended_by : array_like of str, shape (C,), optional
            Default ``"smooth"`` for contacts at rest, or ``"triggered"`` where ``trigger >= 0``.
        trigger : array_like of int, shape (C,), optional

        Returns
        -------
        ContactPattern

        Examples
        --------
        >>> p = ContactPattern.from_contacts([1, 0], [7.0, 2.0], ["B", "bounce"], 2, 6.0)
        >>> p.node.tolist(), p.t.tolist(), [str(k) for k in p.kind]
        ([0, 1], [2.0, 1.0], ['bounce', 'bounce'])
        >>> ContactPattern.from_contacts([0], [1.0], ["stick"], 1, 6.0)
        Traceback (most recent call last):
        ...
        ValueError: liftoff must be finite and >= t for every 'stick' or 'chatter' contact (contact 0 of node 0)
        """
        n_nodes = int(n_nodes)
        period = float(period)
        t_start = float(t_start)
        if n_nodes < 1:
            raise ValueError(f"n_nodes must be >= 1, got {n_nodes}")
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0, got {period}")
        node = np.asarray(node, dtype=int).reshape(-1)
        t = np.asarray(t, dtype=float).reshape(-1)
        letters = {v: k for k, v in LETTERS.items()}
        kind = np.array([letters.get(str(k), str(k)) for k in np.asarray(kind).reshape(-1)], dtype="U7")
        C = node.size
        if t.size != C or kind.size != C:
            raise ValueError(f"node, t and kind must have one length, got {C}, {t.size}, {kind.size}")
        bad = [str(k) for k in kind if k not in KINDS]
        if bad:
            raise ValueError(f"kind must be one of {KINDS} (or the letters {tuple(LETTERS.values())}), "
                             f"got {bad[0]!r}")
        if C and (node.min() < 0 or node.max() >= n_nodes):
            raise ValueError(f"node must lie in [0, {n_nodes - 1}]")
        if not np.all(np.isfinite(t)):
            raise ValueError("t must be finite")
        liftoff = np.full(C, np.nan) if liftoff is None else np.asarray(liftoff, dtype=float).reshape(-1)
        trigger = np.full(C, -1, dtype=int) if trigger is None else np.asarray(trigger, dtype=int).reshape(-1)
        if liftoff.size != C or trigger.size != C:
            raise ValueError("liftoff and trigger must have the length of t")
        rest = np.isin(kind, _AT_REST)
        # window: t in [t_start, t_start + period), lift-offs move with their contact
        shift = np.floor((t - t_start) / period) * period
        t = t - shift
        liftoff = np.where(rest, liftoff - shift, np.nan)
        for i in np.flatnonzero(rest):
            if not (np.isfinite(liftoff[i]) and liftoff[i] >= t[i]):
                k = int(np.count_nonzero(node[:i] == node[i]))
                raise ValueError("liftoff must be finite and >= t for every 'stick' or 'chatter' contact "
                                 f"(contact {k} of node {int(node[i])})")
        if ended_by is None:
            ended_by = np.where(rest, np.where(trigger >= 0, "triggered", "smooth"), "")
        ended_by = np.asarray(ended_by, dtype="U9").reshape(-1)
        if ended_by.size != C:
            raise ValueError("ended_by must have the length of t")
        ended_by = np.where(rest, ended_by, "")
        if np.any(rest & ~np.isin(ended_by, LIFTOFF_CAUSES)):
            raise ValueError(f"ended_by must be one of {LIFTOFF_CAUSES} for a contact at rest")
        trigger = np.where(rest & (ended_by == "triggered"), trigger, -1)
        if np.any((ended_by == "triggered") & ((trigger < 0) | (trigger >= n_nodes))):
            raise ValueError("a triggered lift-off needs the triggering node (trigger in [0, n_nodes))")
        order = np.lexsort((t, node))
        out = cls(node=node[order], t=t[order], kind=kind[order], liftoff=liftoff[order],
                  ended_by=ended_by[order], trigger=trigger[order], n_nodes=n_nodes, period=period,
                  t_start=t_start)
        for name in ("node", "t", "kind", "liftoff", "ended_by", "trigger"):
            out[name].setflags(write=False)
        return out

    @classmethod
    def single(cls, tc, period, kind="bounce", t_start=0.0):
        """The pattern of a single-contact orbit: one contact per node at ``tc``.

        Examples
        --------
        >>> ContactPattern.single([1.0, 2.0], 12.0).tc.tolist()
        [1.0, 2.0]
        """
        tc = np.asarray(tc, dtype=float).reshape(-1)
        return cls.from_contacts(np.arange(tc.size), tc, [kind] * tc.size, tc.size, period, t_start)

    @property
    def counts(self):
        """Contacts per node in one period, shape (n_nodes,)."""
        return np.bincount(self.node, minlength=self.n_nodes)

    @property
    def single_contact(self):
        """Whether every node has exactly one contact per period, with no rest on the plate."""
        return bool(np.all(self.counts == 1) and not np.any(np.isin(self.kind, _AT_REST)))

    @property
    def tc(self):
        """Contact time of each node, shape (n_nodes,): only for a single-contact pattern."""
        if not self.single_contact:
            raise ValueError("tc is defined only for a single-contact pattern (one contact per node, no "
                             f"rest); this one has {self.counts.max(initial=0)} contacts on some node")
        return np.asarray(self.t)

    def of_node(self, j):
        """The contacts of node ``j`` (a :class:`ContactPattern` on the same nodes)."""
        m = self.node == int(j)
        return ContactPattern(node=self.node[m], t=self.t[m], kind=self.kind[m], liftoff=self.liftoff[m],
                              ended_by=self.ended_by[m], trigger=self.trigger[m], n_nodes=self.n_nodes,
                              period=self.period, t_start=self.t_start)

    def sequence(self, j):
        """Node ``j``'s contacts of the period as letters of :data:`LETTERS` (e.g. ``"TS"``)."""
        return "".join(LETTERS[str(k)] for k in self.kind[self.node == int(j)])

    def sequences(self):
        """The letter sequence of every node, a list of str of length ``n_nodes``."""
        return [self.sequence(j) for j in range(self.n_nodes)]

    def event_sequences(self, brief=None):
        """Every node's landings and lift-offs of the period in time order, as space-separated tokens.

        The landings are the letters of :data:`LETTERS` (a stick whose time at rest is below
        ``brief`` is ``s``), a lift-off from rest is ``L``, or ``L*`` where a neighbour's landing
        triggered it (``ended_by``); each sequence is rotated to start at the node's first
        lift-off (the study alphabet of ``validation/inelastic_kinks.py``).

        Parameters
        ----------
        brief : float, optional
            Time at rest (units 1/omega) below which a stick is brief (``s``), > 0.

        Returns
        -------
        list of str, length n_nodes

        Examples
        --------
        >>> import math
        >>> p = ContactPattern.from_contacts([0, 0, 1], [3.0, 4.0, 2.0], ["T", "S", "S"], 2, 12.0,
        ...                                  liftoff=[math.nan, 14.0, 5.0], trigger=[-1, 1, -1])
        >>> p.event_sequences(), p.event_sequences(brief=5.0)
        (['L* T S', 'L S'], ['L* T S', 'L s'])
        """
        if brief is not None and not (isinstance(brief, (int, float, np.floating)) and np.isfinite(brief)
                                      and brief > 0):
            raise ValueError(f"brief must be a finite number > 0, got {brief!r}")
        T, t0 = self.period, self.t_start
        rest_t = self.rest_times()
        out = []
        for j in range(self.n_nodes):
            toks = []                                    # (time in the window, order, token)
            for i in np.flatnonzero(self.node == j):
                k = str(self.kind[i])
                letter = LETTERS[k]
                if k == "stick" and brief is not None and rest_t[i] < brief:
                    letter = "s"
                toks.append((float(self.t[i]), 0, letter))
                if k in _AT_REST:
                    tl = t0 + float(np.mod(self.liftoff[i] - t0, T))
                    toks.append((tl, 1, "L*" if self.ended_by[i] == "triggered" else "L"))
            toks = [tok for _, _, tok in sorted(toks, key=lambda r: (r[0], r[1]))]
            lifts = [k for k, tok in enumerate(toks) if tok.startswith("L")]
            if lifts:
                toks = toks[lifts[0]:] + toks[:lifts[0]]
            out.append(" ".join(toks))
        return out

    def rest_times(self):
        """Time at rest after each contact (``liftoff - t``; 0 without rest), shape (C,)."""
        return np.where(np.isfinite(self.liftoff), self.liftoff - self.t, 0.0)

    def max_phase_distance(self, other):
        """Largest distance (mod period) between matching contact and lift-off times of two patterns.

        Contacts are matched per node up to a cyclic shift (two windows of one orbit may start
        at different instants); the shift with the same kinds and the smallest distance is
        taken.  Patterns with other nodes, periods or per-node kinds (up to the shift) are
        ``inf`` apart.

        Examples
        --------
        >>> a = ContactPattern.single([1.0, 2.0], 12.0)
        >>> b = ContactPattern.single([1.0 + 1e-9, 1.999], 12.0)
        >>> round(a.max_phase_distance(b), 12)
        0.001
        >>> c = ContactPattern.from_contacts([0, 0], [1.0, 5.0], ["T", "S"], 1, 12.0, liftoff=[0, 6.0])
        >>> d = ContactPattern.from_contacts([0, 0], [5.0, 13.0], ["S", "T"], 1, 12.0, t_start=3.0,
        ...                                  liftoff=[6.0, 0])
        >>> c.sequences(), d.sequences(), c.max_phase_distance(d)
        (['TS'], ['ST'], 0.0)
        """
        if self.n_nodes != other.n_nodes or abs(self.period - other.period) > 1e-12 * self.period:
            return float("inf")
        T = self.period

        def dist(a, b):
            d = np.mod(a - b, T)
            return np.minimum(d, T - d)

        worst = 0.0
        for j in range(self.n_nodes):
            a, b = self.of_node(j), other.of_node(j)
            if a.t.size != b.t.size:
                return float("inf")
            best = float("inf")
            for shift in range(max(a.t.size, 1)):
                kb = np.roll(b.kind, shift)
                if not np.array_equal(a.kind, kb):
                    continue
                d = float(np.max(dist(a.t, np.roll(b.t, shift)), initial=0.0))
                rest = np.isfinite(a.liftoff)
                if np.any(rest):
                    d = max(d, float(np.max(dist(a.liftoff[rest], np.roll(b.liftoff, shift)[rest]))))
                best = min(best, d)
            worst = max(worst, best)
        return worst
