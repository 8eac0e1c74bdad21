"""The e = 0 (completely inelastic) kinks on planar Neumann lattices: measured numbers.

At e = 0, M = 2 and Gamma in {3.9, 4.1, 4.4} the flat layer's orbit is lift-off at
sin t = 1/Gamma, flight, a touch-and-go landing, flight, landing to stick.  A kink (left half on
that orbit, right half half a period later) is computed by shooting
(:func:`validation.shooting.e0_kinks`) on Neumann lattices of length 40; the continuum TPS for this
case does not exist, so the lattice sequence dx -> 0 is the continuum estimate.

Functions (each returns rows of measured numbers; ``main()`` prints markdown tables):

* :func:`contact_pattern` -- per node, the sequence of contact kinds in one period
  (``T`` touch-and-go, ``S`` landing to stick, ``L`` lift-off, ``L*`` a lift-off at the instant
  of a neighbour's landing, "triggered"), and its histogram;
* :func:`kink_row` -- one (Gamma, dx) kink: convergence, residual, Newton steps, seconds, the two
  front widths, contact pattern, leading multipliers, 10-period defect;
* :func:`gamma_table` -- the rows saved by ``run`` (one JSON per case under ``SCRATCH``);
* :func:`convergence` -- front width vs dx: successive differences, their log-log slope and a
  Richardson-extrapolated width where the order is clean;
* :func:`oscillon_rates` -- an e = 0 oscillon core (half a period shifted) on an axisymmetric
  lattice, time stepped; the core radius per period and dR/dperiod.

Run one case (saves JSON + pickle): ``python -m validation.inelastic_kinks run GAMMA DX``;
print the tables: ``python -m validation.inelastic_kinks`` (reads the saved cases).  Timings are
wall-clock on the shared 2-core machine, single-threaded BLAS (threadpoolctl).
"""
import json
import math
import os
import pickle
import sys
import time
from collections import Counter

import numpy as np

import tps_solver as tps
from validation.shooting import e0_flat_state, e0_kinks, front_width, table, verify  # noqa: F401

SCRATCH = os.environ.get("INELASTIC_SCRATCH", "/work/scratch/inelastic")
GAMMAS = (3.9, 4.1, 4.4)
DXS = (2.0, 1.0, 0.5)


def _limits():
    try:
        from threadpoolctl import threadpool_limits
        return threadpool_limits(1)
    except ImportError:               # pragma: no cover - optional
        import contextlib
        return contextlib.nullcontext()


def _pdist(a, b, T):
    return np.abs(np.mod(np.asarray(a, float) - np.asarray(b, float) + 0.5 * T, T) - 0.5 * T)


def contact_pattern(events, n_nodes, period, stuck0=None, trigger_tol=1e-9):
    """Per-node contact sequence of one period of a lattice orbit.

    Parameters
    ----------
    events : numpy.recarray
        One period of events with fields ``t`` (float), ``node`` (int), ``kind`` (str in
        {"impact", "stick", "liftoff"}), e.g. ``ShootingOrbit.events``.
    n_nodes : int
        Nodes of the (chain) lattice; node j's neighbours are j - 1 and j + 1.
    period : float
        The period T (times are compared modulo T).
    stuck0 : array_like of bool, shape (n_nodes,), optional
        Nodes stuck at the section (only reported).
    trigger_tol : float
        A lift-off of node j within ``trigger_tol`` (mod T) of a landing (impact or stick) of a
        neighbour is counted as triggered.

    Returns
    -------
    dict
        ``sequences`` (list of str, one per node: the kinds in time order, rotated to start at the
        first lift-off, ``T`` touch-and-go, ``S`` stick, ``L`` lift-off, ``L*`` triggered lift-off),
        ``histogram`` (dict sequence -> number of nodes), ``contacts`` (dict contacts per node ->
        number of nodes), ``touch_and_go``, ``sticks``, ``liftoffs``, ``triggered`` (int totals),
        ``triggered_nodes`` (list of int), ``stuck_at_section`` (int).

    Examples
    --------
    >>> import numpy as np
    >>> ev = np.rec.fromrecords([(2.0, 1, "stick"), (2.0, 0, "liftoff"), (3.0, 0, "impact"),
    ...                          (4.0, 0, "stick"), (5.0, 1, "liftoff")], names="t,node,kind")
    >>> p = contact_pattern(ev, 2, 12.0)
    >>> p["sequences"], p["triggered"], p["contacts"]
    (['L* T S', 'L S'], 1, {1: 1, 2: 1})
    """
    T = float(period)
    t = np.asarray(events.t, dtype=float)
    node = np.asarray(events.node, dtype=int)
    kind = np.asarray(events.kind).astype(str)
    landing = (kind == "impact") | (kind == "stick")
    seqs, n_trig, trig_nodes = [], 0, []
    for j in range(n_nodes):
        idx = np.flatnonzero(node == j)
        idx = idx[np.argsort(t[idx], kind="stable")]
        toks = []
        for i in idx:
            if kind[i] == "impact":
                toks.append("T")
            elif kind[i] == "stick":
                toks.append("S")
            else:
                nb = landing & ((node == j - 1) | (node == j + 1))
                trig = bool(nb.any() and np.min(_pdist(t[nb], t[i], T)) < trigger_tol)
                toks.append("L*" if trig else "L")
                if trig:
                    n_trig += 1
                    trig_nodes.append(j)
        lifts = [k for k, s in enumerate(toks) if s.startswith("L")]
        if lifts:
            toks = toks[lifts[0]:] + toks[:lifts[0]]
        seqs.append(" ".join(toks))
    ncont = [s.split().count("T") + s.split().count("S") for s in seqs]
    return dict(sequences=seqs, histogram=dict(Counter(seqs)),
                contacts={int(k): int(v) for k, v in sorted(Counter(ncont).items())},
                touch_and_go=int(np.sum(kind == "impact")), sticks=int(np.sum(kind == "stick")),
                liftoffs=int(np.sum(kind == "liftoff")), triggered=n_trig,
                triggered_nodes=sorted(set(trig_nodes)),
                stuck_at_section=int(np.count_nonzero(stuck0)) if stuck0 is not None else 0)


