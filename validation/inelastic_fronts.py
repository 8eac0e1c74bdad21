"""The contact structure of the e = 0 kink's fronts as the lattice is refined (why no continuum TPS yet).

On a lattice every node of an e = 0 kink has two contacts per period.  Far from the front
these are the flat layer's touch-and-go and its landing to stick.  This study classifies
every contact of the converged shooting orbit (``tps.lattice_kink``):

* a **touch** lasts less than ``tol`` (the node leaves at once);
* a **stick** lasts longer and ends in a lift-off that is either **triggered** (within
  ``tol`` of a lattice neighbour's landing: the neighbour's velocity jump makes the
  reaction tensile) or **smooth** (the reaction falls to zero on its own,
  sin t = 1/Gamma in a uniform region).

Where neighbours land one after the other along a tilted front t_land(x), a node whose
lift-off is triggered by its neighbour's landing stays on the plate for
|dt_land/dx| * dx: on the continuum such contacts become a moving front along which a
point lands and leaves, and the velocity jump of each point is smeared by viscosity
(docs/design.md, hazard 3).  :func:`chain_statistics` measures how many contacts are
chains of that kind and how their durations scale with dx.

Run: ``python -m validation.inelastic_fronts [dx ...]`` (default 2 1 0.5; the dx = 0.5
kink takes about 10 minutes on the shared machine).
"""
import sys
import time

import numpy as np

import tps_solver as tps
from tps_solver.analyses.fronts import chain_statistics as chain_stats

TOL = 1e-9


def chain_statistics(t, node, kind, t_start, period, n_nodes, tol=TOL):
    """Classify the contacts of one period of a lattice orbit (:func:`tps_solver.analyses.fronts.chain_statistics`)."""
    return chain_stats(t, node, kind, t_start, period, n_nodes, tol)


def front_chains(dxs=(2.0, 1.0, 0.5), Gamma=4.1, length=40.0, periods=10, max_iter=80):
    """The e = 0 kink per spacing and the statistics of its contacts.  Returns rows of dicts."""
    rows = []
    for dx in dxs:
        n = int(round(length / dx)) + 1
        lat = tps.Lattice.planar(n_nodes=n, length=length)
        tic = time.perf_counter()
        orb = tps.lattice_kink(lat, Gamma=Gamma, e=0.0, periods=periods, max_iter=max_iter, multipliers=False)
        sec = time.perf_counter() - tic
        row = dict(dx=dx, n_nodes=n, converged=orb.converged, residual=orb.residual, seconds=sec)
        if orb.converged:
            ev = orb.events
            st = chain_statistics(ev.t, ev.node, ev.kind, orb.t_start, orb.period, n)
            d = st["chain_durations"]
            row.update(touch=st["touch"], stick_smooth=st["stick_smooth"], stick_triggered=st["stick_triggered"],
                       chain_max=float(d.max()) if d.size else 0.0,
                       chain_max_over_dx=float(d.max() / dx) if d.size else 0.0,
                       front_width=tps.front_width(orb)[0])
        rows.append(row)
    return rows


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    dxs = tuple(float(a) for a in argv) or (2.0, 1.0, 0.5)
    rows = front_chains(dxs)
    keys = ["dx", "n_nodes", "converged", "residual", "touch", "stick_smooth", "stick_triggered", "chain_max",
            "chain_max_over_dx", "front_width", "seconds"]
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(_fmt(r.get(k, "")) for k in keys) + " |")
    return rows


if __name__ == "__main__":
    main()
