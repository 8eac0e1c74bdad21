"""``tps-solver flat``: subprocess runs, parsed numbers compared with FlatLayer."""
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from tps_solver.cli import main
from tps_solver.model.flat import FlatLayer

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NUMBER = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"


def _run(*args):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "tps_solver.cli", "flat", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


def _field(text, label):
    m = re.search(rf"{re.escape(label)}\s*=\s*(.+)", text)
    assert m, f"{label!r} not in output:\n{text}"
    return m.group(1).strip()


def _multipliers(text):
    pairs = re.findall(rf"({NUMBER})({NUMBER})j", _field(text, "Floquet multipliers"))
    return np.array([complex(float(a), float(b)) for a, b in pairs])


def test_subprocess_prints_orbit_and_multipliers():
    proc = _run("--gamma", "2.5", "--e", "0.45", "--M", "2")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    out = proc.stdout
    fl = FlatLayer(2.5, 2, e=0.45)
    mu = _multipliers(out)
    assert mu.shape == (2,)
    np.testing.assert_allclose(mu, fl.floquet_multipliers(), rtol=0, atol=2e-10)
    np.testing.assert_allclose(np.abs(mu), 0.45, rtol=1e-9)          # independent: |mu|^2 = e^2
    assert float(_field(out, "launch phase t0")) == pytest.approx(fl.t0, abs=1e-11)
    assert float(_field(out, "post-impact W0")) == pytest.approx(fl.W0, abs=1e-11)
    assert float(_field(out, "peak height")) == pytest.approx(fl.peak_height, abs=1e-11)
    assert _field(out, "stable?") == "True"


def test_plot_writes_png(tmp_path, capsys):
    png = tmp_path / "flat.png"
    assert main(["flat", "--gamma", "2.5", "--e", "0.45", "--M", "2", "--plot", str(png)]) == 0
    assert str(png) in capsys.readouterr().out
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


def test_subprocess_bad_gamma_exits_2():
    proc = _run("--gamma", "-1", "--e", "0.45", "--M", "2")
    assert proc.returncode == 2
    assert "Gamma" in proc.stderr and proc.stdout == ""


@pytest.mark.parametrize("argv, name", [
    (["--gamma", "nan", "--e", "0.45"], "Gamma"),
    (["--gamma", "inf", "--e", "0.45"], "Gamma"),
    (["--gamma", "2.5", "--e", "1.0"], "e"),
    (["--gamma", "2.5", "--M", "0"], "M"),
    (["--gamma", "1.0", "--e", "0.45"], "Gamma"),
    (["--gamma", "2.5", "--e", "0.45", "--t0", "0.0"], "e and t0"),
    (["--gamma", "10", "--t0", "0.0", "--M", "1"], "t0"),
])
def test_bad_values_exit_2_in_process(capsys, argv, name):
    assert main(["flat", *argv]) == 2
    err = capsys.readouterr().err
    assert f"error: {name}" in err


def test_paper_preset_in_process_reports_fold(capsys):
    assert main(["flat", "--gamma", "2.5", "--t0", "0", "--M", "2"]) == 0
    out = capsys.readouterr().out
    mu = _multipliers(out)
    assert mu[0] == pytest.approx(1.0, abs=1e-9)
    assert "bifurcation" in out
    assert float(re.search(rf"e = ({NUMBER})", out).group(1)) == pytest.approx(0.43073044, abs=1e-8)


def test_unstable_branch_in_process(capsys):
    assert main(["flat", "--gamma", "2.5", "--e", "0.45", "--M", "2", "--branch", "unstable"]) == 0
    out = capsys.readouterr().out
    np.testing.assert_allclose(_multipliers(out),
                               FlatLayer(2.5, 2, e=0.45, branch="unstable").floquet_multipliers(), atol=2e-10)
    assert _field(out, "stable?") == "False"
