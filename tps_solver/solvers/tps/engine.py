r"""The TPS engine: Newton--GMRES, continuation in the coupling, fixed-point schemes.

Every discretisation of the time-periodic problem (the continuum TPS
:class:`~tps_solver.solvers.tps.problems.ContinuumProblem`, the lattice TPS
:class:`~tps_solver.solvers.tps.problems.LatticeProblem` and the exact lattice cycle
:class:`~tps_solver.solvers.tps.cycle.CycleProblem`) implements the small **problem
protocol** used here:

``problem.residual(tc) -> (F, aux, phase)``
    the contact condition :math:`F_j(t_c)` (46) at the unknown nodes and two
    opaque objects that the Jacobian may reuse;
``problem.jacobian_operator(tc, aux, phase) -> (J, diag)``
    :math:`\partial F/\partial t_c` as a ``scipy.sparse.linalg.LinearOperator``
    and its diagonal (the Jacobi preconditioner);
``problem.T``
    the period (Newton steps are capped at T/4);
``problem.coupling``
    the coupling :math:`\nu_c` the problem was built with.

The status codes of every solver that uses the engine are the table
:data:`tps_solver.core.orbit.STATUS`.
"""
import math

import numpy as np
from scipy.sparse.linalg import LinearOperator

from tps_solver.core.newton import newton as core_newton
from tps_solver.core.orbit import converged_message
from tps_solver.core.progress import progress_state
from tps_solver.core.problem import Problem

__all__ = ["TimePeriodicProblem", "newton", "continuation", "fixed_point", "interrupted_message", "CORRECTOR_ITER", "SCHEMES"]

SCHEMES = ("newton", "picard", "paper")
CORRECTOR_ITER = 12      # Newton corrector steps per continuation point (quadratic: ~4 suffice)


class TimePeriodicProblem(Problem):
    """The problem protocol (:mod:`tps_solver.core.problem`) of the TPS problems, on top of
    their ``residual(tc) -> (F, aux, phase)`` and ``jacobian_operator``: the Jacobian's action,
    the Jacobi preconditioner (its diagonal, floored at 1e-3) and the step cap T/4.

    Examples
    --------
    >>> from tps_solver import FlatLayer
    >>> from tps_solver.solvers.tps.problems import ContinuumProblem
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> problem = ContinuumProblem("axisymmetric", 20.0, 4, flat, 8)
    >>> isinstance(problem, TimePeriodicProblem)
    True
    >>> F, w, phase = problem.residual(np.full(4, flat.t0))
    >>> J = problem.jacobian(np.full(4, flat.t0), F, (w, phase))
    >>> J.shape, bool(np.allclose(problem.limit_step(None, np.full(4, 100.0)), problem.T / 4))
    ((4, 4), True)
    """

    def jacobian(self, x, F, data):
        J, slope = self.jacobian_operator(x, *data)
        J.slope = slope
        return J

    def preconditioner(self, x, F, data, J):
        big = np.maximum(np.abs(J.slope), 1e-3)
        return LinearOperator(J.shape, matvec=lambda v: np.asarray(v).ravel() / big, dtype=float)

    def limit_step(self, x, dx):
        scale = float(np.max(np.abs(dx)))
        cap = self.T / 4.0
        return dx * (cap / scale) if scale > cap else dx


def interrupted_message(where):
    """The one wording of status 5 (interrupted; the last accepted iterate is kept).

    Examples
    --------
    >>> interrupted_message("in Newton step 3")
    'interrupted in Newton step 3 (KeyboardInterrupt); the fields are the last accepted iterate (pass tc_initial=sol.tc to resume)'
    """
    return (f"interrupted {where} (KeyboardInterrupt); the fields are the last accepted iterate "
            "(pass tc_initial=sol.tc to resume)")


