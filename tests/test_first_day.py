"""A new user's first day with periodic orbits: each test is the user's call and the right outcome.

Success only when the requested object was found; far fields that say whether they are stable;
stability verdicts that agree with the multipliers (or say why they cannot); Ctrl-C at every
stage of the e = 0 kink (a callback raising KeyboardInterrupt at a chosen stage: deterministic
under load); continuation guarded from its start.
"""
import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core.problem import Problem


def _kink_lattice():
    return tps.Lattice.planar(n_nodes=6, length=40.0)      # dx = 8: the e = 0 kink in ~2 s


# ------------------------------------------------------------------ success that is not success
def test_e0_oscillon_that_collapses_to_the_flat_layer_is_not_converged():
    """dr = 2: the core of radius 5 shrinks to no node while settling; the orbit found is uniform."""
    lat = tps.Lattice.axisymmetric(n_nodes=11, r_max=20.0, grid="uniform")
    sol = tps.solve_oscillon(Gamma=4.1, e=0.0, lattice=lat, r_core=5.0)
    assert sol.converged is False and sol.success is False
    assert sol.status == 9 and tps.STATUS[9].startswith("not the orbit asked for")
    assert not sol.localized and not sol.checks.all_pass
    assert "no oscillon found" in sol.message and "status 9" in sol.message
    # it is the uniform orbit: the two ends of the lattice move alike over the period
    ts = sol.period * np.arange(32) / 32
    Z = sol.height(ts)
    assert np.max(np.abs(Z[:, 0] - Z[:, -1])) <= 1e-9 * np.max(np.abs(Z))


def test_kink_with_an_unstable_far_field_says_so():
    """Gamma = 4.1, e = 0.45: the single-bounce flat layer lies outside its stability window."""
    sol = tps.solve_kink(Gamma=4.1, e=0.45)
    lo, hi = tps.FlatLayer.stability_window(0.45, 2)
    assert not lo <= 4.1 <= hi                                   # the reference: the closed-form window
    rho = float(np.max(np.abs(sol.flat.floquet_multipliers())))
    assert rho == pytest.approx(5.78, abs=5e-3)
    assert sol.converged                                           # the kink exists ...
    assert sol.far_field_stable is False and sol.checks.far_field_stable is False   # ... but cannot be observed
    assert f"|mu| = {rho:.3g} > 1" in sol.message and "unstable" in sol.message
    np.testing.assert_array_equal(np.abs(sol.far_field_multipliers), np.abs(sol.flat.floquet_multipliers()))


def test_kink_with_a_stable_far_field_says_so():
    sol = tps.solve_kink()                                        # Gamma = 2.5, e = 0.45: inside the window
    lo, hi = tps.FlatLayer.stability_window(0.45, 2)
    assert lo <= sol.Gamma <= hi
    assert sol.converged and sol.far_field_stable is True and "unstable" not in sol.message


# ------------------------------------------------------------------ Ctrl-C at every stage of the e = 0 kink
STAGES = ["settle", "shooting", "multipliers", "tps", "checks"]


@pytest.mark.parametrize("stage", STAGES)
def test_e0_kink_interrupted_at_every_stage_returns_status_5_with_the_state_so_far(stage, tmp_path):
    seen = []

    def stop_at(state):
        seen.append(state.stage)
        if state.stage == stage:
            raise KeyboardInterrupt

    sol = tps.solve_kink(Gamma=4.1, e=0.0, lattice=_kink_lattice(), callback=stop_at)
    assert sol.status == 5 and sol.converged is False and sol.success is False
    assert sol.interrupted_stage == stage and "interrupted (KeyboardInterrupt)" in sol.message
    assert seen[-1] == stage
    before = STAGES[:STAGES.index(stage)]
    assert [s for s in STAGES if s in seen] == before + [stage]     # the stages run in order, none after
    # the state so far is kept: the settling run after "settle", the orbit after "shooting", ...
    assert (sol.run is not None) == (stage != "settle")
    assert (sol.orbit is not None) == (stage not in ("settle", "shooting"))
    if stage in ("tps", "checks"):
        assert sol.multipliers is not None and abs(sol.multipliers[0]) < 1.0
        assert sol.orbit.converged
    if stage == "checks":
        assert sol.residual <= 1e-10 and not sol.fda_check.passed
    assert not sol.checks.all_pass
    back = tps.load(sol.save(tmp_path / "cut"))                   # the state so far saves and loads
    assert back.status == 5 and back.interrupted_stage == stage and back.message == sol.message


