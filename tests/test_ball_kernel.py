"""The compiled one-node ball (tps_solver.model.ball_kernel) against ClosedFormBall, and flat_basins both ways."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from tps_solver import flat_basins
from tps_solver.core import jit
from tps_solver.model.ball import FREE, ClosedFormBall

needs_numba = pytest.mark.skipif(not jit.enabled(), reason="numba (the fast extra) is not installed or disabled")

# (Gamma, e): sticking e = 0, the paper's chatter regime, a bouncing f/1-f/2 point, Gamma < 2
CASES = [(4.1, 0.0), (2.5, 0.45), (4.75, 0.2), (1.5, 0.3), (3.0, 0.1)]


def _reference_orbit(Gamma, e, w0, z0, n):
    ball = ClosedFormBall(Gamma, e, "point", None, 1e-6, 10000)
    st, out = (w0, z0, FREE), [(w0, z0, FREE)]
    for _ in range(n):
        st = ball.cycle(0.0, st)
        out.append(st)
    return np.array(out, dtype=float)


@pytest.mark.parametrize("Gamma,e", CASES)
def test_ball_cycles_equal_closed_form(Gamma, e):
    from tps_solver.model.ball_kernel import ball_cycles

    rng = np.random.default_rng(7)
    for _ in range(6):
        w0, z0 = rng.uniform(-2.0, 2.0), rng.uniform(0.0, 3.0)
        ref = _reference_orbit(Gamma, e, w0, z0, 30)
        out = ball_cycles(Gamma, e, 1e-6, 0.0, w0, z0, 30)
        assert np.array_equal(out[:, 2], ref[:, 2])
        # the same arithmetic; Brent's iterates may differ from scipy's brentq in the last bits
        assert np.max(np.abs(out[:, :2] - ref[:, :2])) <= 64 * np.finfo(float).eps * (1 + np.max(np.abs(ref)))


def test_ball_cycles_flat_orbit_closes():
    """From the e = 0 flat orbit's lift-off, the f/2 orbit repeats to rounding (closed form of the period)."""
    from tps_solver.model.ball_kernel import ball_cycles

    G = 4.1
    tl = math.asin(1 / G)
    x = ball_cycles(G, 0.0, 1e-6, tl, 0.0, 0.0, 8)
    # from rest at the lift-off phase: free at every section, the same state every two cycles
    assert np.max(np.abs(x[2::2] - x[2])) <= 1e-14
    assert np.max(np.abs(x[1::2] - x[1])) <= 1e-14


def test_ball_cycles_too_many_events_raises():
    from tps_solver.model.ball_kernel import ball_cycles

    # the reference raises with the same message (chatter at Gamma = 2.5, e = 0.45 from rest)
    ref = ClosedFormBall(2.5, 0.45, "point", None, 1e-12, 3)
    with pytest.raises(RuntimeError, match="more than 3 events") as exc_ref:
        st = (0.0, 0.0, FREE)
        for _ in range(5):
            st = ref.cycle(0.0, st)
    with pytest.raises(RuntimeError, match="more than 3 events") as exc:
        ball_cycles(2.5, 0.45, 1e-12, 0.0, 0.0, 0.0, 5, max_events=3)
    assert str(exc.value) == str(exc_ref.value)


@needs_numba
@pytest.mark.parametrize("Gamma,e", CASES)
def test_flat_basins_compiled_equals_reference(Gamma, e):
    kw = dict(M=2, n_samples=48, seed=3, periods=60)
    a = flat_basins(Gamma, e, engine="compiled", **kw)
    b = flat_basins(Gamma, e, engine="reference", **kw)
    assert np.array_equal(a.labels, b.labels) and np.array_equal(a.phases, b.phases)
    assert np.array_equal(a.n_cycles, b.n_cycles)
    assert (a.status, [x.label for x in a.attractors]) == (b.status, [x.label for x in b.attractors])
    for x, y in zip(a.attractors, b.attractors):
        assert np.allclose(x.points, y.points, rtol=0, atol=1e-12)
        assert np.allclose(x.multipliers, y.multipliers, rtol=0, atol=1e-6)


@needs_numba
def test_flat_basins_compiled_failed_samples_match():
    kw = dict(M=2, n_samples=16, seed=0, periods=20, max_events_per_cycle=4)
    a = flat_basins(2.5, 0.45, engine="compiled", **kw)
    b = flat_basins(2.5, 0.45, engine="reference", **kw)
    assert a.status == b.status == 6
    assert np.array_equal(a.labels, b.labels) and a.message == b.message


@pytest.mark.parametrize("kw,match", [
    (dict(model="soft", cutoff=0.3, e=0.5), "model='soft'"),
    (dict(integrator="simulate"), "integrator='simulate'"),
    (dict(executor=None), "executor or a store"),
])
def test_compiled_engine_refuses_what_it_does_not_model(kw, match):
    args = dict(e=0.45, n_samples=2, periods=20)
    args.update(kw)
    e = args.pop("e")
    with pytest.raises(ValueError, match=match):
        flat_basins(2.5, e, engine="compiled", **args)


def test_engine_is_validated():
    with pytest.raises(ValueError, match="engine"):
        flat_basins(2.5, 0.45, n_samples=2, periods=20, engine="gpu")


def test_interpreter_path_without_numba():
    """TPS_SOLVER_NUMBA=0: the same kernel source runs in the interpreter and gives the same states."""
    code = ("import numpy as np\n"
            "from tps_solver.core import jit\n"
            "from tps_solver.model.ball_kernel import ball_cycles, _advance\n"
            "assert not jit.enabled() and not hasattr(_advance, 'py_func')\n"
            "x = ball_cycles(2.5, 0.45, 1e-6, 0.0, 0.3, 0.7, 12)\n"
            "print(repr(x.tolist()))\n")
    env = dict(os.environ, TPS_SOLVER_NUMBA="0")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    x = np.array(eval(out.stdout))
    ref = _reference_orbit(2.5, 0.45, 0.3, 0.7, 12)
    assert np.array_equal(x[:, 2], ref[:, 2])
    assert np.max(np.abs(x[:, :2] - ref[:, :2])) <= 1e-13
