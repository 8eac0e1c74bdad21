r"""The one Newton engine of the package: Newton's method on any :class:`~tps_solver.core.problem.Problem`.

Every nonlinear solve of the package goes through :func:`newton`: the spectral TPS and
the exact lattice cycle (Newton--GMRES with a Jacobi preconditioner), shooting on the
FDA period map (Newton--Krylov with a finite-difference or exact Jacobian action), the
impact-and-stick TPS (a dense Jacobian reused as a chord while it contracts), the
corrector of the continuation (plain Newton on the bordered system) and the polish of a
one-node cycle in the basins.  What differs between them are options, not loops:

``linear``
    how the Newton step is solved: ``"auto"`` takes a dense LU for an ndarray Jacobian and
    restarted GMRES (``scipy.sparse.linalg.gmres``) for a ``LinearOperator``;
``line_search``
    ``"backtrack"`` (halve the step until the merit decreases by the Armijo fraction
    ``decrease`` or the trial meets ``tol``; give up below ``min_step``), ``"quadratic"``
    (the same acceptance, each new step from the quadratic model of
    :math:`\phi(\lambda) = |F|^2`, clipped to [0.1, 0.5] of the last; at most
    ``max_backtracks`` trials) or ``"none"`` (the full step, always accepted);
``merit``
    the norm the line search decreases: ``"max"`` (the problem's ``error``) or ``"2"``;
``chord``
    reuse a dense LU while the residual falls by ``chord`` per step (0.1: by ten);
    a stale direction that fails is replaced by a fresh one at no iteration cost.

Status codes are those of :data:`tps_solver.core.orbit.STATUS`: 0 converged, 1 iteration
limit, 2 stagnation (or a non-finite Krylov step, a non-finite residual, a step below
``xtol``), 5 interrupted (``KeyboardInterrupt``; the last accepted iterate is kept),
8 singular or non-finite dense Jacobian.

The callback convention
-----------------------
``callback(state)`` after every accepted step, ``state`` the package's one
:class:`~tps_solver.core.progress.ProgressState`: stage ``"newton"``, ``iteration`` (steps
taken), ``residual`` (the iterate's ``error``), ``x`` (the iterate) and ``step`` (the
line-search length).
"""
import math
import warnings

import numpy as np
from scipy.linalg import LinAlgWarning, lu_factor, lu_solve
from scipy.sparse.linalg import LinearOperator, aslinearoperator, gmres

from tps_solver.core.bunch import Bunch
from tps_solver.core.orbit import STATUS, converged_message, outcome
from tps_solver.core.progress import progress_state
from tps_solver.core.problem import Inadmissible

__all__ = ["newton", "NewtonResult", "LINE_SEARCHES"]

LINE_SEARCHES = ("backtrack", "quadratic", "none")


class NewtonResult(Bunch):
    """The result of :func:`newton`.

    Attributes
    ----------
    x : ndarray of float, shape (n,)
        The last accepted iterate.
    F : ndarray of float, shape (m,)
        Its residual.
    data : tuple
        The rest of what ``problem.residual`` returned with it.
    converged, success : bool
    status : int
        A code of :data:`tps_solver.core.orbit.STATUS` (module docstring).
    message : str
    nit : int
        Accepted Newton steps.
    residual : float
        ``problem.error`` of the last iterate.
    history : ndarray of float, shape (nit + 1,)
        ``error`` before the first and after every accepted step.
    step_lengths : ndarray of float, shape (nit,)
        Line-search length of every accepted step.
    linear_residuals : ndarray of float, shape (nit,)
        GMRES relative residual of every step (0 for a dense solve).
    linear_products : ndarray of int, shape (nit,)
        Jacobian-vector products of every step (0 for a dense solve).
    n_jacobians : int
        Jacobians evaluated (dense) or Krylov solves started.
    n_residuals : int
        Residual evaluations.

    Examples
    --------
    >>> from tps_solver.core.problem import Problem
    >>> class Cube(Problem):
    ...     def residual(self, x):
    ...         return x ** 3 - 8.0, None
    ...     def jacobian(self, x, F, data):
    ...         return np.diag(3.0 * x ** 2)
    >>> out = newton(Cube(), np.array([3.0]), tol=1e-12, max_iter=3)
    >>> out.status, out.converged, out.nit, out.history.size == out.nit + 1
    (1, False, 3, True)
    """


def _merit(problem, F, data, merit):
    if merit == "2":
        return float(np.linalg.norm(F))
    return problem.error(F, data)


def _dense_factor(J):
    J = np.asarray(J, dtype=float)
    if not np.all(np.isfinite(J)):
        return None, "the Jacobian has non-finite entries"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", LinAlgWarning)
            return lu_factor(J, check_finite=False), ""
    except (LinAlgWarning, ValueError, np.linalg.LinAlgError) as exc:
        return None, str(exc)