def test_e0_kink_without_interrupt_reports_every_stage_and_converges():
    seen = []
    sol = tps.solve_kink(Gamma=4.1, e=0.0, lattice=_kink_lattice(), callback=lambda s: seen.append(s.stage))
    assert sol.converged and sol.status == 0 and sol.checks.all_pass and sol.far_field_stable
    assert [s for s in STAGES if s in seen] == STAGES


class _Interrupting(Problem):
    """x = p: a problem whose first residual is interrupted (the user's Ctrl-C during the start)."""

    def __init__(self, p=1.0, calls=None):
        self.p = p
        self.calls = [0] if calls is None else calls

    @property
    def parameters(self):
        return {"p": self.p}

    def at(self, **values):
        return _Interrupting(values.get("p", self.p), self.calls)

    def residual(self, x):
        self.calls[0] += 1
        if self.calls[0] == 1:
            raise KeyboardInterrupt
        return np.array([x[0] - self.p]), None

    def jacobian(self, x, F, data):
        return np.eye(1)


def test_continue_branch_interrupted_while_correcting_its_start_returns_status_5():
    br = tps.continue_branch((_Interrupting(1.0), np.array([1.0])), "p", (0.0, 2.0), multipliers=False)
    assert br.status == 5 and "interrupted" in br.message
    assert br.parameter_values.shape == (0,) and br.states.shape == (0, 1)


# ------------------------------------------------------------------ stability that agrees with the multipliers
def test_branch_without_multipliers_is_unknown_not_unstable():
    """An impact-and-stick branch computes no multipliers: every point is "unknown"."""
    from tps_solver.solvers.tps.stick import solve_stick_flat

    sol = solve_stick_flat(4.1, perturbation=1e-3)
    br = tps.continue_branch(sol, "Gamma", (4.0, 4.2), max_points=3)
    assert br.parameter_values.size == 3 and np.all(np.isnan(br.multipliers))
    assert br.stability.tolist() == ["unknown"] * 3
    assert "stability unknown at 3 of 3 points" in br.message
    import matplotlib.pyplot as plt

    fig = br.plot()
    labels = [line.get_label() for line in fig.axes[0].lines]
    plt.close(fig)
    assert "stability unknown (no multipliers)" in labels
    assert not any(len(line.get_xdata()) for line in fig.axes[0].lines if line.get_label() == "unstable")


def test_branch_with_multipliers_is_stable_where_every_multiplier_is_inside():
    """Flat layer, e = 0.45: stable below the closed-form period-doubling Gamma, unstable above."""
    br = tps.continue_branch(tps.FlatLayer(2.5, 2, e=0.45), "Gamma", (2.3, 2.7))
    hi = tps.FlatLayer.stability_window(0.45, 2)[1]
    inside = br.parameter_values < hi - 1e-6
    outside = br.parameter_values > hi + 1e-6
    assert np.all(br.stability[inside] == "stable") and np.all(br.stability[outside] == "unstable")
    assert np.all(br.stable == (br.stability == "stable"))


# ------------------------------------------------------------------ plots of every periodic result
@pytest.fixture(scope="module")
def e0_kink():
    return tps.solve_kink(Gamma=4.1, e=0.0, lattice=_kink_lattice())


def _periodic_results(kink):
    cycle = tps.solve_lattice_cycle(tps.Lattice.planar(n_nodes=8, length=140.0), Gamma=2.5, M=2, e=0.45)
    return [kink, kink.orbit, cycle, tps.solve_kink(n_harmonics=8)]


