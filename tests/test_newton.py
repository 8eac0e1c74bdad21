"""The one Newton engine (tps_solver.core.newton) on problems with known answers."""
import math

import numpy as np
import pytest
from scipy.sparse.linalg import aslinearoperator

from tps_solver.core.newton import newton
from tps_solver.core.problem import Inadmissible, Problem

EPS = np.finfo(float).eps


class Rosen(Problem):
    """F = (10 (y - x^2), 1 - x): root (1, 1); J singular nowhere."""

    def __init__(self, operator=False):
        self.operator = operator

    def residual(self, x):
        return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]]), None

    def jacobian(self, x, F, data):
        J = np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0]])
        return aslinearoperator(J) if self.operator else J


class Arctan(Problem):
    """F = arctan(x - 2): plain Newton diverges from |x - 2| > 1.39; the line search must save it."""

    def residual(self, x):
        return np.arctan(x - 2.0), None

    def jacobian(self, x, F, data):
        return np.diag(1.0 / (1.0 + (x - 2.0) ** 2))


@pytest.mark.parametrize("operator", [False, True])
def test_quadratic_convergence_order(operator):
    out = newton(Rosen(operator), np.array([-1.2, 1.0]), tol=1e-15, max_iter=30)
    assert out.status == 0 and out.converged and out.success
    assert np.max(np.abs(out.x - 1.0)) <= 4 * EPS
    h = out.history[out.history > 1e-13]
    # log-log slope of successive residuals -> 2 (quadratic), measured on the last three
    slopes = np.diff(np.log(h[-3:]))[1:] / np.diff(np.log(h[-3:]))[:-1]
    assert np.all(slopes > 1.8)


@pytest.mark.parametrize("search", ["backtrack", "quadratic"])
def test_line_search_globalises_where_plain_newton_diverges(search):
    x0 = np.array([6.0])
    plain = newton(Arctan(), x0, tol=1e-14, max_iter=8, line_search="none")
    assert not plain.converged and not np.all(np.abs(plain.x - 2.0) < 1.0)
    damped = newton(Arctan(), x0, tol=1e-14, max_iter=40, line_search=search)
    assert damped.status == 0 and abs(damped.x[0] - 2.0) <= 4 * EPS
    assert np.min(damped.step_lengths) < 1.0            # it had to shorten a step
    assert np.all(np.diff(damped.history) < 0)           # monotone merit


def test_chord_reuses_the_factorisation_and_converges_to_the_same_root():
    fresh = newton(Rosen(), np.array([0.5, 0.5]), tol=1e-14, max_iter=40)
    chord = newton(Rosen(), np.array([0.5, 0.5]), tol=1e-14, max_iter=40, chord=0.5)
    assert fresh.status == chord.status == 0
    assert np.max(np.abs(chord.x - fresh.x)) <= 4 * EPS
    assert chord.n_jacobians <= fresh.n_jacobians


class Singular(Problem):
    def residual(self, x):
        return np.array([x[0] + x[1] - 1.0, 2.0 * (x[0] + x[1]) - 3.0]), None

    def jacobian(self, x, F, data):
        return np.array([[1.0, 1.0], [2.0, 2.0]])


def test_singular_jacobian_is_status_8_not_a_warning():
    out = newton(Singular(), np.zeros(2), tol=1e-12, max_iter=5)
    assert out.status == 8 and not out.converged
    assert "singular" in out.message and out.nit == 0


class Wall(Problem):
    """x = 3 is the root, but points beyond x = 1 are not admissible."""

    def residual(self, x):
        if x[0] > 1.0:
            raise Inadmissible("beyond the wall")
        return x - 3.0, None

    def jacobian(self, x, F, data):
        return np.eye(1)


def test_inadmissible_trials_are_rejected_and_reported_as_stagnation():
    out = newton(Wall(), np.array([0.99]), tol=1e-12, max_iter=10)
    # the full step (to 3) and its halvings down to min_step all lie beyond the wall except
    # the last few: the engine stops at the wall instead of raising
    assert out.status in (1, 2) and not out.converged
    assert out.x[0] <= 1.0


def test_keyboard_interrupt_keeps_the_last_accepted_iterate():
    seen = []

    def callback(state):
        seen.append(state.x.copy())
        if state.iteration == 2:
            raise KeyboardInterrupt

    out = newton(Rosen(), np.array([-1.2, 1.0]), tol=1e-15, max_iter=30, callback=callback)
    assert out.status == 5 and out.nit == 2
    assert np.array_equal(out.x, seen[-1]) and out.history.size == 3


def test_iteration_limit_and_xtol():
    out = newton(Arctan(), np.array([2.5]), tol=0.0, max_iter=3)
    assert out.status == 1 and out.nit == 3 and out.history.size == 4
    # from 2.5 the steps are 0.46, 0.04, 3e-5: the third is below xtol = 1e-3 while max|F| > 0
    stop = newton(Arctan(), np.array([2.5]), tol=0.0, max_iter=50, xtol=1e-3)
    assert stop.status == 2 and "xtol" in stop.message and stop.nit == 3
    assert 0.0 < abs(stop.x[0] - 2.0) < 1e-6


@pytest.mark.parametrize("kw, name", [({"line_search": "wolfe"}, "line_search"),
                                      ({"merit": "l1"}, "merit"), ({"linear": "qr"}, "linear")])
def test_bad_options_name_the_parameter(kw, name):
    with pytest.raises(ValueError, match=name):
        newton(Rosen(), np.zeros(2), tol=1e-12, max_iter=5, **kw)


def test_parameters_by_name():
    class Square(Problem):
        parameters = {"p": 2.0}

        def residual(self, x):
            return x ** 2 - self.parameters["p"], None

        def jacobian(self, x, F, data):
            return np.diag(2.0 * x)

    prob = Square()
    assert newton(prob.at(p=16.0), np.array([1.0]), tol=1e-14, max_iter=30).x[0] == pytest.approx(4.0, abs=4 * EPS)
    assert prob.parameters == {"p": 2.0}                   # at() copies
    with pytest.raises(ValueError, match="parameter"):
        prob.at(q=1.0)
    assert math.isclose(newton(prob, np.array([1.0]), tol=1e-15, max_iter=30).x[0] ** 2, 2.0, rel_tol=4 * EPS)


def test_every_former_newton_loop_keeps_its_iteration_count():
    """The five loops that became the one engine take the steps they took before (commit 33c4ade)."""
    from validation.house import BEFORE, engine_counts

    now = engine_counts()
    for key in ("kink_nit", "cycle_nit", "stick_flat_nit_4.1", "stick_flat_nit_4.6", "shooting_nit"):
        assert now[key] == BEFORE[key], key
    # scipy's GMRES forms the true residual once per cycle: one period map more per Newton step
    assert now["shooting_maps"] == BEFORE["shooting_maps"] + now["shooting_nit"]
    assert now["kink_residual"] <= 1e-10 and now["cycle_residual"] <= 1e-12
    assert now["stick_flat_error_4.1"] <= 1e-12 and now["stick_flat_error_4.6"] <= 1e-11


def test_gmres_on_a_dense_jacobian_uses_its_action():
    dense = newton(Rosen(), np.array([-1.2, 1.0]), tol=1e-15, max_iter=30)
    krylov = newton(Rosen(), np.array([-1.2, 1.0]), tol=1e-15, max_iter=30, linear="gmres")
    assert krylov.status == 0 and np.max(np.abs(krylov.x - dense.x)) <= 4 * EPS
    assert np.all(krylov.linear_products[:1] >= 1)
