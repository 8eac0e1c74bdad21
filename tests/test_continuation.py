"""Pseudo-arclength continuation: folds and period doublings against closed forms and the exact cycle."""
import math

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.analyses.continuation import continue_branch, load_branch
from tps_solver.core import problem as tps_problem


@pytest.fixture(scope="module")
def flat_branch():
    return continue_branch(tps.FlatLayer(2.5, 2, e=0.45), "Gamma", (2.3, 3.2), bothsides=True)


def test_flat_branch_finds_the_stability_window_to_1e8(flat_branch):
    lo, hi = tps.FlatLayer.stability_window(0.45, 2)
    kinds = dict(flat_branch.special_points)
    assert set(kinds) == {"fold", "period_doubling"}
    assert abs(kinds["fold"] - lo) <= 1e-8
    assert abs(kinds["period_doubling"] - hi) <= 1e-8
    # the fold is the saddle-node of (19): Gamma_SN = s pi M exactly
    assert abs(kinds["fold"] - (0.55 / 1.45) * math.pi * 2) <= 1e-8


def test_flat_branch_stability_matches_flatlayer_pointwise(flat_branch):
    for G, t0, stable in zip(flat_branch.parameter_values, flat_branch.states[:, 0], flat_branch.stable):
        fl = tps.FlatLayer(G, 2, t0=t0)
        assert abs(fl.e - 0.45) < 1e-9                    # the point solves (19) at the fixed e
        assert bool(stable) == bool(fl.is_stable)
    # both sides of the fold are on the branch: t0 changes sign there
    assert flat_branch.states[:, 0].min() < 0.0 < flat_branch.states[:, 0].max()


def test_flat_branch_in_e():
    br = continue_branch(tps.FlatLayer(2.5, 2, e=0.45), "e", (0.3, 0.6), bothsides=True)
    kinds = dict(br.special_points)
    # period doubling at e where the window's upper end is 2.5
    e_pd = kinds["period_doubling"]
    assert abs(tps.FlatLayer.stability_window(e_pd, 2)[1] - 2.5) < 1e-7
    # fold where Gamma = s(e) pi M = 2.5
    s = 2.5 / (2 * math.pi)
    assert abs(kinds["fold"] - (1 - s) / (1 + s)) < 1e-8


@pytest.fixture(scope="module")
def cycle():
    lat = tps.Lattice.planar(n_nodes=8, length=140.0)
    return tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=0.45, t0=None)


def test_lattice_cycle_branch_passes_the_fold_in_spacing(cycle):
    br = continue_branch(cycle, "spacing", (8.0, 30.0), direction=-1, multipliers=False)
    folds = [v for k, v in br.special_points if k == "fold"]
    assert len(folds) == 1
    # the exact cycle's fold, measured before by natural continuation in the coupling: 13.6 +- 0.5 %
    assert abs(folds[0] - 13.6) / 13.6 < 0.01
    # the branch comes back: the spacing decreases to the fold, then increases past the start
    p = br.parameter_values
    i = int(np.argmin(p))
    assert p[i] < 13.7 and p[-1] > 20.0 and np.all(np.diff(p[:i + 1]) < 0) and np.all(np.diff(p[i:]) > 0)
    # every point is a solution of the exact cycle's contact condition on the scaled lattice
    for tc, h in zip(br.states[::7], p[::7]):
        lat = tps.Lattice(cycle.lattice.nodes * h / 20.0, "planar", "neumann")
        res = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=0.45, t0=None, tc_initial=tc, continuation=False)
        assert res.converged and res.nit == 0