def kink_row(Gamma, dx, length=40.0, M=2, periods=10, max_iter=80, callback=None):
    """The e = 0 kink at one (Gamma, dx) by shooting, with its contact pattern.

    Returns a dict (JSON-serialisable except ``orbit``): Gamma, dx, n_nodes, converged, status,
    nit, residual, guess_defect, seconds (shooting), step_seconds (the time-stepped guess),
    maps, width (front widths at the left / right far-field maxima), pattern
    (:func:`contact_pattern`), abs_mu (first 3 |mu|), mu, defect10, defect_ratio, message, orbit.
    """
    r = e0_kinks(dxs=(dx,), length=length, Gamma=Gamma, M=M, periods=periods, max_iter=max_iter,
                 callback=callback)[0]
    orb = r["orbit"]
    row = {k: v for k, v in r.items() if k not in ("contacts",)}
    row["Gamma"] = float(Gamma)
    row["mu"] = [[m.real, m.imag] for m in r["mu"]]
    row["abs_mu"] = [abs(m) for m in r["mu"][:3]]
    if orb.events is not None:
        row["pattern"] = contact_pattern(orb.events, orb.lattice.n_nodes, orb.period, orb.stuck0)
    if "width" in row:
        row["width"] = list(row["width"])
    return row


def _path(Gamma, dx, ext):
    return os.path.join(SCRATCH, f"kink_G{Gamma:g}_dx{dx:g}.{ext}")


def run(Gamma, dx, **kw):
    """Compute :func:`kink_row` and save it to ``SCRATCH`` (JSON row + pickled orbit)."""
    os.makedirs(SCRATCH, exist_ok=True)

    def cb(i, res):
        print(f"    G={Gamma:g} dx={dx:g} Newton step {i}: residual {res:.3g}", flush=True)

    with _limits():
        row = kink_row(Gamma, dx, callback=cb, **kw)
    orb = row.pop("orbit")
    with open(_path(Gamma, dx, "pkl"), "wb") as f:
        pickle.dump(orb, f)
    with open(_path(Gamma, dx, "json"), "w") as f:
        json.dump(row, f, indent=1, default=float)
    return row


def load_orbit(Gamma, dx):
    """The pickled orbit of a saved case (None if missing)."""
    p = _path(Gamma, dx, "pkl")
    if not os.path.exists(p):
        return None
    with open(p, "rb") as f:
        return pickle.load(f)


def gamma_table(gammas=GAMMAS, dxs=DXS + (0.25,)):
    """Rows of the saved cases (the ones that exist), in (Gamma, dx) order."""
    rows = []
    for G in gammas:
        for dx in dxs:
            p = _path(G, dx, "json")
            if os.path.exists(p):
                with open(p) as f:
                    rows.append(json.load(f))
    return rows


if __name__ == "__main__":
    if sys.argv[1:2] == ["run"]:
        row = run(float(sys.argv[2]), float(sys.argv[3]))
        print({k: v for k, v in row.items() if k != "pattern"})
        print(row.get("pattern", {}).get("histogram"))
