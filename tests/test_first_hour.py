"""A user's first hour: defaults that work, honest results, bounded cost.

Each test pins one behaviour that failed before: the natural first calls, integral floats,
one set of defaults, what an unconverged result says and reports, refusals of calls out of
reach, callbacks, interrupts, and the BLAS thread limit.
"""
import argparse
import inspect
import logging

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import costs as budget, defaults, progress
from tps_solver.solvers.tps.engine import newton

COARSE = dict(n_nodes=8, length=140.0)          # the README's coarse lattice (spacing 20)


# ----------------------------------------------------------- 1. first calls
@pytest.mark.parametrize("solver", ["oscillon", "kink"])
def test_e_alone_fixes_the_model(solver):
    """`solve_oscillon(Gamma=2.5, e=0.45)` raised 'e and t0 are inconsistent' (t0 defaulted to 0)."""
    fn = tps.solve_oscillon if solver == "oscillon" else tps.solve_kink
    sol = fn(Gamma=2.5, e=0.45, n_harmonics=8)
    assert sol.e == 0.45
    assert sol.t0 == pytest.approx(tps.FlatLayer(2.5, 2, e=0.45).t0, abs=1e-15)


def test_lattice_cycle_with_e_alone():
    cyc = tps.solve_lattice_cycle(tps.Lattice.planar(**COARSE), e=0.45)
    assert cyc.converged and cyc.e == 0.45


@pytest.mark.parametrize("solver", ["oscillon", "kink"])
def test_defaults_converge_on_a_stable_non_marginal_layer(solver):
    """No e, no t0, no grid: a converged, physically checked result on a stable interior layer."""
    fn = tps.solve_oscillon if solver == "oscillon" else tps.solve_kink
    sol = fn()
    assert sol.converged and sol.status == 0, sol.message
    assert sol.checks.all_pass and sol.checks.min_zeta >= 0.0
    assert sol.e == defaults.E and sol.N == defaults.N_HARMONICS
    mu = np.abs(sol.flat.floquet_multipliers())
    assert sol.flat.is_stable and np.max(mu) < 0.9          # not marginal (the paper's t0 = 0 has |mu| = 1)
    assert np.min(np.diff(sol.nodes)) == pytest.approx(defaults.SPACING)
    np.testing.assert_array_equal(sol.nodes, sol.nodes_requested)


def test_paper_preset_is_named_and_marginal():
    fl = tps.FlatLayer(defaults.GAMMA, defaults.M, **defaults.PAPER_PRESET)
    assert fl.t0 == 0.0 and abs(fl.e - 0.4307) < 1e-4
    assert abs(np.max(np.abs(fl.floquet_multipliers())) - 1.0) < 1e-9


def test_integral_floats_are_integers():
    sol = tps.solve_kink(M=2.0, n_harmonics=8.0, n_nodes=8.0)
    assert sol.M == 2 and isinstance(sol.M, int) and sol.N == 8 and sol.nodes.size == 16
    assert tps.Lattice.planar(41.0, 20.0).n_nodes == 41
    chk = tps.check_stability(tps.FlatLayer(2.5, 2.0, e=0.45), periods=4.0, n_nodes=5.0)
    assert chk.periods == 4 and chk.lattice.n_nodes == 5
    for kw, name in ((dict(M=2.5), "M"), (dict(n_nodes=8.5), "n_nodes"), (dict(n_harmonics=np.nan), "n_harmonics")):
        with pytest.raises(ValueError, match=name):
            tps.solve_kink(**kw)
    with pytest.raises(ValueError, match="periods"):
        tps.check_stability(tps.FlatLayer(2.5, e=0.45), periods=4.5)


def test_one_set_of_defaults_api_cli_demo():
    from tps_solver._commands import _tps_common, demo

    osc = inspect.signature(tps.solve_oscillon).parameters
    kink = inspect.signature(tps.solve_kink).parameters
    assert osc["n_nodes"].default == kink["n_nodes"].default == defaults.N_NODES
    assert osc["n_harmonics"].default == kink["n_harmonics"].default == defaults.N_HARMONICS
    assert osc["r_max"].default == defaults.R_MAX
    assert osc["e"].default is None and osc["t0"].default is None
    for geometry, size in (("planar", defaults.HALF_LENGTH), ("axisymmetric", defaults.R_MAX)):
        parser = argparse.ArgumentParser()
        _tps_common.configure(parser, geometry)
        args = parser.parse_args([])
        # --nodes, --length / --r-max and --gamma are None unless given: the command resolves them to the
        # library's defaults for the model asked for (the single-contact grid, or the e = 0 lattice)
        assert (args.nodes, args.N, args.size, args.gamma, args.M) == (
            None, defaults.N_HARMONICS, None, None, defaults.M)
        assert args.e in (None, defaults.E) and args.t0 is None
    parser = argparse.ArgumentParser()
    demo.configure(parser)
    args = parser.parse_args([])
    assert (args.nodes, args.N, args.e, args.gamma, args.M) == (
        defaults.N_NODES, defaults.N_HARMONICS, defaults.E, defaults.GAMMA, defaults.M)