def newton(problem, x0, *, tol, max_iter, linear="auto", line_search="backtrack", merit="max",
           decrease=1e-4, min_step=1.0 / 64, max_backtracks=None, chord=None, xtol=None,
           gmres_rtol=None, gmres_restart=None, gmres_maxiter=None, first=None, callback=None):
    """Newton's method on ``problem`` from ``x0`` (module docstring).

    Parameters
    ----------
    problem : Problem
        Any object of the problem protocol (:mod:`tps_solver.core.problem`).
    x0 : ndarray of float, shape (n,)
    tol : float
        Converged when ``problem.error(F, data) <= tol``.
    max_iter : int
        Largest number of accepted steps.
    linear : {"auto", "dense", "gmres"}
    line_search : {"backtrack", "quadratic", "none"}
    merit : {"max", "2"}
    decrease : float
        Armijo fraction: a step of length lam is accepted when the merit falls below
        ``(1 - decrease * lam)`` times the last.
    min_step : float
        Smallest step length of ``"backtrack"`` (1 tries the full step only).
    max_backtracks : int, optional
        Largest number of trials of ``"quadratic"`` (default 10).
    chord : float, optional
        Reuse a dense LU while the residual falls by this factor per step.
    xtol : float, optional
        Stop (status 2 unless converged) after a step with max|dx| <= xtol.
    gmres_rtol : float or callable, optional
        Relative tolerance of GMRES, or a function of the current error (default
        ``max(min(1e-2, 0.1 * error), 1e-13)``).
    gmres_restart, gmres_maxiter : int, optional
        Restart length (default min(n, 50)) and number of restart cycles (default 4).
    first : tuple, optional
        What ``problem.residual(x0)`` returns, when the caller has it already (saves one
        evaluation).
    callback : callable, optional
        ``callback(state)`` after every accepted step (module docstring).

    Returns
    -------
    NewtonResult

    Examples
    --------
    Two equations, a dense Jacobian, quadratic convergence to (1, 2):

    >>> from tps_solver.core.problem import Problem
    >>> class Circle(Problem):
    ...     def residual(self, x):
    ...         return np.array([x[0] ** 2 + x[1] ** 2 - 5.0, x[1] - 2.0 * x[0]]), None
    ...     def jacobian(self, x, F, data):
    ...         return np.array([[2 * x[0], 2 * x[1]], [-2.0, 1.0]])
    >>> out = newton(Circle(), np.array([2.0, 1.0]), tol=1e-13, max_iter=20)
    >>> out.status, out.nit, np.allclose(out.x, [1.0, 2.0], atol=1e-13)
    (0, 5, True)
    >>> out.message
    'converged: max|F| = ... <= tol = 1.0e-13'

    The same through its action (GMRES):

    >>> from scipy.sparse.linalg import aslinearoperator
    >>> class CircleOp(Circle):
    ...     def jacobian(self, x, F, data):
    ...         return aslinearoperator(super().jacobian(x, F, data))
    >>> newton(CircleOp(), np.array([2.0, 1.0]), tol=1e-13, max_iter=20).status
    0
    """
    if line_search not in LINE_SEARCHES:
        raise ValueError(f"line_search must be one of {LINE_SEARCHES}, got {line_search!r}")
    if merit not in ("max", "2"):
        raise ValueError(f"merit must be 'max' or '2', got {merit!r}")
    if linear not in ("auto", "dense", "gmres"):
        raise ValueError(f"linear must be 'auto', 'dense' or 'gmres', got {linear!r}")
    max_backtracks = 10 if max_backtracks is None else int(max_backtracks)
    x = np.array(x0, dtype=float)
    F, *data = problem.residual(x) if first is None else first
    data = tuple(data)
    n_res = 1 if first is None else 0
    err = problem.error(F, data)
    phi = _merit(problem, F, data, merit)
    history, lams, lin_res, lin_prod = [err], [], [], []
    status, message = 1, f"iteration limit ({max_iter}) reached"
    n_jac = 0
    lu, fresh = None, False
    nit = 0

    def result():
        out = NewtonResult(x=x, F=F, data=data, status=status, message=message, nit=nit,
                           residual=float(history[-1]), history=np.asarray(history, dtype=float),
                           step_lengths=np.asarray(lams, dtype=float),
                           linear_residuals=np.asarray(lin_res, dtype=float),
                           linear_products=np.asarray(lin_prod, dtype=int), n_jacobians=n_jac,
                           n_residuals=n_res)
        out.update(outcome(status))
        return out

    if not np.isfinite(err):
        status, message = 2, "the residual at the initial point is not finite"
        return result()
    try:
        while True:
            if history[-1] <= tol:
                status, message = 0, converged_message(history[-1], tol)
                break
            if nit >= max_iter:
                status, message = 1, f"iteration limit ({max_iter}) reached"
                break
            # ---- the Newton direction
            rel, used = 0.0, 0
            if lu is not None:
                J = None
            else:
                J = problem.jacobian(x, F, data)
                n_jac += 1
            dense = (linear == "dense" or (linear == "auto" and not isinstance(J, LinearOperator))) \
                if J is not None else True
            if dense:
                if lu is None:
                    lu, why = _dense_factor(J)
                    fresh = True
                    if lu is None:
                        status, message = 8, f"singular or non-finite Jacobian at iteration {nit + 1}: {why}"
                        break
                with np.errstate(all="ignore"):
                    dx = -lu_solve(lu, F, check_finite=False)
                if not np.all(np.isfinite(dx)):
                    if not fresh:
                        lu = None
                        continue
                    status, message = 8, f"non-finite Newton step at iteration {nit + 1}"
                    break
            else:
                fresh = True
                n = x.size
                count = [0]
                J = aslinearoperator(J)          # linear="gmres" with a matrix: its action

                def matvec(v, J=J, count=count):
                    count[0] += 1
                    return J.matvec(v)

                op = LinearOperator(J.shape, matvec=matvec, dtype=float)
                rtol = gmres_rtol(err) if callable(gmres_rtol) else gmres_rtol
                if rtol is None:
                    rtol = max(min(1e-2, 0.1 * history[-1]), 1e-13)
                norms = []
                dx, info = gmres(op, -F, rtol=rtol, atol=0.0,
                                 restart=min(n, 50) if gmres_restart is None else gmres_restart,
                                 maxiter=4 if gmres_maxiter is None else gmres_maxiter,
                                 M=problem.preconditioner(x, F, data, J),
                                 callback=norms.append, callback_type="pr_norm")
                rel, used = (float(norms[-1]) if norms else 0.0), count[0]
                if not np.all(np.isfinite(dx)):
                    status, message = 2, "GMRES returned a non-finite step"
                    break
            try:
                dx = problem.limit_step(x, dx)
            except Inadmissible as exc:
                status, message = 2, f"no admissible Newton step at iteration {nit + 1}: {exc}"
                break
            # ---- the line search
            lam, accepted, tries = 1.0, False, 0
            trial = F_t = data_t = None
            err_t = math.inf
            while True:
                tries += 1
                try:
                    trial = problem.project(x + lam * dx)
                    F_t, *data_t = problem.residual(trial)
                    data_t = tuple(data_t)
                    n_res += 1
                    err_t = problem.error(F_t, data_t)
                    phi_t = _merit(problem, F_t, data_t, merit)
                except Inadmissible:
                    err_t = phi_t = math.inf
                if not np.isfinite(phi_t):
                    err_t = phi_t = math.inf
                if line_search == "none" or phi_t < (1.0 - decrease * lam) * phi or err_t <= tol:
                    accepted = np.isfinite(err_t)
                    break
                if line_search == "backtrack":
                    if not fresh:
                        break
                    lam *= 0.5
                    if lam < min_step:
                        break
                else:
                    if tries >= max_backtracks:
                        break
                    quad = phi * phi * lam * lam / (phi_t * phi_t - phi * phi + 2.0 * phi * phi * lam) \
                        if np.isfinite(phi_t) else 0.0
                    lam = float(np.clip(quad, 0.1 * lam, 0.5 * lam))
            if not accepted:
                if lu is not None and not fresh:
                    lu = None               # a stale chord direction failed: take a fresh one
                    continue
                if line_search == "none":
                    status, message = 2, f"the residual is not finite after Newton step {nit + 1}"
                else:
                    extra = f" (GMRES relative residual {rel:.2g} after {used} products)" if used else ""
                    status = 2
                    message = (f"Newton stagnated at iteration {nit + 1}: no decrease of max|F| = "
                               f"{history[-1]:.3e} along the Newton direction{extra}")
                break
            nit += 1
            if lu is not None and (chord is None or err_t > chord * history[-1]):
                lu = None
            fresh = False
            x, F, data, err, phi = trial, F_t, data_t, err_t, phi_t
            history.append(err)
            lams.append(lam)
            lin_res.append(rel)
            lin_prod.append(used)
            if callback is not None:
                callback(progress_state("newton", nit, residual=err, x=x, step=lam))
            if xtol is not None and float(np.max(np.abs(lam * dx))) <= xtol and err > tol:
                status, message = 2, (f"the Newton step fell below xtol = {xtol:.1e} with max|F| = "
                                      f"{err:.3e} > tol = {tol:.1e}")
                break
    except KeyboardInterrupt:
        status = 5
        message = f"interrupted in Newton step {nit + 1} (KeyboardInterrupt); the last accepted iterate is kept"
    assert status in STATUS
    return result()