def _touch_phases(fig, T=1.0):
    """Per node position: the touch-and-go phases t/T mod 1 drawn in the first panel."""
    ax = fig.axes[0]
    dots = next(c for c in ax.collections if c.get_label() in ("touch-and-go", "impact"))
    xy = np.asarray(dots.get_offsets())
    order = np.lexsort((np.mod(xy[:, 1], 1.0), xy[:, 0]))
    return xy[order, 0], np.mod(xy[order, 1], 1.0)


def test_orbit_and_contact_figures_accept_every_periodic_result(e0_kink):
    import matplotlib.pyplot as plt
    from tps_solver.plotting import TIME_LABEL, contact_pattern_figure, orbit_period_figure, solution_figures

    for res in _periodic_results(e0_kink):
        for fig in (orbit_period_figure(res, n_times=8, n_snapshots=2), contact_pattern_figure(res, zoom=False),
                    *solution_figures(res, n_times=8).values()):
            labels = [ax.get_ylabel() for ax in fig.axes] + [ax.get_title() for ax in fig.axes]
            assert any("$t/T$" in label for label in labels), (type(res).__name__, labels)   # one time axis: t/T
            assert not any(r"\omega t" in label for label in labels), (type(res).__name__, labels)
            if fig.axes[0].name != "polar" and "profile" not in " ".join(labels):
                assert TIME_LABEL in labels
            plt.close(fig)


def test_contact_pattern_of_the_tps_kink_matches_its_shooting_orbit(e0_kink):
    """Two solvers, one figure: the TPS's touch-and-go phases against the FDA shooting orbit's events."""
    import matplotlib.pyplot as plt
    from tps_solver.plotting import contact_pattern_figure

    a, b = contact_pattern_figure(e0_kink, zoom=False), contact_pattern_figure(e0_kink.orbit, zoom=False)
    (xa, pa), (xb, pb) = _touch_phases(a), _touch_phases(b)
    plt.close(a)
    plt.close(b)
    assert xa.size == xb.size == e0_kink.nodes.size                  # one touch-and-go per node and period
    np.testing.assert_array_equal(xa, xb)
    assert np.max(np.abs((pa - pb + 0.5) % 1.0 - 0.5)) < 1e-8


def test_plots_refuse_what_they_cannot_draw_with_a_reason(e0_kink, tmp_path):
    from tps_solver.plotting import plot_contact_pattern, plot_orbit_period, plot_solution

    with pytest.raises(ValueError, match="periodic result of the package.*FlatLayer"):
        plot_orbit_period(tps.FlatLayer(2.5, e=0.45), tmp_path / "x.png")

    def stop(state):
        if state.stage == "shooting":
            raise KeyboardInterrupt

    cut = tps.solve_kink(Gamma=4.1, e=0.0, lattice=_kink_lattice(), callback=stop)
    assert cut.status == 5
    for plot in (plot_orbit_period, plot_contact_pattern):
        with pytest.raises(ValueError, match="holds no fields to draw.*status 5"):
            plot(cut, tmp_path / "x.png")
    with pytest.raises(ValueError, match="holds no fields to draw"):
        plot_solution(cut, str(tmp_path))


# ------------------------------------------------------------------ the CLI reaches the e = 0 results
def test_cli_e0_kink_runs_on_a_lattice(capsys, e0_kink):
    from tps_solver.cli import main

    assert main(["kink", "--gamma", "4.1", "--e", "0", "--dx", "8"]) == 0
    out = capsys.readouterr().out
    assert "kink (e = 0): Gamma = 4.1" in out and "lattice of 6 nodes, spacing 8" in out
    assert "converged?            True (status 0)" in out and "all checks            True" in out
    assert f"{abs(e0_kink.multipliers[0]):.6f}" in out                  # the library call it stands for


def test_cli_e0_oscillon_runs_and_says_when_none_exists(capsys):
    from tps_solver.cli import main

    assert main(["oscillon", "--gamma", "4.1", "--e", "0", "--dx", "2", "--r-max", "20", "--r-core", "5"]) == 1
    out = capsys.readouterr().out
    assert "converged?            False (status 9)" in out and "no oscillon found" in out


