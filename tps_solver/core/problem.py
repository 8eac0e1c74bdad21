r"""The problem protocol: what every nonlinear problem of the package offers the one Newton.

A *problem* is an equation :math:`F(x; p) = 0` for unknowns ``x`` (a float vector) at
parameters ``p`` that can be read and set by name (BifurcationKit's problems are the
model).  The one Newton engine (:func:`tps_solver.core.newton.newton`), the continuation
(:func:`tps_solver.continue_branch`) and the Floquet module
(:mod:`tps_solver.solvers.shooting.floquet`) use nothing else of it.

Required
--------
``residual(x) -> (F, *data)``
    a tuple: ``F``, ndarray of float, shape (m,), then any objects that
    :meth:`~Problem.jacobian` (and :meth:`~Problem.monodromy`) may reuse; the engine passes
    them on as the tuple ``data``.  A point at which
    the problem cannot be evaluated (a contact order broken, a height below the plate, a
    parameter out of range) raises :class:`Inadmissible`; the line search then treats the
    trial as rejected.
``jacobian(x, F, data)``
    :math:`\partial F/\partial x` at ``x``: a dense ndarray of shape (m, n) or its action,
    a ``scipy.sparse.linalg.LinearOperator``.

Optional (the defaults of :class:`Problem`)
-------------------------------------------
``error(F, data) -> float``
    the convergence measure (default max|F|);
``preconditioner(x, F, data, J)``
    a ``LinearOperator`` approximating the inverse Jacobian for GMRES, or ``None``;
``limit_step(x, dx) -> dx``
    a capped Newton step (default: unchanged), or :class:`Inadmissible` when no step of
    that direction is acceptable (the engine then stops with status 2);
``project(x) -> x``
    the admissible point nearest a trial (default: unchanged), or :class:`Inadmissible`
    when there is none (a contact order that a step would break);
``parameters`` and ``at(**values)``
    the parameters by name (a dict) and a copy of the problem at other values;
``monodromy(x, data)``
    for periodic orbits: the linearised period map (ndarray or ``LinearOperator``), from
    which :func:`~tps_solver.solvers.shooting.floquet.multipliers` computes the multipliers.
"""
import numpy as np

__all__ = ["Problem", "Inadmissible"]


class Inadmissible(ValueError):
    """The problem cannot be evaluated at this point (the line search rejects the trial).

    Examples
    --------
    >>> issubclass(Inadmissible, ValueError)
    True
    """


class Problem:
    """Base class of the problem protocol (module docstring); subclasses define
    :meth:`residual` and :meth:`jacobian`.

    Examples
    --------
    A scalar problem x^2 = p, at p = 2 and, through :meth:`at`, at p = 9:

    >>> class Square(Problem):
    ...     def __init__(self, p=2.0):
    ...         self.parameters = {"p": p}
    ...     def residual(self, x):
    ...         return x ** 2 - self.parameters["p"], None
    ...     def jacobian(self, x, F, data):
    ...         return np.diag(2.0 * x)
    >>> from tps_solver.core.newton import newton
    >>> out = newton(Square(), np.array([1.0]), tol=1e-14, max_iter=20)
    >>> out.status, round(float(out.x[0]) ** 2, 14)
    (0, 2.0)
    >>> float(newton(Square().at(p=9.0), np.array([1.0]), tol=1e-14, max_iter=20).x[0])
    3.0
    """

    #: the parameters by name; :meth:`at` returns a copy at other values
    parameters = {}

    def residual(self, x):
        """``(F, *data)`` at ``x`` (module docstring)."""
        raise NotImplementedError(f"{type(self).__name__} must define residual(x)")

    def jacobian(self, x, F, data):
        """dF/dx at ``x``: an ndarray or a ``LinearOperator``."""
        raise NotImplementedError(f"{type(self).__name__} must define jacobian(x, F, data)")

    def error(self, F, data):
        """The convergence measure of a residual: max|F|."""
        return float(np.max(np.abs(F), initial=0.0))

    def preconditioner(self, x, F, data, J):
        """An approximate inverse Jacobian for GMRES, or ``None`` (none)."""
        return None

    def limit_step(self, x, dx):
        """The Newton step actually tried (default: ``dx`` itself)."""
        return dx

    def project(self, x):
        """The admissible point nearest ``x`` (default: ``x`` itself)."""
        return x

    def at(self, **values):
        """A copy of the problem with the named parameters set to ``values``.

        Raises
        ------
        ValueError
            For a name not in :attr:`parameters`.
        """
        unknown = sorted(set(values) - set(self.parameters))
        if unknown:
            raise ValueError(f"parameter must be one of {sorted(self.parameters)}, got {unknown[0]!r}")
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.parameters = {**self.parameters, **{k: float(v) for k, v in values.items()}}
        new.reparameterised()
        return new

    def reparameterised(self):
        """Hook called on the copy made by :meth:`at` after its parameters changed."""

    def monodromy(self, x, data):
        """The linearised period map at a periodic orbit ``x`` (periodic problems only)."""
        raise NotImplementedError(f"{type(self).__name__} has no monodromy (not a periodic-orbit problem)")