def test_the_multiplier_passes_plus_one_at_the_fold(cycle):
    br = continue_branch(cycle, "spacing", (8.0, 30.0), direction=-1, multipliers=False)
    fold = next(d for d in br.special_details if d["kind"] == "fold")
    i = fold["index"]
    before, after = br.states[i - 1], br.states[i + 1]
    mu = []
    for tc, h in ((before, br.parameter_values[i - 1]), (after, br.parameter_values[i + 1])):
        lat = tps.Lattice(cycle.lattice.nodes * h / 20.0, "planar", "neumann")
        cyc = tps.solve_lattice_cycle(lat, Gamma=2.5, M=2, e=0.45, t0=None, tc_initial=tc, continuation=False)
        orb = tps.find_periodic_orbit(lat, Gamma=2.5, M=2, e=0.45, guess=cyc)
        mu.append(float(np.max(np.abs(orb.multipliers))))
    assert mu[0] < 1.0 < mu[1]


def test_branch_save_load_round_trip(flat_branch, tmp_path):
    path = flat_branch.save(tmp_path / "branch")
    assert path.endswith(".npz")
    again = load_branch(tmp_path / "branch")
    assert again.special_points == flat_branch.special_points
    np.testing.assert_array_equal(again.parameter_values, flat_branch.parameter_values)
    np.testing.assert_array_equal(again.stable, flat_branch.stable)
    fig = again.plot(tmp_path / "branch.png")
    ax = fig.axes[0]
    assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title()
    assert (tmp_path / "branch.png").stat().st_size > 0


def test_load_branch_refuses_foreign_files(tmp_path):
    np.savez(tmp_path / "other.npz", a=np.arange(3))
    with pytest.raises(ValueError, match="not a tps_solver branch"):
        load_branch(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="readable"):
        load_branch(tmp_path / "junk.npz")


@pytest.mark.parametrize("kw, name", [
    (dict(bounds=None), "bounds"),
    (dict(bounds=(3.0, 2.0)), "bounds"),
    (dict(bounds=(2.6, 3.0)), "bounds"),          # does not contain the start
    (dict(bounds=(2.0, float("nan"))), "bounds"),
    (dict(bounds=(2.0, 3.0), step=0.0), "step"),
    (dict(bounds=(2.0, 3.0), step=-1.0), "step"),
    (dict(bounds=(2.0, 3.0), parameter="cutoff"), "parameter"),
    (dict(bounds=(2.0, 3.0), direction=0), "direction"),
])
def test_bad_input(kw, name):
    kw = dict(dict(parameter="Gamma"), **kw)
    with pytest.raises(ValueError, match=name):
        continue_branch(tps.FlatLayer(2.5, 2, e=0.45), **kw)


def test_bad_start():
    with pytest.raises(ValueError, match="start"):
        continue_branch("a flat layer", "Gamma", (2.0, 3.0))


def test_cli_branch_flat_reports_both_special_points(tmp_path, capsys):
    from tps_solver.cli import main

    code = main(["branch", "flat", "--e", "0.45", "--bounds", "2.3", "3.2", "--plot", str(tmp_path / "b.png"),
                 "--save", str(tmp_path / "b.npz")])
    out = capsys.readouterr().out
    assert code == 0
    lo, hi = tps.FlatLayer.stability_window(0.45, 2)
    assert f"fold             at Gamma = {lo:.12g}"[:38] in out
    assert "period_doubling" in out and (tmp_path / "b.png").exists() and (tmp_path / "b.npz").exists()


def test_cli_sweep_basins_serial(tmp_path, capsys):
    from tps_solver.cli import main

    code = main(["sweep", "basins", "--gamma", "4.1", "4.1", "1", "--e", "0", "0", "1", "--samples", "4",
                 "--serial", "--store", str(tmp_path / "store")])
    out = capsys.readouterr().out
    assert code == 0
    # e = 0, Gamma = 4.1: every start reaches the sticking f/2 orbit
    assert out.strip().splitlines()[-1].split()[-1] == "1.000"