# ------------------------------------------------------ 2. honest results
@pytest.fixture(scope="module")
def folded():
    """A fine grid: the single-contact branch ends at a fold (status 4)."""
    return tps.solve_oscillon(n_harmonics=8, n_nodes=20, r_max=4.0)


def test_unconverged_result_is_labelled_and_fails_checks(folded):
    sol = folded
    assert sol.status == 4 and not sol.converged
    assert sol.checks.all_pass is False and sol.checks.converged is False
    np.testing.assert_allclose(sol.nodes_requested, np.linspace(0.0, 4.0, 20), atol=1e-12)
    # the fields are on the stretched nodes, by the coupling reached
    np.testing.assert_allclose(sol.nodes, sol.nodes_requested / np.sqrt(sol.coupling), rtol=1e-12)
    assert "sol.nodes_requested" in sol.message and "What to try" in sol.message
    assert "n_nodes" in sol.message or "r_max" in sol.message
    assert "soft" in sol.message


def test_suggested_grid_converges(folded):
    """The grid the message names does converge."""
    text = folded.message.split("What to try")[1]
    r_max = float(text.split("r_max=")[1].split(" ")[0])
    sol = tps.solve_oscillon(n_harmonics=8, n_nodes=20, r_max=r_max)
    assert sol.converged, sol.message


def test_iteration_limit_fails_checks():
    sol = tps.solve_kink(n_harmonics=8, n_nodes=6, half_length=110.0, max_iter=1, continuation=False,
                         tc_initial=lambda x: np.full(x.size, 0.4))
    assert not sol.converged and sol.status in (1, 2)
    assert sol.checks.all_pass is False and "What to try" in sol.message


def test_paper_preset_says_it_is_marginal():
    sol = tps.solve_kink(n_harmonics=8, **defaults.PAPER_PRESET)
    assert not sol.converged
    assert "marginal" in sol.message and "e=0.45" in sol.message


def test_check_stability_refuses_an_unconverged_orbit(folded):
    with pytest.raises(ValueError, match="solution must be a periodic orbit, but it did not converge"):
        tps.check_stability(folded, periods=2)


def test_grid_instability_is_named_first():
    fl = tps.FlatLayer(Gamma=2.5, M=2, e=0.45)
    chk = tps.check_stability(fl, periods=10, n_nodes=21)
    assert fl.is_stable and not chk.stable and chk.growth_factor > 1.5
    assert chk.grid_instability is True
    assert chk.message.startswith("not stable, by the grid-scale instability of point impacts")
    assert "method='soft'" in chk.message


def test_stable_cycle_is_not_called_grid_instability():
    cyc = tps.solve_lattice_cycle(tps.Lattice.planar(**COARSE))
    chk = tps.check_stability(cyc, periods=6)
    assert chk.stable and chk.grid_instability is False and chk.message.startswith("stable")


# ------------------------------------------------------- 3. bounded cost
def test_huge_truncation_is_refused_before_allocating():
    with pytest.raises(ValueError, match=r"n_harmonics = 1000000 is out of reach for solve_kink: estimated .*GB"):
        tps.solve_kink(e=0.45, n_harmonics=10 ** 6)


def test_huge_lattice_is_refused():
    with pytest.raises(ValueError, match=r"n_nodes = 100000 is out of reach for Lattice: estimated memory .*GB"):
        tps.Lattice.planar(10 ** 5)
    with pytest.raises(ValueError, match="lattice.n_nodes = 1000 is out of reach for solve_lattice_cycle"):
        tps.solve_lattice_cycle(tps.Lattice.planar(1000, 20000.0))


def test_harmonics_helper_for_flat_layer():
    with pytest.raises(ValueError, match=r"N = 1000000000 is out of reach for FlatLayer.harmonics"):
        budget.check_cost("FlatLayer.harmonics", "N", 10 ** 9, *budget.harmonics_cost(10 ** 9))
    assert budget.check_cost("FlatLayer.harmonics", "N", 64, *budget.harmonics_cost(64))


def test_limits_can_be_changed():
    old = budget.set_limits(memory=1e6)
    try:
        with pytest.raises(ValueError, match="n_nodes = 8 is out of reach for solve_kink: estimated memory"):
            tps.solve_kink()
    finally:
        budget.set_limits(**old)
    with pytest.raises(ValueError, match="memory"):
        budget.set_limits(memory=-1)


