r"""One vocabulary for periodic orbits: :class:`PeriodicOrbit` and the status table.

Every periodic result of the package -- the spectral TPS
(:class:`~tps_solver.solvers.tps.PeriodicSolution`), the exact lattice cycle
(:class:`~tps_solver.solvers.tps.LatticeCycle`) -- is a :class:`PeriodicOrbit`: a
result bunch with the fields below and the evaluators :meth:`velocity` and
:meth:`height`, which ``dir()`` shows next to the fields.

Status codes
------------
One table, :data:`STATUS`, for every solver of the package (periodic orbits, time
stepping, continuation, basins): a code has one meaning wherever it appears.

====  ==========================================================================
code  meaning
====  ==========================================================================
0     done: the residual met the tolerance (a simulation reached ``t_end``; a
      branch reached a bound of its interval; every basin sample was classified)
1     limit reached before an answer: the iteration limit of a solve, the point
      limit of a branch, basin samples still irregular after ``periods``
2     stagnation: no decrease along the Newton direction (a branch's corrector
      failed down to the smallest step), or a non-finite step
3     the contact computation failed (no jump-like up-crossing of (46), or the
      FDA's contact search stalled)
4     the branch ended before the requested parameter (a fold, or the orbit
      stopped existing); the fields hold the last converged point
5     interrupted by the user (``KeyboardInterrupt``); the last iterate is kept
6     event bound exceeded (chattering or Zeno behaviour) in a simulation, a
      period map or a basin sample
7     periodic on the free nodes, but a node stuck at the section is free after
      one period (choose another section)
8     singular or non-finite Jacobian
9     not the orbit asked for: the solve converged, but to the uniform flat
      layer (no kink or oscillon is left on the lattice) or to an orbit of a
      shorter period repeated; the fields hold that orbit
====  ==========================================================================

:func:`outcome` gives the ``converged``/``success`` pair of a code (computed once).
"""
import numpy as np

from tps_solver.core.bunch import Bunch
from tps_solver.core.pattern import ContactPattern

__all__ = ["PeriodicOrbit", "STATUS", "converged_message", "far_field", "outcome"]

STATUS = {
    0: "converged",
    1: "iteration limit reached",
    2: "stagnation (no decrease along the Newton direction)",
    3: "contact computation failed",
    4: "branch ended before the requested parameter (fold)",
    5: "interrupted",
    6: "event bound exceeded",
    7: "stuck set changed at the section",
    8: "singular or non-finite Jacobian",
    9: "not the orbit asked for (the uniform flat layer, or a shorter period repeated)",
}


def outcome(status):
    """``{"converged": ..., "success": ...}`` of a :data:`STATUS` code (both ``status == 0``).

    Examples
    --------
    >>> outcome(0), outcome(6)
    ({'converged': True, 'success': True}, {'converged': False, 'success': False})
    """
    if int(status) not in STATUS:
        raise ValueError(f"status must be a code of STATUS {sorted(STATUS)}, got {status!r}")
    ok = int(status) == 0
    return {"converged": ok, "success": ok}


def converged_message(residual, tol, how=""):
    """The one wording of a converged solve: ``"converged[ how]: max|F| = r <= tol = t"``.

    Examples
    --------
    >>> converged_message(3e-12, 1e-10)
    'converged: max|F| = 3.000e-12 <= tol = 1.0e-10'
    """
    how = f" {how}" if how else ""
    return f"converged{how}: max|F| = {residual:.3e} <= tol = {tol:.1e}"


def far_field(flat):
    """Whether the far-field flat layer of an orbit is stable, its multipliers, and a sentence.

    A kink or oscillon whose far field is unstable (a Floquet multiplier of the flat layer
    outside the unit circle) cannot be observed: the layer away from the front leaves its orbit.
    Every periodic result states it in ``far_field_stable`` and, when unstable, in its message.

    Parameters
    ----------
    flat : FlatLayer
        The far field (duck-typed: ``floquet_multipliers()``).

    Returns
    -------
    stable : bool
    multipliers : ndarray of complex, shape (2,)
        By decreasing modulus.
    note : str
        '' when stable; else a sentence naming the largest modulus.

    Examples
    --------
    >>> class Flat:
    ...     def floquet_multipliers(self):
    ...         return np.array([5.78, 0.035], dtype=complex)
    >>> stable, mu, note = far_field(Flat())
    >>> stable, note
    (False, 'the far field (flat layer) is unstable: its largest Floquet multiplier has |mu| = 5.78 > 1, so this orbit cannot be observed (far_field_stable = False). ')
    """
    mu = np.asarray(flat.floquet_multipliers(), dtype=complex)
    rho = float(np.max(np.abs(mu))) if mu.size else float("nan")
    stable = bool(rho < 1.0)
    note = "" if stable else (f"the far field (flat layer) is unstable: its largest Floquet multiplier has "
                              f"|mu| = {rho:.3g} > 1, so this orbit cannot be observed (far_field_stable = False). ")
    return stable, mu, note