@pytest.mark.parametrize("argv, flag", [
    (["sweep", "basins", "--gamma", "4.1", "4.0", "1", "--e", "0", "0", "1"], "--gamma"),
    (["sweep", "basins", "--gamma", "4.1", "4.1", "0", "--e", "0", "0", "1"], "--gamma"),
    (["sweep", "basins", "--gamma", "4.1", "4.1", "1", "--e", "0", "0", "1", "--samples", "0"], "--samples"),
    (["sweep", "basins", "--gamma", "4.1", "4.1", "1", "--e", "0", "0", "1", "--model", "soft"], "--cutoff"),
    (["branch", "cycle", "--bounds", "8", "30", "--nodes", "1"], "--nodes"),
])
def test_cli_bad_flags_name_the_flag(argv, flag, capsys):
    from tps_solver.cli import main

    assert main(argv) == 2
    assert flag in capsys.readouterr().err


def test_shooting_orbit_branch_matches_independent_shooting(cycle):
    orb = tps.find_periodic_orbit(cycle.lattice, Gamma=2.5, M=2, e=0.45, guess=cycle, method="point")
    br = continue_branch(orb, "e", (0.40, 0.50), max_points=3, step=0.004, tol=1e-9)
    assert br.problem == "shooting" and br.parameter_values.size == 3
    for e, mu in zip(br.parameter_values[1:], br.multipliers[1:]):
        c = tps.solve_lattice_cycle(cycle.lattice, Gamma=2.5, M=2, e=e, t0=None)
        ref = tps.find_periodic_orbit(cycle.lattice, Gamma=2.5, M=2, e=e, guess=c, method="point")
        assert abs(abs(mu[0]) - abs(ref.multipliers[0])) < 1e-6


def test_shooting_orbit_cutoff_needs_a_soft_orbit(cycle):
    orb = tps.find_periodic_orbit(cycle.lattice, Gamma=2.5, M=2, e=0.45, guess=cycle, method="point")
    with pytest.raises(ValueError, match="cutoff"):
        continue_branch(orb, "cutoff", (0.1, 0.5))


def test_soft_orbit_branch_multipliers_match_the_closed_form_flat_monodromy():
    """Soft flat orbit on 3 nodes continued in the cut-off: the branch's multipliers (exact soft
    monodromy, tps_solver.solvers.shooting.soft_monodromy) against SoftFlatOrbit's closed-form per-mode map at
    every point.  (The central-difference Jacobian it replaced was off by 3e-10 to 3e-9 here.)"""
    from validation.continuation import soft_branch

    rows = soft_branch("cutoff", (0.25, 0.35), max_points=3)
    assert len(rows) == 3 and rows[-1]["value"] > 0.304
    for r in rows:
        assert r["n_multipliers"] == 6 and r["error"] < 1e-10, r


def test_special_points_are_typed_records_that_survive_save_and_load(flat_branch, tmp_path):
    from tps_solver.analyses.continuation import SpecialPoint

    sps = flat_branch.special_points
    assert sps and all(isinstance(sp, SpecialPoint) for sp in sps)
    window = tps.FlatLayer.stability_window(0.45, 2)
    fold = next(sp for sp in sps if sp.kind == "fold")
    assert fold.parameter == "Gamma" and abs(fold.value - window[0]) < 1e-8
    # at the fold a multiplier is +1, at the period doubling -1 (the located point's own multipliers)
    assert np.min(np.abs(fold.multipliers - 1.0)) < 1e-6
    pd = next(sp for sp in sps if sp.kind == "period_doubling")
    assert np.min(np.abs(pd.multipliers + 1.0)) < 1e-6
    back = tps.load(flat_branch.save(tmp_path / "b"))
    for a, b in zip(sps, back.special_points):
        assert type(b) is SpecialPoint and (a.kind, a.value, a.parameter, a.index) == (b.kind, b.value, b.parameter, b.index)
        assert np.array_equal(a.state, b.state) and np.array_equal(a.multipliers, b.multipliers)