def newton(problem, tc, tol, max_iter, callback=None):
    """Newton-GMRES with backtracking on max|F|: the one Newton engine
    (:func:`tps_solver.core.newton.newton`) with a Jacobi preconditioner, steps capped at T/4.

    A ``KeyboardInterrupt`` returns status 5 with the last accepted iterate (and the
    ``w`` that belongs to it).

    Returns ``(tc, w, status, message, nit, history)``: the contact times, shape (n,), their
    harmonics, a code of :data:`tps_solver.core.orbit.STATUS`, the message, the accepted steps and
    max|F| before and after each step.

    Examples
    --------
    The flat layer (every node at its launch phase t0 = 0.3068) is an exact solution; from
    all contact times shifted by 0.05, Newton returns to it quadratically:

    >>> from tps_solver import FlatLayer
    >>> from tps_solver.solvers.tps.problems import ContinuumProblem
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> problem = ContinuumProblem("axisymmetric", 20.0, 4, flat, 8)
    >>> tc, w, status, message, nit, history = newton(problem, np.full(4, flat.t0 + 0.05), 1e-12, 20)
    >>> status, nit, bool(np.allclose(tc, flat.t0, atol=1e-12))
    (0, 4, True)
    >>> message
    'converged: max|F| = ... <= tol = 1.0e-12'
    """
    cb = None if callback is None else (
        lambda s: callback(progress_state("newton", s.iteration, residual=s.residual, tc=s.x)))
    out = core_newton(problem, tc, tol=tol, max_iter=max_iter, min_step=1.0 / 64, callback=cb)
    message = out.message
    if out.status == 5:
        message = interrupted_message(f"in Newton step {out.nit + 1}")
    return out.x, out.data[0], out.status, message, out.nit, [float(r) for r in out.history]


def continuation(make_problem, tc, tol, max_iter, nu_start, callback=None, min_step=1e-2):
    r"""Natural-parameter continuation in the coupling :math:`\nu_c` from the decoupled limit.

    At :math:`\nu_c \to 0` the nodes decouple and every pattern of flat phases
    is an exact solution; the branch is followed in :math:`\ln\nu_c` up to 1
    with a secant predictor and Newton corrector.  A step that fails is
    halved; when the step falls below ``min_step`` the branch is declared to
    end (a fold: no solution on this branch beyond the last coupling reached).
    ``callback(state)`` after the k-th accepted point (stage ``"coupling continuation"``,
    ``iteration`` k, ``residual``, ``tc``, ``coupling``).  A
    ``KeyboardInterrupt`` returns status 5 with the last accepted point (at its
    coupling, which ``problem.coupling`` reports).

    Returns (tc, w, status, message, nit, history, path, problem), where
    ``path`` lists (coupling, Newton iterations, residual) of accepted points.

    Examples
    --------
    The default kink (8 half-line nodes of spacing 20) from the step pattern at the decoupled
    coupling (h / 60)^2 = 1/9; the result is that of :func:`~tps_solver.solve_kink`:

    >>> from tps_solver import FlatLayer, solve_kink
    >>> from tps_solver.solvers.tps.problems import ContinuumProblem
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> make = lambda nu: ContinuumProblem("planar", 20.0, 8, flat, 8, coupling=nu)
    >>> tc, w, status, message, nit, history, path, problem = continuation(
    ...     make, np.full(8, flat.t0), 1e-10, 50, 1 / 9)
    >>> status, path[0][0], path[-1][0], problem.coupling
    (0, 0.111..., 1.0, 1.0)
    >>> bool(np.allclose(tc, solve_kink(n_harmonics=8).tc[8:], atol=1e-8))
    True

    On a grid of spacing 2 the branch ends at a fold, at the spacing ~10.9 of
    :data:`tps_solver.core.defaults.FOLD_SPACING_TPS`:

    >>> make = lambda nu: ContinuumProblem("planar", 2.0, 3, flat, 8, coupling=nu)
    >>> out = continuation(make, np.full(3, flat.t0), 1e-10, 50, (2.0 / 60) ** 2)
    >>> out[2], round(2.0 / math.sqrt(out[7].coupling), 1)
    (4, 10.9)
    >>> out[3]
    'continuation from the decoupled limit stopped at coupling nu_c = ... < 1 ...'
    """
    s = math.log(nu_start)
    problem = make_problem(nu_start)
    tc, w, status, message, nit, history = newton(problem, tc, tol, max_iter)
    total = nit
    path = [(nu_start, nit, history[-1])]
    if status == 5:
        return tc, w, 5, message, total, history, path, problem
    if status != 0:
        return tc, w, status, f"continuation could not start at coupling {nu_start:.3g}: {message}", \
            total, history, path, problem
    step, s_prev, tc_prev = 0.5, None, None
    try:
        while s < 0.0:
            s_try = min(0.0, s + step)
            if tc_prev is not None:
                tc_pred = tc + (tc - tc_prev) * (s_try - s) / (s - s_prev)
            else:
                tc_pred = tc
            trial_problem = make_problem(math.exp(s_try))
            out = newton(trial_problem, tc_pred, tol, min(max_iter, CORRECTOR_ITER))
            total += out[4]
            if out[2] == 5:
                raise KeyboardInterrupt
            if out[2] == 0:
                s_prev, tc_prev = s, tc
                s = s_try
                tc, w, _, _, nit, history = out
                problem = trial_problem
                path.append((math.exp(s), nit, history[-1]))
                if callback is not None:
                    callback(progress_state("coupling continuation", len(path), residual=history[-1], tc=tc,
                                            coupling=math.exp(s)))
                step = min(2.0 * step, 1.0)
            else:
                step *= 0.5
                if step < min_step:
                    nu = math.exp(s)
                    return tc, w, 4, (
                        f"continuation from the decoupled limit stopped at coupling nu_c = {nu:.6g} < 1 "
                        f"(node spacing {1 / math.sqrt(nu):.4g} x the requested one): the branch of "
                        f"single-contact solutions ends there (Newton fails for every smaller step; a fold "
                        f"is the likely cause); the returned fields are the converged solution at that "
                        f"coupling."), total, history, path, problem
    except KeyboardInterrupt:
        return tc, w, 5, interrupted_message(
            f"during the continuation at coupling nu_c = {problem.coupling:.6g} < 1 ({len(path)} points)"), \
            total, history, path, problem
    return tc, w, 0, converged_message(history[-1], tol, f"by continuation in the coupling ({len(path)} points)"), total, history, path, problem