class PeriodicOrbit(Bunch):
    r"""Base of every periodic result: fields shared by all, evaluators as methods.

    Attributes
    ----------
    converged, success : bool
        Whether the solver met its tolerance (the two are the same).
    status : int
        A code of :data:`STATUS`.
    message : str
        What happened, and what to try next when it did not converge.
    nit : int
        Newton steps (or sweeps) taken.
    residual : float
        Final residual (max norm).
    residual_history : ndarray of float, shape (nit + 1,)
    geometry : str
        ``"planar"`` (kink) or ``"axisymmetric"`` (oscillon).
    nodes : ndarray of float, shape (n_nodes,)
        Positions ``x`` or ``r`` of the nodes the fields live on.
    tc : ndarray of float, shape (n_nodes,)
        Contact time of each node in [0, T), where the orbit is single-contact.
    contacts : ContactPattern
        The contact pattern of one period in the one shape and alphabet of the package
        (:mod:`tps_solver.core.pattern`): per node the ordered contacts, each with its time,
        kind (bounce / touch / stick / chatter) and, for a rest on the plate, the lift-off
        time and what ended it.  Single-contact results derive it from ``tc``; shooting
        orbits from their events; impact-and-stick solutions from their solved pattern.
    Gamma, e, t0, period : float
        Parameters; ``t0`` is the launch phase of the far-field flat layer.
    M : int
        Subharmonic order (period ``T = 2 pi M``).
    flat : FlatLayer
        The far-field flat layer.
    far_field_stable : bool
        Whether that flat layer is stable (its Floquet multipliers inside the unit circle, in
        ``far_field_multipliers``); when it is not, the message says so (:func:`far_field`).
    coupling : float
        The coupling :math:`\nu_c` the fields belong to (1 unless a
        continuation stopped early, ``status = 4``).
    lattice : Lattice or None
        The FDA lattice of a lattice solution, ``None`` on the continuum.
    time : float
        Wall time of the solve, seconds.

    Examples
    --------
    >>> from tps_solver import LatticeCycle, PeriodicSolution
    >>> issubclass(PeriodicSolution, PeriodicOrbit) and issubclass(LatticeCycle, PeriodicOrbit)
    True
    >>> orb = PeriodicOrbit(converged=True, status=0, message=converged_message(1e-12, 1e-10))
    >>> STATUS[orb.status], [name for name in dir(orb) if name in ("height", "status", "velocity")]
    ('converged', ['height', 'status', 'velocity'])
    >>> PeriodicOrbit.as_times(2.0)
    array([2.])
    >>> PeriodicOrbit(tc=np.array([1.0, 2.0]), period=12.0, e=0.45).contacts.sequences()
    ['B', 'B']
    """

    @property
    def contacts(self):
        """The contact pattern of one period (:class:`~tps_solver.core.pattern.ContactPattern`).

        The base class derives it from ``tc``: one contact per node, a rebound (``"bounce"``)
        for e > 0 and a touch-and-go (``"touch"``) for e = 0.
        """
        tc = self.get("tc")
        if tc is None:
            raise AttributeError(f"{type(self).__name__} has no contact pattern (no tc)")
        return ContactPattern.single(tc, self.period, "bounce" if self.e > 0 else "touch")

    def velocity(self, t):
        """Velocity w(t) at the nodes; shape (len(t), n_nodes)."""
        raise NotImplementedError

    def height(self, t):
        """Height zeta(t) at the nodes; shape (len(t), n_nodes)."""
        raise NotImplementedError

    def __dir__(self):
        methods = [name for name in dir(type(self)) if not name.startswith("_")
                   and callable(getattr(type(self), name)) and name not in dir(dict)]
        return sorted(set(self.keys()) | set(methods))

    @staticmethod
    def as_times(t):
        """``t`` as a 1-D float array (a scalar becomes shape (1,))."""
        return np.atleast_1d(np.asarray(t, dtype=float))
