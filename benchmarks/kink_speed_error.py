"""Speed against error of the e = 0 kink solvers: residual against seconds, mirrored map vs period map.

``tps.lattice_kink(lattice, Gamma=4.1, e=0.0)`` on planar Neumann lattices of length 40 (odd n: the
kink centred on a node), one BLAS thread, in one process:

* ``mirrored``: ``symmetric=True`` -- Newton on the mirrored half-period map G, then the period map;
* ``period map``: ``symmetric=False`` -- Newton--Krylov on the period map from the same settled state.

For each Newton step the wall time since the call started and the residual (max|G(x) - x| or
max|P(x) - x|) are recorded; the table gives the time to reach 1e-4, 1e-8 and 1e-11 and the total,
with the final |mu1| and width of each (the period map's kink may sit a node away; its width then
differs only by the lattice's ends).  The settling (10 periods) is in both totals.

Run (from the repository root)::

    PYTHONPATH=. python benchmarks/kink_speed_error.py [--dx 1 0.5] [--write]

``--write`` writes ``validation/sections/kink_speed.md`` (and the curves as
``validation/figures/kink_speed.png``).
"""
import argparse
import os
import time

import numpy as np
from threadpoolctl import threadpool_limits

import tps_solver as tps

LEVELS = (1e-4, 1e-8, 1e-11)


def curve(dx, symmetric, Gamma=4.1, length=40.0):
    """(seconds, residual) per Newton step and the result of one lattice_kink call."""
    n = int(round(length / dx)) + 1
    lat = tps.Lattice.planar(n_nodes=n, length=length)
    pts = []
    tic = time.perf_counter()

    def cb(state):
        if state.stage == "shooting" and np.isfinite(state.residual):
            pts.append((time.perf_counter() - tic, float(state.residual), bool(state.get("symmetric", False))))

    orb = tps.lattice_kink(lat, Gamma=Gamma, e=0.0, symmetric=symmetric, callback=cb)
    return np.array(pts, dtype=float).reshape(-1, 3), orb, time.perf_counter() - tic


def table(dxs):
    rows, curves = [], {}
    for dx in dxs:
        for name, sym in (("mirrored", True), ("period map", False)):
            pts, orb, total = curve(dx, sym)
            curves[(dx, name)] = pts
            row = dict(dx=dx, solver=name, steps=int(len(pts)), total_s=total, converged=bool(orb.converged),
                       residual=float(orb.residual), mu1=float(abs(orb.multipliers[0])) if orb.converged else None,
                       width=float(tps.front_width(orb, instant="lower_far_field_top")[0]) if orb.converged else None)
            for lev in LEVELS:
                hit = pts[pts[:, 1] <= lev] if pts.size else pts
                row[f"t({lev:g})"] = float(hit[0, 0]) if len(hit) else None
            rows.append(row)
    return rows, curves


def plot(curves, path):
    import matplotlib
    from matplotlib.figure import Figure

    del matplotlib
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot(1, 1, 1)
    for (dx, name), pts in curves.items():
        if len(pts):
            ax.semilogy(pts[:, 0], pts[:, 1], "o-" if name == "mirrored" else "s--", ms=3,
                        label=f"{name}, dx = {dx:g}")
    ax.set_xlabel("seconds (settling included)")
    ax.set_ylabel("Newton residual")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dx", type=float, nargs="+", default=[1.0, 0.5])
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    with threadpool_limits(1):
        rows, curves = table(args.dx)
    from validation.report import FIGURES_DIR, markdown_table, write_section

    cols = [("dx", "dx"), ("solver", "solver"), ("Newton steps", "steps")] + \
        [(f"s to {lev:g}", f"t({lev:g})") for lev in LEVELS] + \
        [("total s", "total_s"), ("converged", "converged"), ("residual", "residual"), ("mu1", "mu1"),
         ("width", "width")]
    text = ("## Speed against error: the e = 0 kink by shooting\n\n"
            "`tps.lattice_kink(lattice, Gamma=4.1, e=0.0)`, planar Neumann lattice of length 40 (odd n), one BLAS "
            "thread, both solvers in one run (`PYTHONPATH=. python benchmarks/kink_speed_error.py --write`): "
            "`mirrored` = Newton on the mirrored half-period map G (`symmetric=True`), then the period map; "
            "`period map` = Newton-Krylov on the period map (`symmetric=False`). Seconds since the call started "
            "(10 settling periods included) until the Newton residual first falls below each level. The "
            "period map's kink may sit a node away from the centre (its width then differs by the lattice's "
            "ends only). Figure: `validation/figures/kink_speed.png`.\n\n" + markdown_table(rows, cols) + "\n")
    print(text)
    if args.write:
        os.makedirs(FIGURES_DIR, exist_ok=True)
        plot(curves, os.path.join(FIGURES_DIR, "kink_speed.png"))
        print("wrote", write_section("kink_speed", text))


if __name__ == "__main__":
    main()
