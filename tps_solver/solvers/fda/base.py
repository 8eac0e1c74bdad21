r"""The integrator interface of the FDA (modelled on scipy's ``OdeSolver`` and ``METHODS``).

Every time stepper of the FDA is a subclass of :class:`Integrator` registered
under a name in :data:`METHODS`; :func:`~tps_solver.solvers.fda.simulate` is the one
driver loop for all of them.  A step of an integrator is one call of
:meth:`Integrator.advance`: propagate from ``t`` to the next *event* (or to
``t_stop``) and return a :class:`Step`.

Two kinds of contact model share the interface:

* **impulsive** (``impulsive = True``: point impacts, ``"exact"`` and
  ``"ode"``): the integrator only *locates* the next contact set or lift-off
  set; the driver applies the impact rule, sticking and lift-off of
  :mod:`~tps_solver.solvers.fda.impacts` to the returned state, so every impulsive
  method shares one event layer;
* **continuous** (``impulsive = False``: the soft contact): contact is part of
  the right-hand side, the integrator resolves it itself and reports what
  happened as event records in :attr:`Step.events`, and the nodes in contact
  in :attr:`Step.stuck`.

Options
-------
Each subclass lists the keyword options it accepts, with their defaults, in
``OPTIONS``.  :meth:`Integrator.check_options` refuses any other option with a
``ValueError`` that names it, so an option that does not apply to the chosen
method is an error, never silently ignored.
"""
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Step", "Integrator"]


def _no_nodes():
    return np.empty(0, dtype=np.int64)


@dataclass
class Step:
    r"""What one :meth:`Integrator.advance` returns.

    Attributes
    ----------
    t : float
        Time reached: the event time, or ``t_stop``.
    w, zeta : ndarray of float, shape (n_nodes,)
        State at ``t`` (for an impulsive model: the pre-event state).
    contact : ndarray of int
        Impulsive models: the contact set, nodes reaching :math:`\zeta = 0` at ``t``
        (empty at ``t_stop``).
    liftoff : ndarray of int
        Impulsive models: stuck nodes whose free acceleration turns positive at ``t``.
    samples : list of (float, ndarray, ndarray)
        ``(t, w, zeta)`` at the requested output times in ``(t_previous, t]``.
    events : list of (float, int, str, float)
        Continuous models: event records ``(t, node, kind, w_before)`` that the
        integrator resolved itself, ``kind`` in {"impact", "stick", "liftoff"}.
    stuck : ndarray of bool, shape (n_nodes,) or None
        Continuous models: the nodes in contact at ``t``; ``None`` for impulsive
        models (the driver keeps that state).

    Examples
    --------
    >>> s = Step(t=1.0, w=np.zeros(2), zeta=np.ones(2))
    >>> s.contact, s.liftoff.size, s.stuck is None
    (array([], dtype=int64), 0, True)
    """

    t: float
    w: np.ndarray
    zeta: np.ndarray
    contact: np.ndarray = field(default_factory=_no_nodes)
    liftoff: np.ndarray = field(default_factory=_no_nodes)
    samples: list = field(default_factory=list)
    events: list = field(default_factory=list)
    stuck: np.ndarray = None


class Integrator:
    """Base class of the FDA's time steppers.

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
        Plate acceleration, > 0 (checked by the driver).
    e : float
        Restitution in [0, 1) (checked by the driver).
    **options
        The method's own options, listed with their defaults in ``OPTIONS``.

    Attributes
    ----------
    name : str
        The key of the method in ``METHODS``.
    impulsive : bool
        Whether the driver applies the impact rule (see the module docstring).
    OPTIONS : dict
        Accepted options and their defaults.
    n_steps : int
        Work counter (search steps or solver steps), reported by the driver.

    Examples
    --------
    A subclass declares its options; any other option is refused by name:

    >>> class Still(Integrator):
    ...     name = "still"
    ...     OPTIONS = {"tol": 1e-9}
    >>> Still(None, 2.5, 0.45, tol=1e-6).options
    {'tol': 1e-06}
    >>> Still(None, 2.5, 0.45, rtol=1e-6)
    Traceback (most recent call last):
    ...
    ValueError: option 'rtol' does not apply to method='still' (its options: tol)
    """

    name = ""
    impulsive = True
    OPTIONS = {}

    def __init__(self, lattice, Gamma, e, **options):
        self.lattice = lattice
        self.Gamma = Gamma
        self.e = e
        self.options = self.check_options(options)
        self.n_steps = 0

    @classmethod
    def check_options(cls, options):
        """Merge ``options`` into the defaults; an unknown option raises ``ValueError`` naming it."""
        unknown = sorted(set(options) - set(cls.OPTIONS))
        if unknown:
            accepted = ", ".join(sorted(cls.OPTIONS)) or "none"
            raise ValueError(f"option {unknown[0]!r} does not apply to method={cls.name!r} "
                             f"(its options: {accepted})")
        merged = dict(cls.OPTIONS)
        merged.update(options)
        return merged

    def advance(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """Propagate from ``t`` to the next event or to ``t_stop``.

        Parameters
        ----------
        t : float
        w, zeta : ndarray of float, shape (n_nodes,)
            State at ``t`` (post-event).
        stuck : ndarray of bool, shape (n_nodes,)
            Nodes held on the plate at ``t``.
        t_stop : float
        t_eval : ndarray of float
            Sorted output times; those in ``(t, t_new]`` are sampled.

        Returns
        -------
        Step

        Raises
        ------
        RuntimeError
            When the event search stalls (the driver turns it into ``status = 3``).
        """
        raise NotImplementedError