def test_checks_memory_is_bounded_in_blocks():
    """The checks evaluate the series in blocks: the same numbers as one evaluation."""
    from tps_solver.solvers.tps import checks

    sol = tps.solve_oscillon(n_harmonics=8)
    whole = checks.physical_checks(sol)
    old = checks.BLOCK_BYTES
    checks.BLOCK_BYTES = 16 * 17 * 100                       # 100 times per block
    try:
        blocks = checks.physical_checks(sol)
    finally:
        checks.BLOCK_BYTES = old
    assert blocks.min_zeta == whole.min_zeta
    np.testing.assert_array_equal(blocks.contacts_per_period, whole.contacts_per_period)


class _StopAt:
    """A callback that raises KeyboardInterrupt once, at its k-th call (Ctrl-C)."""

    def __init__(self, k):
        self.k, self.calls, self.fired = k, 0, False

    def __call__(self, *args):
        self.calls += 1
        if self.calls == self.k and not self.fired:
            self.fired = True
            raise KeyboardInterrupt


@pytest.mark.parametrize("continuation", [True, False])
def test_interrupted_tps_keeps_last_iterate(continuation):
    stop = _StopAt(2)
    kw = dict(n_harmonics=8, continuation=continuation, callback=stop)
    if not continuation:
        kw["tc_initial"] = lambda x: np.full(x.size, tps.FlatLayer(2.5, e=0.45).t0 + 0.3)
    sol = tps.solve_oscillon(**kw)
    assert sol.status == 5 and not sol.converged and not sol.checks.all_pass
    assert "interrupted" in sol.message and sol.tc.shape == (8,)
    assert np.all(np.isfinite(sol.tc)) and np.all(np.isfinite(sol.residual_history))
    if continuation:                   # the last accepted continuation point, at its coupling
        assert sol.coupling < 1.0 and sol.residual <= 1e-10
    else:                              # the last accepted Newton step
        assert sol.residual_history.size == sol.nit + 1 == 3


def test_interrupted_newton_returns_consistent_iterate():
    """The returned w belongs to the returned tc (the residual recomputed from tc matches)."""
    from tps_solver.solvers.tps.problems import ContinuumProblem

    fl = tps.FlatLayer(2.5, e=0.45)
    problem = ContinuumProblem("axisymmetric", 20.0, 6, fl, 6)
    tc, w, status, message, nit, history = newton(problem, np.full(6, fl.t0 + 0.3), 1e-12, 20, _StopAt(2))
    assert status == 5 and nit == 2 and len(history) == 3
    F, w_again, _ = problem.residual(tc)
    np.testing.assert_allclose(w, w_again, rtol=0, atol=0)
    assert float(np.max(np.abs(F))) == history[-1]


def test_lattice_cycle_callback_and_interrupt():
    seen = []
    cyc = tps.solve_lattice_cycle(tps.Lattice.planar(**COARSE), callback=lambda s: seen.append(s.residual))
    assert cyc.converged and len(seen) >= 2 and seen[-1] <= 1e-12
    cut = tps.solve_lattice_cycle(tps.Lattice.planar(**COARSE), callback=_StopAt(2))
    assert cut.status == 5 and not cut.converged and cut.coupling < 1.0
    with pytest.raises(ValueError, match="callback"):
        tps.solve_lattice_cycle(tps.Lattice.planar(**COARSE), callback=3)


def test_check_stability_progress_and_interrupt():
    fl = tps.FlatLayer(2.5, e=0.45)
    seen = []
    chk = tps.check_stability(fl, periods=3, n_nodes=5, callback=lambda p: seen.append((p.stage, p.fraction)))
    fractions = [f for _, f in seen]
    assert np.all(np.diff(fractions) >= 0) and fractions[-1] == 1.0
    assert {s for s, _ in seen} == {"reference", "perturbed", "uniform mode"}
    assert chk.interrupted is False
    cut = tps.check_stability(fl, periods=3, n_nodes=5, callback=_StopAt(1))
    assert cut.interrupted and not cut.stable and cut.message.startswith("interrupted")


