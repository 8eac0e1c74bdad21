"""The ``tps-solver`` command line: methods, zero values, help, flag names in errors, version,
``python -m tps_solver``, and output paths (one-line errors before the run, one extension rule)."""
import argparse
import os
import subprocess
import sys

import numpy as np
import pytest

from tps_solver.solvers.tps import load
from tps_solver.cli import build_parser, main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _err_line(capsys):
    out = capsys.readouterr()
    lines = [ln for ln in out.err.splitlines() if ln.strip()]
    assert len(lines) == 1, out.err          # one line, no traceback
    assert "Traceback" not in out.err
    return out.out, lines[0]


# ----------------------------------------------------------------------------- simulate --method soft


def test_simulate_soft_contact_with_cutoff_runs(capsys):
    # was: "invalid choice: 'soft'"
    assert main(["simulate", "kink", "--method", "soft", "--cutoff", "1", "--periods", "1", "--nodes", "3",
                 "--length", "6"]) == 0
    out = capsys.readouterr().out
    assert "method soft" in out and "cut-off soft contact = 1" in out


def _method_choices():
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return next(a for a in sub.choices["simulate"]._actions if a.dest == "method").choices


@pytest.mark.parametrize("method", sorted(_method_choices()))
def test_every_simulate_method_follows_the_flat_layer(method, capsys):
    """Each method the command offers runs the flat case; its printed state is the closed form's."""
    import re

    from tps_solver import FlatLayer

    soft = method.startswith("soft")
    argv = ["simulate", "flat", "--method", method, "--periods", "2", "--nodes", "3"]
    assert main(argv + (["--cutoff", "0.3"] if soft else [])) == 0
    out = capsys.readouterr().out
    rows = re.findall(r"t = +([0-9.]+), events +(\d+) .*min zeta ([0-9.eE+-]+)", out)
    assert len(rows) == 2
    fl = FlatLayer(2.5, 2, e=0.45)
    for t, n_events, zmin in rows:
        # three uniform nodes: one contact each per period ("soft" logs entry and exit)
        assert int(n_events) == (6 if method == "soft" else 3)
        if not soft:      # point impacts: the height is the closed-form flat orbit's (17)
            assert zmin == f"{float(fl.height(float(t))):.3g}"
    assert float(rows[-1][0]) == pytest.approx(fl.t0 + 1.0 + 2 * fl.period, abs=1e-3)


@pytest.mark.parametrize("argv, flag", [
    (["simulate", "kink", "--method", "soft"], "--cutoff is required"),
    (["simulate", "kink", "--cutoff", "0.5"], "--cutoff is only used with --method soft"),
    (["simulate", "kink", "--method", "soft", "--cutoff", "0.5", "--impact", "diffused"], "--impact"),
    (["simulate", "kink", "--method", "soft", "--cutoff", "-1", "--periods", "1", "--nodes", "3"], "--cutoff"),
])
def test_simulate_cutoff_rules(argv, flag, capsys):
    assert main(argv) == 2
    assert flag in _err_line(capsys)[1]


# ----------------------------------------------------------------------------- zero is an error


@pytest.mark.parametrize("argv, flag", [
    (["simulate", "kink", "--nodes", "0"], "--nodes"),      # was: ran silently on 41 nodes
    (["simulate", "flat", "--nodes", "0"], "--nodes"),      # was: 11 nodes
    (["simulate", "kink", "--length", "0"], "--length"),    # was: length 20
    (["simulate", "oscillon", "--length", "0"], "--length"),  # was: r_max 20
    (["kink", "--nodes", "0"], "--nodes"),
    (["oscillon", "--r-max", "0"], "--r-max"),
])
def test_zero_sizes_are_errors_naming_the_flag(argv, flag, capsys):
    assert main(argv) == 2
    out, err = _err_line(capsys)
    assert flag in err and out == ""


# ----------------------------------------------------------------------------- help, flag names, version


def test_every_option_of_every_command_has_help():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = []
    for name, p in sub.choices.items():
        for action in p._actions:
            if action.dest in ("help",):
                continue
            if not action.help or action.help == argparse.SUPPRESS:
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}")
    assert not missing, missing


@pytest.mark.parametrize("argv, flag, param", [
    (["kink", "--length", "-1"], "--length", "length"),
    (["oscillon", "--r-max", "-1"], "--r-max", "r_max"),
    (["oscillon", "--N", "0"], "--N", "n_harmonics"),
    (["simulate", "oscillon", "--length", "-1"], "--length", "r_max"),
    (["flat", "--gamma", "-1", "--e", "0.45"], "--gamma", "Gamma"),
    (["flat", "--gamma", "2.5", "--e", "0.45", "--t0", "0.0"], "--e, --t0", "e and t0"),
])
def test_errors_name_the_flag(argv, flag, param, capsys):
    assert main(argv) == 2
    _, err = _err_line(capsys)
    assert flag in err and param in err and err.startswith(f"tps-solver {argv[0]}: error: ")


def test_version(capsys):
    from tps_solver import __version__

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"tps-solver {__version__}"


def test_python_dash_m_tps_solver():
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "tps_solver", "flat", "--e", "0.45"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "launch phase t0" in proc.stdout


# ----------------------------------------------------------------------------- output paths


@pytest.mark.parametrize("argv", [
    ["flat", "--plot", "{missing}/x.png"],
    ["simulate", "flat", "--nodes", "3", "--periods", "1", "--plot", "{missing}/x.png"],
    ["stability", "--kh", "1", "--plot", "{missing}/x.png"],
    ["kink", "--save", "{missing}/x.npz"],
    ["oscillon", "--plot", "{missing}/figures"],
    ["flat", "--plot", "{tmp}/x.unknownformat"],
])
def test_unwritable_outputs_fail_in_one_line_before_the_run(argv, tmp_path, capsys):
    # (a directory under tmp_path that does not exist, rather than /nonexistent: the tests may run as root)
    argv = [a.format(missing=tmp_path / "nonexistent", tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    assert not (tmp_path / "nonexistent").exists() and os.listdir(tmp_path) == []
    out, err = _err_line(capsys)
    assert out == ""                        # refused before any computation
    flag = "--save" if "--save" in argv else "--plot"
    assert f"error: {flag} " in err


def test_figure_and_result_names_follow_one_rule(tmp_path, capsys):
    stem = tmp_path / "flat_noext"
    assert main(["flat", "--e", "0.45", "--plot", str(stem)]) == 0
    out = capsys.readouterr().out
    assert f"figure written to {stem}.png" in out and (tmp_path / "flat_noext.png").is_file()
    assert not stem.exists()
    save = tmp_path / "noext"
    assert main(["kink", "--e", "0.45", "--N", "8", "--max-iter", "2", "--save", str(save)]) in (0, 1)
    out = capsys.readouterr().out
    assert f"saved to {save}.npz" in out
    sol = load(save)                         # with or without the extension
    np.testing.assert_array_equal(sol.tc, load(f"{save}.npz").tc)
