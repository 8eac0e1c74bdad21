"""The validation suite: its functions in a fast configuration, asserted on their numbers.

Tolerances are those of the underlying issues: the TPS reproduces the flat
layer to <= 1e-10 in tc and <= 1e-12 in the harmonics ; the FDA
flat lattice reproduces (17)-(19) to <= 1e-10 (exact) / <= 1e-8 (ode) with
contact times to <= 1e-12 (exact), and its uniform-mode multipliers equal
``FlatLayer.floquet_multipliers`` to <= 1e-7 (FDA issue).  No wall-clock
assertions: times are measured, never asserted.
"""
import os
import subprocess
import sys

import numpy as np
import pytest

from validation import figures, flat_layer, report, run_all, speed_vs_error

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TC_TOL, HARMONIC_TOL, MU_TOL = 1e-10, 1e-12, 1e-7
FDA_TOL = {"FDA exact": 1e-10, "FDA ode": 1e-8}


@pytest.fixture(scope="module")
def flat_result():
    return flat_layer.flat_comparison(flat_layer.FAST)


@pytest.fixture(scope="module")
def speed_result():
    return speed_vs_error.speed_vs_error(speed_vs_error.FAST)


# --------------------------------------------------------------- helpers
@pytest.mark.parametrize("ref, mes, expected", [
    ([1 + 1j, 1 - 1j], [1 - 1j, 1 + 1j], 0.0),                     # order does not matter
    ([0.5, 0.2], [0.2, 0.5 + 1e-3], 1e-3),
    ([0.5, 0.2], [0.5, 0.5], 0.3),                                # no double use of one multiplier
    ([0.5], [0.1, 0.49, 2.0], 0.01),                              # nearest among more
    ([0.5, 0.2], [], np.inf),
])
def test_multiplier_error(ref, mes, expected):
    assert flat_layer.multiplier_error(ref, mes) == pytest.approx(expected, abs=1e-15)


def test_periodic_distance():
    T = 4 * np.pi
    d = flat_layer.periodic_distance([0.1, T - 0.1, 2 * T + 0.3, T / 2], 0.0, T)
    np.testing.assert_allclose(d, [0.1, 0.1, 0.3, T / 2], atol=4 * np.finfo(float).eps * T)


def test_cases_are_in_the_window_and_admissible():
    grid, skipped = flat_layer.cases(es=(0.45, 0.7), Ms=(1, 2), fractions=(0.25, 0.75))
    assert grid
    for fl in grid:
        low, high = fl.stability_window(fl.e, fl.M)
        assert low < fl.Gamma < high
        assert fl.is_stable == (fl.branch == "stable")
    for s in skipped:
        assert "Gamma" in s and s["reason"]


# --------------------------------------------------------- flat layer
def test_flat_tps_reproduces_flat_layer(flat_result):
    tps = [r for r in flat_result["rows"] if r["solver"].startswith("TPS")]
    assert {r["solver"] for r in tps} == {"TPS oscillon", "TPS kink (even)"}
    for r in tps:
        assert r["converged"], r["message"]
        returned = r["start"] == "t0" or r["branch"] == "stable" or r["tc_err"] <= flat_layer.RETURN_THRESHOLD
        if returned:
            assert r["tc_err"] <= TC_TOL, r
            assert r["w_hat_err"] <= HARMONIC_TOL, r
            assert r["zeta_hat_err"] <= HARMONIC_TOL, r
            assert r["checks"]


def test_flat_fda_reproduces_flat_layer(flat_result):
    if not flat_result["fda"]:
        pytest.skip("tps_solver.solvers.fda does not exist yet")
    fda = [r for r in flat_result["rows"] if r["solver"].startswith("FDA")]
    assert {r["solver"] for r in fda} == {"FDA exact", "FDA ode"}
    for r in fda:
        assert r["converged"], r["message"]
        assert r["n_impacts"] == r["expected_impacts"]
        # the finite-difference multipliers of the FDA period map (central differences, step 1e-5)
        assert r["mu_fd_err"] <= MU_TOL, r
        if flat_result["stability"]:
            assert r["mu_err"] <= MU_TOL, r
        if r["branch"] == "stable":     # on the unstable branch round-off grows by the multiplier > 1
            assert max(r["W_err"], r["zeta_err"]) <= FDA_TOL[r["solver"]], r
            if r["solver"] == "FDA exact":
                assert r["tc_err"] <= 1e-12, r