def test_cli_e0_refuses_single_contact_options_by_flag(capsys):
    from tps_solver.cli import main

    assert main(["kink", "--gamma", "4.1", "--e", "0", "--nodes", "5"]) == 2
    assert "--nodes applies to the single-contact TPS" in capsys.readouterr().err
    assert main(["kink", "--e", "0.45", "--dx", "2"]) == 2
    assert "--dx applies to --e 0 only" in capsys.readouterr().err


def test_cli_lattice_kink_prints_settling_as_a_fraction_not_as_newton(capsys):
    from tps_solver.cli import main

    assert main(["lattice-kink", "--dx", "8", "--periods", "2", "--multipliers", "1"]) == 0
    out = capsys.readouterr().out
    assert "settling: 100 % of 2 periods" in out
    assert "= nan" not in out
    newton = [ln for ln in out.splitlines() if ln.strip().startswith("Newton")]
    assert newton and all("nan" not in ln for ln in newton)


def test_progress_bar_moves_and_names_its_stage():
    """States without a fraction (Newton steps) advance a step count; each stage is named."""
    pytest.importorskip("tqdm")
    from tps_solver.core.progress import Progress, progress_state

    with Progress("kink TPS") as bar:
        for k in range(3):
            bar(progress_state("coupling continuation", k, residual=10.0 ** -k))
        assert bar.bar.n == 3 and bar.bar.total is None and "[coupling continuation]" in bar.bar.desc
        bar(progress_state("settle", 0, fraction=0.25))
        assert bar.bar.n == 25 and bar.bar.total == 100 and "[settle]" in bar.bar.desc


# ------------------------------------------------------------------ check_stability agrees with the multipliers
def test_check_stability_of_a_shooting_kink_measures_its_leading_multiplier(e0_kink):
    """|mu_1| = 0.031 (dense period-map Jacobian) against the decay of a time-stepped perturbation."""
    orbit = e0_kink.orbit
    mu1 = abs(orbit.multipliers[0])
    assert mu1 == pytest.approx(0.0313, abs=1e-3)
    chk = tps.check_stability(orbit)                          # default 20 periods: decays to round-off in ~5
    assert np.isfinite(chk.growth_factor)
    assert chk.growth_factor == pytest.approx(mu1, rel=0.05)
    assert chk.stable and chk.verdict == "stable" and "agrees with the orbit's multipliers" in chk.message


def test_check_stability_accepts_a_stick_solution(e0_kink):
    chk = tps.check_stability(e0_kink, periods=8)
    assert chk.lattice is e0_kink.lattice                    # checked on its own lattice: no mismatch
    assert chk.defects[-1].max() <= 1e-10                     # the TPS orbit is an orbit of the FDA
    assert chk.growth_factor == pytest.approx(abs(e0_kink.multipliers[0]), rel=0.05)
    assert chk.verdict == "stable"
    np.testing.assert_array_equal(chk.orbit_multipliers, e0_kink.multipliers)


def test_check_stability_refuses_a_verdict_against_the_multipliers(e0_kink):
    """An orbit whose multipliers say unstable while the measured perturbation decays: "unknown", and why."""
    orbit = tps.solvers.shooting.periodic.ShootingOrbit(e0_kink.orbit)
    orbit.multipliers = np.array([1.5, 0.1], dtype=complex)
    chk = tps.check_stability(orbit, periods=6)
    assert chk.growth_factor < 0.1 and chk.verdict == "unknown" and not chk.stable
    assert "disagree" in chk.verdict_reason and "1.5" in chk.verdict_reason


def test_check_stability_of_the_continuum_kink_says_why_it_cannot_decide():
    """The continuum TPS kink is not an orbit of the FDA lattice: its defect decays, it is no instability."""
    sol = tps.solve_kink()
    chk = tps.check_stability(sol, periods=5)
    assert chk.growth_factor < 1.0                           # a perturbation decays ...
    assert chk.defects[-1].max() < 0.1 * chk.defects[0].max()   # ... and the run settles
    assert chk.verdict == "unknown" and "not stable" not in chk.message
    assert "not a periodic orbit of this lattice" in chk.verdict_reason


