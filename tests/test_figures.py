"""Every figure the CLI writes: labelled axes with units, a colour bar where colour carries a value,
a title with the parameters; the specific defects of the old figures stay fixed."""
import os

import numpy as np
import pytest
from matplotlib.collections import QuadMesh
from matplotlib.figure import Figure

from tps_solver.cli import main

UNITS = ("viscous lengths", "plate amplitudes", r"A\omega", r"\omega t", r"t\,\omega", "dimensionless",
         r"1/\omega")


@pytest.fixture
def saved_figures(monkeypatch):
    """Run the CLI and collect every Figure it saves (the objects, with their axes).

    Rendering is skipped (the PNG writing itself is tested in test_cli.py and test_cli_flat.py);
    an empty file is created so the command's own checks see the path.
    """
    figures = []

    def record(self, fname, *args, **kwargs):
        figures.append((os.fspath(fname), self))
        open(fname, "wb").close()

    monkeypatch.setattr(Figure, "savefig", record)
    return figures


def _data_axes(fig):
    return [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]


def _colorbars(fig):
    return [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]


def _check_publishable(path, fig):
    title = " ".join([fig._suptitle.get_text() if fig._suptitle else ""] + [ax.get_title() for ax in fig.axes])
    assert "=" in title, f"{path}: the title states no parameters: {title!r}"
    for ax in _data_axes(fig):
        if ax.name == "polar":
            assert ax.get_xlabel(), f"{path}: polar panel without a radial label"
            assert any(t.get_text() for t in ax.get_yticklabels()), f"{path}: polar panel without a radial scale"
            continue
        assert ax.name != "3d", f"{path}: 3-D surface (blocky, no readable scale)"
        xlabel = ax.get_xlabel() or next(
            (a.get_xlabel() for a in ax.get_shared_x_axes().get_siblings(ax) if a.get_xlabel()), "")
        for label in (xlabel, ax.get_ylabel()):
            assert label, f"{path}: an axis has no label"
            assert any(u in label for u in UNITS), f"{path}: axis label {label!r} has no unit"
    colour = any(isinstance(c, QuadMesh) for ax in _data_axes(fig) for c in ax.collections)
    if colour:
        bars = _colorbars(fig)
        assert bars, f"{path}: colour carries a value but there is no colour bar"
        assert all(b.get_ylabel() or b.get_xlabel() for b in bars), f"{path}: colour bar without a label"


def test_every_cli_figure_is_publishable(saved_figures, tmp_path, capsys):
    runs = [
        ["flat", "--e", "0.45", "--plot", str(tmp_path / "flat")],
        ["simulate", "flat", "--periods", "1", "--nodes", "4", "--plot", str(tmp_path / "sim_flat")],
        ["kink", "--e", "0.45", "--N", "8", "--plot", str(tmp_path / "kink")],
        ["oscillon", "--e", "0.45", "--N", "8", "--plot", str(tmp_path / "osc")],
    ]
    for argv in runs:
        assert main(argv) in (0, 1), capsys.readouterr().err
    names = sorted(os.path.basename(p) for p, _ in saved_figures)
    assert names == sorted(["flat.png", "sim_flat.png", "kink_zeta.png",
                            "kink_w_minus_W.png", "kink_snapshots.png", "oscillon_zeta.png",
                            "oscillon_w_minus_W.png", "oscillon_snapshots.png"])
    for path, fig in saved_figures:
        assert os.path.isfile(path)
        _check_publishable(path, fig)


@pytest.mark.slow
def test_the_other_cli_figures_are_publishable(saved_figures, tmp_path, capsys):
    # the growth-rate figure solves (35) at 121 wavenumbers (~5 s); the kink FDA map like sim_flat's
    assert main(["stability", "--kh", "1", "--n-modes", "1", "--plot", str(tmp_path / "sigma")]) == 0
    assert main(["simulate", "kink", "--periods", "1", "--nodes", "5", "--length", "10",
                 "--plot", str(tmp_path / "sim_kink")]) == 0
    assert [os.path.basename(p) for p, _ in saved_figures] == ["sigma.png", "sim_kink.png"]
    for path, fig in saved_figures:
        _check_publishable(path, fig)


def test_stopped_continuation_is_drawn_on_the_requested_domain(saved_figures, tmp_path, capsys):
    # 30 nodes over r_max = 12: the branch ends at a fold and the fields live on stretched nodes
    # (r up to ~1300); the maps are drawn on the grid that was asked for, and the title says so
    main(["oscillon", "--e", "0.45", "--r-max", "12", "--nodes", "30", "--N", "8", "--plot", str(tmp_path)])
    out = capsys.readouterr().out
    assert "converged?            False" in out
    figs = dict((os.path.basename(p), f) for p, f in saved_figures)
    for name in ("oscillon_zeta.png", "oscillon_w_minus_W.png"):
        ax = _data_axes(figs[name])[0]
        mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
        r = mesh.get_coordinates()[..., 0]
        assert r.max() <= 12.0 + 1e-9 and ax.get_xlim()[1] <= 12.0 + 1e-9
        assert "NOT converged" in ax.get_title() and "coupling" in ax.get_title()
    polar = _data_axes(figs["oscillon_snapshots.png"])
    assert all(ax.get_ylim()[1] <= 12.0 + 1e-9 for ax in polar)


def test_round_off_is_not_coloured_as_physics(saved_figures, tmp_path, capsys):
    assert main(["simulate", "flat", "--periods", "1", "--nodes", "4", "--plot", str(tmp_path / "f")]) == 0
    (_, fig), = saved_figures
    ax = _data_axes(fig)[0]
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    vmin, vmax = mesh.get_clim()
    data = np.asarray(mesh.get_array())
    assert np.max(np.abs(data)) < 1e-12          # the flat layer is reproduced to round-off ...
    assert vmax >= 1e-9 and vmin == -vmax          # ... and not stretched to fill the colour map
    assert any("round-off" in t.get_text() for t in ax.texts)