def test_flat_render_contains_every_row(flat_result):
    text = flat_layer.render(flat_result)
    assert text.startswith("## Flat layer")
    assert text.count("\n| ") >= len(flat_result["rows"]) + len(flat_result["cases"])
    assert "python -m validation.flat_layer" in text


# --------------------------------------------------------- speed vs error
def test_speed_vs_error_numbers(speed_result, tmp_path):
    fl = speed_result["flat"]
    for r in speed_result["rows"]:
        assert r["time"] > 0 and r["repeats"] >= 1
        if r["method"] == "TPS" and r["problem"] == "flat layer":
            assert r["converged"] and r["error"] <= 1e-10, r
        if r["method"] == "FDA exact" and r["problem"].startswith("flat"):
            assert r["error"] <= 1e-10, r
        if r["method"] == "FDA ode" and r["problem"].startswith("flat"):
            assert r["error"] <= 1e3 * r["tol"], r
    coarse = [r for r in speed_result["rows"] if r["problem"].startswith("coarse oscillon")]
    assert [r["N"] for r in coarse] == list(speed_vs_error.FAST["coarse_Ns"])
    for r in coarse:
        assert r["converged"] and r["non_flat"], r
    assert coarse[-1]["checks"]         # physical checks of the reference (largest N)
    # refinement in N against the largest N: the error falls by more than 4x per doubling
    assert coarse[1]["error"] < coarse[0]["error"] / 4
    assert coarse[1]["tc_error"] < coarse[0]["tc_error"] / 4
    if speed_result["fda"]:
        for b in speed_result["brute"]:
            if b["periods"] is not None:
                assert b["error"] <= b["target"]
                # the step before did not yet reach the target: the first passage is reported
                assert b["periods"] == 1 or b["history"][b["periods"] - 2] > b["target"]
                # the distance to the cycle decays no faster than the flat orbit's multipliers allow
                # (the uniform part of the perturbation contracts by |mu| per period)
                mu = float(np.max(np.abs(fl.floquet_multipliers())))
                h = b["history"][: b["periods"]]
                assert h[-1] >= 0.1 * h[0] * mu ** (len(h) - 1)
        for s in speed_result["speedup"]:
            assert s["speedup"] is None or s["speedup"] > 0
        cycle = speed_result["cycle"]
        if cycle:
            c = cycle[0]
            assert c["converged"] and c["non_flat"], c
            assert c["error"] <= 1e-12, c          # FDA periodicity defect of the exact lattice cycle
            for b in cycle[1:]:
                assert b["periods"] is not None and b["error"] <= b["target"], b
                assert b["periods"] == 1 or b["history"][b["periods"] - 2] > b["target"]
                assert np.all(b["history"][b["periods"] - 1:] <= b["target"])
    path = speed_vs_error.plot(speed_result, str(tmp_path / "pareto.png"))
    assert os.path.getsize(path) > 1000
    text = speed_vs_error.render(speed_result)
    assert "## Speed against error" in text


# ----------------------------------------------------------------- figures
def test_figures_listed_or_made(tmp_path):
    entries = figures.make_figures(figures.FAST, directory=str(tmp_path))
    assert [e["figure"] for e in entries] == ["Fig. 2", "Fig. 3", "Fig. 4", "Fig. 5", "Fig. 7", "Fig. 8"]
    for e in entries:
        if e["made"]:
            assert e["paths"] and all(os.path.getsize(p) > 1000 for p in e["paths"])
        else:
            assert not e["paths"] and e["reason"]
        if e["figure"] in ("Fig. 3", "Fig. 4", "Fig. 5"):
            # TPS figures exist exactly when the TPS oscillon converged
            assert e["made"] == ("converged True" in e["solver"])
    assert "| Fig. 8 |" in figures.render(entries)


def test_oscillon_state_joins_the_two_phases():
    from tps_solver.model.flat import FlatLayer
    from tps_solver.operators.lattice import Lattice

    fl = FlatLayer(2.5, 2, e=0.45)
    lat = Lattice.axisymmetric(n_nodes=30, r_max=6.0, grid="uniform")
    t = fl.t0 + 1.0
    w, z = figures.oscillon_state(lat, fl, t, r_core=1.0, width=0.5)
    core, far = lat.nodes < 0.75, lat.nodes > 1.25
    np.testing.assert_array_equal(z[core], fl.height(t + fl.period / 2))
    np.testing.assert_array_equal(w[far], fl.velocity(t))