# ------------------------------------------------------------------ defaults that work for every e
def test_cli_without_flags_computes_the_library_defaults(capsys):
    from tps_solver.cli import main

    sol = tps.solve_kink()
    assert main(["kink"]) == 0
    out = capsys.readouterr().out
    assert f"Gamma = {sol.Gamma:g}," in out and f"nodes = {sol.nodes.size}," in out
    assert f"residual max|F|       {sol.residual:.3e}" in out


def test_solve_kink_at_e0_uses_a_Gamma_where_e0_kinks_exist():
    """No Gamma given: 4.1 for e = 0 (2.5 has no sticking f/2 orbit: the closed form's window)."""
    from tps_solver.core import defaults

    with pytest.raises(ValueError, match="3.857 <= Gamma <= 6.362"):
        tps.solve_kink(Gamma=defaults.GAMMA, e=0.0, lattice=_kink_lattice())
    sol = tps.solve_kink(e=0.0, lattice=_kink_lattice())
    assert sol.Gamma == defaults.GAMMA_STICK == 4.1 and sol.converged and sol.checks.all_pass
    assert tps.solve_kink(e=0.45).Gamma == defaults.GAMMA == 2.5


def test_the_result_types_a_user_meets_are_exported():
    from tps_solver.core.problem import Problem as P
    from tps_solver.solvers.shooting.periodic import ShootingOrbit
    from tps_solver.solvers.tps.stick import StickSolution

    assert tps.ShootingOrbit is ShootingOrbit and tps.StickSolution is StickSolution and tps.Problem is P
    assert {"ShootingOrbit", "StickSolution", "Problem"} <= set(tps.__all__)


def test_sweep_map_says_it_counts_any_period_2_attractor(monkeypatch, tmp_path, capsys):
    """Gamma 2.8, e 0.15: (19) has no single-bounce f/2 orbit, yet every start reaches a period-2 attractor."""
    from matplotlib.figure import Figure
    from tps_solver.cli import main

    with pytest.raises(ValueError, match="Gamma is too small for a period-2 orbit"):
        tps.FlatLayer(2.8, 2, e=0.15, pattern="bounce")
    saved = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, path, **kw: saved.append(fig))
    assert main(["sweep", "basins", "--gamma", "2.8", "2.8", "0.1", "--e", "0.15", "0.15", "0.1", "--samples", "4",
                 "--serial", "--plot", str(tmp_path / "map.png")]) == 0
    out = capsys.readouterr().out
    assert "period-2 (f/2) attractor of any contact pattern" in out and "1.000" in out
    title = saved[0].axes[0].get_title()
    assert "any f/2 (period-2) attractor" in title and "not only the flat single-bounce orbit" in title
    assert "basin of the flat" not in title


def test_e0_kink_by_anticontinuum_interrupted_before_its_tps_returns_status_5():
    def stop(state):
        if state.stage == "tps":
            raise KeyboardInterrupt

    sol = tps.solve_kink(Gamma=4.1, e=0.0, lattice=_kink_lattice(), start="anticontinuum", callback=stop)
    assert sol.status == 5 and sol.interrupted_stage == "tps" and sol.orbit is None and not sol.converged


def test_cli_branch_without_multipliers_says_unknown_not_unstable(capsys):
    from tps_solver.cli import main

    code = main(["branch", "cycle", "--nodes", "4", "--length", "60", "--parameter", "Gamma", "--bounds", "2.45",
                 "2.55", "--no-multipliers", "--one-side"])
    out = capsys.readouterr().out
    points = [ln for ln in out.splitlines() if ln.strip().startswith("point")]
    assert code == 0 and points
    assert all(ln.endswith("stability unknown (no multipliers)") for ln in points)
    assert "stability unknown at" in out


def test_lattice_kink_states_its_far_field():
    orb = tps.lattice_kink(_kink_lattice(), Gamma=4.1, e=0.0, periods=2, multipliers=False)
    flat = tps.FlatLayer(4.1, 2, e=0.0)                      # the sticking f/2 orbit: multipliers 0
    assert orb.converged and orb.far_field_stable is True
    np.testing.assert_array_equal(orb.far_field_multipliers, flat.floquet_multipliers())
