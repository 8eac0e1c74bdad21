"""The ``tps-solver simulate`` subcommand."""
import pytest

from tps_solver.cli import main


def test_simulate_flat_reports_progress_and_plots(tmp_path, capsys):
    png = tmp_path / "flat.png"
    assert main(["simulate", "flat", "--periods", "2", "--nodes", "5", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "period    2/2" in out and "events      5 (impact 5, stick 0, liftoff 0)" in out
    assert "cut-off lattice spacing = 2" in out
    assert png.stat().st_size > 0


def test_simulate_kink_runs_a_period(capsys):
    assert main(["simulate", "kink", "--periods", "1", "--nodes", "11", "--length", "10"]) == 0
    assert "stuck nodes" in capsys.readouterr().out


@pytest.mark.parametrize("argv, name", [
    (["simulate", "flat", "--nodes", "2"], "n_nodes"),
    (["simulate", "oscillon", "--periods", "0"], "periods"),
    (["simulate", "kink", "--e", "1.5"], "e"),
])
def test_simulate_bad_input_exits_2(argv, name, capsys):
    assert main(argv) == 2
    assert name in capsys.readouterr().err