# ------------------------------------------------------------------ report
def test_build_report_contains_every_section(tmp_path):
    sections = tmp_path / "sections"
    texts = {
        "speed": "## Speed\n\nmarker-speed 1.234e-05\n",
        "flat": "## Flat\n\nmarker-flat | 3 |\n",
        "zzz_extra": "## Extra\n\nmarker-extra\n",
        "aaa_extra": "## Another\n\nmarker-aaa\n",
        "kink": "## Kinks\n\nmarker-kink\n",
    }
    for stem, text in texts.items():
        report.write_section(stem, text, str(sections))
    out = report.build_report(str(tmp_path / "REPORT.md"), sections_dir=str(sections))
    with open(out, encoding="utf-8") as fh:
        body = fh.read()
    for text in texts.values():
        assert text.rstrip() in body
    pos = [body.index(f"marker-{m}") for m in ("flat", "kink", "speed", "aaa", "extra")]
    assert pos == sorted(pos)                              # fixed order, unknown ones alphabetically last
    assert "Oscillons: *not yet measured*" in body        # a missing known section is listed
    info = report.machine_info()
    for key in ("platform", "numpy", "scipy", "python"):
        assert info[key] in body
    assert f"{info['cpu_count']} CPUs" in body


def test_markdown_table():
    text = report.markdown_table([{"a": 1, "b": 2.5e-12, "c": None, "d": True}, {"a": 2, "b": 0.5}],
                                 [("A", "a"), ("B", "b"), ("C", "c"), ("D", lambda r: r.get("d", False))])
    assert text.splitlines() == ["| A | B | C | D |", "|---|---|---|---|",
                                 "| 1 | 2.50e-12 | — | yes |", "| 2 | 0.5 | — | no |"]


# --------------------------------------------------------- run_all / CLI
def test_run_modules_skips_missing_and_reports_failures(capsys):
    log = run_all.run_modules(["no_such_validation_module"])
    assert log[0]["status"] == "missing"
    lines = run_all.log_lines(log)
    assert any("does not exist" in line for line in lines)
    with pytest.raises(SystemExit):
        run_all.main(["--only", "no_such_validation_module"])


def test_validate_finds_the_source_tree():
    from tps_solver._commands import validate

    assert os.path.samefile(validate.find_root(), ROOT)


def test_demo_exits_zero():
    proc = subprocess.run([sys.executable, "-m", "tps_solver.cli", "demo"], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    for item in ("flat layer (17)-(19)", "TPS reproduces flat layer", "oscillon TPS (N=30, 8 nodes, r_max 140)",
                 "kink TPS", "oscillon TPS, fine grid", "FDA check of flat layer"):
        assert item in out
    flat_line = next(line for line in out.splitlines() if line.startswith("TPS reproduces flat layer"))
    assert " ok " in flat_line


# ------------------------------------------------------------------- slow
@pytest.mark.slow
def test_full_flat_comparison():
    res = flat_layer.flat_comparison(flat_layer.FULL)
    for r in res["rows"]:
        if r["solver"].startswith("TPS") and (r["start"] == "t0" or r["tc_err"] <= flat_layer.RETURN_THRESHOLD):
            assert r["converged"] and r["tc_err"] <= TC_TOL and r["w_hat_err"] <= HARMONIC_TOL, r
        if r["solver"].startswith("FDA"):
            assert r["mu_fd_err"] <= MU_TOL, r
            if res["stability"]:
                assert r["mu_err"] <= MU_TOL, r
            if r["branch"] == "stable":
                assert max(r["W_err"], r["zeta_err"]) <= FDA_TOL[r["solver"]], r


def test_run_modules_survives_a_failing_main(tmp_path, monkeypatch):
    pkg = tmp_path / "validation_fake"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "boom.py").write_text("def main():\n    raise RuntimeError('measured failure')\n")
    (pkg / "quits.py").write_text("import sys\n\ndef main():\n    sys.exit(3)\n")
    (pkg / "fine.py").write_text("def main():\n    print('fine ran')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(run_all, "optional_import",
                        lambda name: report.optional_import(name.replace("validation.", "validation_fake.")))
    log = run_all.run_modules(["boom", "quits", "fine", "absent"])
    assert [e["status"] for e in log] == ["failed", "failed", "ok", "missing"]
    assert "measured failure" in log[0]["error"] and "3" in log[1]["error"]