# ---------------------------------------------------------------- any problem of the protocol
def test_impact_and_stick_orbits_continue_in_gamma_against_the_closed_form():
    """The e = 0 flat orbit (impact, then stick) followed in Gamma by the library's continuation:
    its contact times at every point against the closed-form orbit of model/sticking."""
    from tps_solver.solvers.tps.stick_problem import flat_stick_orbit

    start = tps.solve_stick_flat(Gamma=4.1)
    br = tps.continue_branch(start, "Gamma", (4.0, 4.3), multipliers=False, step=0.02, max_step=0.05)
    assert br.status == 0 and br.problem == "stick" and br.parameter_values.size >= 8
    assert br.parameter_values[-1] > 4.3
    C = start.problem.C
    errors = [np.max(np.abs(np.sort(x[:C]) - np.sort(flat_stick_orbit(G, 2).t)))
              for G, x in zip(br.parameter_values, br.states)]
    assert max(errors) <= 100 * 1e-11                 # the corrector's tol times the sensitivity


class _Circle(tps_problem.Problem):
    """x^2 + p^2 = 1: a fold (turning point in p) at p = +-1, x = 0."""

    parameters = {"p": 0.0}

    def residual(self, x):
        return np.array([x[0] ** 2 + self.parameters["p"] ** 2 - 1.0]), None

    def jacobian(self, x, F, data):
        return np.array([[2.0 * x[0]]])


def test_a_user_problem_continues_through_its_fold():
    br = tps.continue_branch((_Circle(), np.array([1.0])), "p", (-0.5, 2.0), multipliers=False,
                             step=0.05, max_step=0.1)
    folds = [sp for sp in br.special_points if sp.kind == "fold"]
    assert len(folds) == 1 and abs(folds[0].value - 1.0) <= 1e-8
    assert br.status == 0 and br.states[-1][0] < 0.0        # came back on the other side
    with pytest.raises(ValueError, match="parameter"):
        tps.continue_branch((_Circle(), np.array([1.0])), "q", (-0.5, 2.0))


def test_branch_point_is_typed_where_a_multiplier_passes_plus_one():
    # the map x -> x + F(x; p), F = p x - x^3, on its trivial branch x = 0: the multiplier 1 + p
    # passes +1 at p = 0 while p keeps increasing (a pitchfork); and the fold test stays silent
    from tps_solver.core.problem import Problem

    class Pitchfork(Problem):
        def __init__(self, p):
            self.p = p

        @property
        def parameters(self):
            return {"p": self.p}

        def at(self, **values):
            return Pitchfork(values.get("p", self.p))

        def residual(self, x):
            return np.array([self.p * x[0] - x[0] ** 3]), None

        def jacobian(self, x, F, data):
            return np.array([[self.p - 3.0 * x[0] ** 2]])

        def monodromy(self, x, data):
            return np.array([[1.0 + self.p - 3.0 * x[0] ** 2]])

    br = tps.continue_branch((Pitchfork(-0.5), np.array([0.0])), "p", (-0.5, 0.5), step=0.05, max_step=0.1)
    kinds = [(k, v) for k, v in br.special_points]
    assert [k for k, _ in kinds] == ["branch_point"]
    assert abs(kinds[0][1]) < 1e-9
    assert br.stable[0] and not br.stable[-1]


def test_continuation_starts_at_the_end_of_the_parameter_range():
    """From e = 0 (the completely inelastic layer) dF/de is one-sided: a central difference would ask
    for e = -1e-6 and be refused.  Manufactured branch x = (1 + e)^2."""
    from tps_solver.core.problem import Problem

    class Square(Problem):
        def __init__(self, e=0.0):
            self.e = e

        @property
        def parameters(self):
            return {"e": self.e}

        def at(self, **values):
            return Square(values.get("e", self.e))

        def residual(self, x):
            return np.array([x[0] - (1.0 + self.e) ** 2]), None

        def jacobian(self, x, F, data):
            return np.eye(1)

    br = tps.continue_branch((Square(0.0), np.array([1.0])), "e", (0.0, 0.5), multipliers=False, step=0.02)
    assert br.status == 0 and br.parameter_values[0] == 0.0 and br.parameter_values[-1] >= 0.5
    assert np.max(np.abs(br.states[:, 0] - (1.0 + br.parameter_values) ** 2)) <= 1e-12