def test_small_lattices_run_on_one_blas_thread():
    threadpoolctl = pytest.importorskip("threadpoolctl")

    def blas_threads_now():
        return {i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"}

    before = blas_threads_now()
    seen = []
    fl = tps.FlatLayer(2.5, e=0.45)
    lat = tps.Lattice.planar(5, 4.0)
    t = fl.t0 + 1.0
    tps.simulate(lat, 2.5, 0.45, np.full(5, fl.velocity(t)), np.full(5, fl.height(t)), t_start=t,
                 t_end=t + 2 * fl.period, callback=lambda p: seen.append(blas_threads_now()))
    assert seen and all(s == {1} for s in seen)
    assert blas_threads_now() == before                     # restored afterwards


def test_blas_limit_scans_the_thread_pools_once(monkeypatch):
    """threadpoolctl's scan of the loaded libraries (2-4 ms) is kept between blas_threads blocks."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from tps_solver.core import costs as budget

    scans = []
    real = threadpoolctl.ThreadpoolController

    class Counting(real):
        def __init__(self, *args, **kwargs):
            scans.append(1)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(threadpoolctl, "ThreadpoolController", Counting)
    monkeypatch.setattr(budget, "_CONTROLLER", [])
    for _ in range(3):
        with budget.blas_threads(1):
            assert {i["num_threads"] for i in real().info() if i["user_api"] == "blas"} == {1}
    assert len(scans) == 1


def test_progress_display_without_tqdm(monkeypatch, caplog):
    import builtins

    real_import = builtins.__import__

    def no_tqdm(name, *args, **kwargs):
        if name.startswith("tqdm"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_tqdm)
    with caplog.at_level(logging.INFO, logger="tps_solver"):
        with progress.Progress("kink") as bar:
            assert bar.bar is None
            bar.newton(3, None, 1.5e-4)
            bar.fraction(argparse.Namespace(fraction=1.0))
    assert "kink: step 3, max|F| = 1.500e-04" in caplog.text and "100 % done" in caplog.text


# ------------------------------------------------- CLI and demo on their defaults
@pytest.mark.parametrize("argv", [["oscillon"], ["kink"], ["oscillon", "--e", "0.45", "--N", "30"],
                                  ["kink", "--e", "0.45", "--N", "30"]])
def test_cli_defaults_converge(argv, capsys):
    """The README's `tps-solver oscillon --e 0.45 --N 30` and `kink` exited 1 (status 4)."""
    from tps_solver.cli import main

    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "converged?            True (status 0)" in out and "all physical checks   True" in out


def test_demo_defaults_are_converged_and_checked():
    from tps_solver._commands import demo

    rows, flat_ok = demo.summary_rows()
    assert flat_ok
    verdicts = {item.strip(): verdict for item, _, _, verdict in rows}
    tps_rows = [item for item in verdicts if item.startswith(("oscillon TPS (", "kink TPS ("))]
    assert len(tps_rows) == 2 and all(verdicts[item] == "ok" for item in tps_rows)
    assert list(verdicts.values()).count("FAIL") == 0 and "not converged" not in verdicts.values()


def test_lattice_cycle_in_blocks_matches_one_block():
    """The O(n^3) residual evaluated in row blocks (bounded memory) gives the same cycle."""
    from tps_solver.solvers.tps import cycle

    lat = tps.Lattice.axisymmetric(8, 140.0, grid="uniform")
    whole = tps.solve_lattice_cycle(lat, r_core=30.0)
    old = cycle.BLOCK_BYTES
    cycle.BLOCK_BYTES = 8 * 6 * 8 * 8 * 3                    # three rows per block
    try:
        blocks = tps.solve_lattice_cycle(lat, r_core=30.0)
        t = np.linspace(0.0, whole.period, 7)
        z_blocks = blocks.height(t)
    finally:
        cycle.BLOCK_BYTES = old
    assert whole.converged and blocks.converged
    np.testing.assert_allclose(blocks.tc, whole.tc, rtol=0, atol=1e-13)
    np.testing.assert_allclose(z_blocks, whole.height(t), rtol=0, atol=1e-12)


def test_flat_harmonics_refuse_an_out_of_reach_N_before_allocating():
    import tps_solver as tps

    fl = tps.FlatLayer(2.5, e=0.45)
    for call in (fl.harmonics, fl.height_harmonics):
        with pytest.raises(ValueError, match=r"^N = 1000000000 is out of reach.*GB"):
            call(10 ** 9)
    # an integral float is an integer
    assert fl.harmonics(2.0).shape == (5,)


@pytest.mark.parametrize("call", [
    lambda: tps.solve_kink(Gamma=4.1, e=0.0, n_harmonics=8),   # e = 0 kinks go to solve_stick_kink
    lambda: tps.solve_oscillon(Gamma=4.1, e=0.0, n_harmonics=8),
    lambda: tps.solve_lattice_cycle(tps.Lattice.planar(8, 140.0), Gamma=4.1, e=0.0),
])
def test_single_contact_tps_refuses_a_sticking_far_field(call):
    # e = 0 has a sticking flat orbit (FlatLayer pattern "stick"), not the single bounce the TPS assumes
    with pytest.raises(ValueError, match=r"^(e = 0.0 gives no single-bounce flat layer.*solve_stick_lattice|"
                                         r"n_harmonics applies to the single-contact TPS)"):
        call()