def fixed_point(problem, tc, tol, max_iter, scheme, paper_sign, callback=None):
    """The plain fixed point ("picard") or the paper's incremental scheme (47) ("paper").

    "paper": with w^0 = w(tc^0) and tc^{-1} = tc^0, each sweep adds
    u^k = H[-sigma Q^{k-1}], Q^{k-1} = Gamma^-1 (e^{-in alpha tc^{k-1}} - e^{-in alpha tc^{k-2}}),
    to the iterate and selects tc^k from it by the contact rule.  For sigma = +1 this gives
    w^k = w(tc^{k-1}) exactly, i.e. the scheme is the Picard iteration lagged by one sweep.
    Convergence is always judged on the consistent residual F(tc^k) (a fresh solve), so an
    iterate that drifted away from w(tc) is never reported as converged.  ``callback(state)``
    after each sweep (stage = the scheme, ``iteration``, ``residual``, ``tc``); a ``KeyboardInterrupt`` returns status 5 with the last sweep.

    Returns ``(tc, w, status, message, nit, history)`` as :func:`newton`.

    Examples
    --------
    Near the flat layer the Picard iteration contracts linearly at
    rho = (2N/Gamma) / (2N/Gamma + sin t0) = 0.955 for N = 8 (docs/design.md, hazard 3):

    >>> from tps_solver import FlatLayer
    >>> from tps_solver.solvers.tps.problems import ContinuumProblem
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> problem = ContinuumProblem("axisymmetric", 20.0, 4, flat, 8)
    >>> tc, w, status, message, nit, history = fixed_point(
    ...     problem, np.full(4, flat.t0 + 1e-3), 1e-10, 20, "picard", 1)
    >>> status, message
    (1, 'iteration limit (20) reached')
    >>> rho = (16 / 2.5) / (16 / 2.5 + math.sin(flat.t0))
    >>> round(history[-1] / history[-2], 3), round(rho, 3)
    (0.955, 0.955)
    """
    F, w, _ = problem.residual(tc)
    history = [float(np.max(np.abs(F)))]
    status, message, nit = 1, f"iteration limit ({max_iter}) reached", 0
    tc_prev = tc.copy()
    w_iter = w
    done = 0
    try:
        for nit in range(1, max_iter + 1):
            if history[-1] <= tol:
                nit -= 1
                status, message = 0, converged_message(history[-1], tol)
                break
            if scheme == "paper":
                w_iter = w_iter + problem.paper_increment(tc, tc_prev, paper_sign)
            else:
                w_iter = w
            sel = problem.select_contact(w_iter, tc)
            if not np.all(sel.ok):
                status = 3
                message = (f"contact-time selection failed at {int(np.sum(~sel.ok))} node(s) in iteration "
                           f"{nit}: no jump-like up-crossing of (46)")
                nit -= 1
                break
            F_new, w_new, _ = problem.residual(sel.tc)
            tc_prev, tc, F, w = tc, sel.tc, F_new, w_new
            history.append(float(np.max(np.abs(F))))
            done = nit
            if callback is not None:
                callback(progress_state(scheme, nit, residual=history[-1], tc=tc))
            if not np.isfinite(history[-1]):
                status, message = 2, "residual became non-finite"
                break
        else:
            if history[-1] <= tol:
                status, message = 0, converged_message(history[-1], tol)
    except KeyboardInterrupt:
        del history[done + 1:]
        return tc, w, 5, interrupted_message(f"in sweep {done + 1}"), done, history
    return tc, w, status, message, nit, history
