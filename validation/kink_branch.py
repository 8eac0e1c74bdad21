"""The e = 0 kink continued in Gamma: width, leading multiplier and special points along the branch.

:func:`gamma_branch` starts from the shooting kink (:func:`tps_solver.lattice_kink`) at
Gamma = 4.1 on a planar Neumann lattice of length 40 and follows it in Gamma by
pseudo-arclength continuation (:func:`tps_solver.continue_branch` on the shooting problem:
the FDA period map with a dense Jacobian, whose eigenvalues are the multipliers) towards both
ends of the range where the far field's sticking f/2 orbit exists (3.857 <= Gamma <= 6.362 at
e = 0).  At every point the width (:func:`tps_solver.front_width`,
``instant="lower_far_field_top"``) is measured on the orbit through the branch state.
:func:`independent_points` re-solves three Gamma values from shooting's own default start and
compares the leading multiplier and the state with the branch.

:func:`mirrored_branch` follows the same kink as a fixed point of the mirrored half-period map
(:class:`tps_solver.solvers.shooting.symmetric.MirroredHalfPeriodMap`, G with G^2 = P_T): its
multipliers mu_G are the signed square roots of the period map's, so a multiplier of P_T through
+1 is either mu_G through +1 (a bifurcation within the symmetric kinks: a fold or a branch point of
G) or mu_G through -1 (a period doubling of G: the mirror-antisymmetric mode, the front's
translation, turns unstable -- the symmetric kink depins).

``main`` writes ``validation/sections/kink_branch.md`` and the figure
``validation/figures/kink_branch.png``.  Run ``python -m validation.kink_branch [--dx 2]``
(about 15 minutes at dx = 2 on one core; the mirrored branch about 6 minutes).
"""
import argparse
import json
import os
import time

import numpy as np

import tps_solver as tps
from validation.report import markdown_table, one_blas_thread, publish

LENGTH = 40.0
BOUNDS = (3.86, 6.36)
FIGURES = os.path.join(os.path.dirname(__file__), "figures")
DATA = os.path.join(os.path.dirname(__file__), "data", "kink_branch")


def _lattice(dx, length=LENGTH):
    return tps.Lattice.planar(n_nodes=int(round(length / dx)) + 1, length=length)


def orbit_at(lat, Gamma, state, t_start):
    """The periodic orbit through a branch state (one period of the FDA, no Newton step).

    The shooting problem's period map reads the state with zeta clipped at 0 (a node at or
    below the plate at the section is on the plate), so the orbit starts from that clipped state;
    the clipping's size is returned in the row (``min_zeta0``)."""
    n = lat.n_nodes
    return tps.find_periodic_orbit(lat, Gamma=Gamma, M=2, e=0.0, guess=(state[:n], np.maximum(state[n:], 0.0)),
                                   t_start=t_start, max_iter=0, multipliers=False)


def _print_point(state):
    print(f"  point {state.get('iteration', '?')}: {dict((k, v) for k, v in state.items() if k != 'stage')}", flush=True)


def gamma_branch(dx=2.0, bounds=BOUNDS, Gamma0=4.1, verbose=False, branch=None, **kw):
    """The branch and per-point measurements (dict: ``branch``, ``rows``, ``start``, ``seconds``).

    ``kw`` goes to :func:`tps_solver.continue_branch` (default ``bothsides=True``); a stored
    ``branch`` (:func:`tps_solver.load_branch`) is measured instead of recomputed.
    """
    kw.setdefault("bothsides", True)
    kw.setdefault("step", 0.05)
    kw.setdefault("max_step", 0.5)
    if verbose:
        kw.setdefault("callback", _print_point)
    lat = _lattice(dx)
    with one_blas_thread():
        start_time = time.perf_counter()
        start = tps.lattice_kink(lat, Gamma=Gamma0, e=0.0)
        if not start.converged:
            raise RuntimeError(f"the start kink at Gamma = {Gamma0} did not converge: {start.message}")
        br = tps.continue_branch(start, "Gamma", bounds, **kw) if branch is None else branch
        seconds = time.perf_counter() - start_time
        rows = []
        for G, x, mu, st in zip(br.parameter_values, br.states, br.multipliers, br.stable):
            orb = orbit_at(lat, float(G), x, start.t_start)
            try:
                w = float(tps.front_width(orb, instant="lower_far_field_top")[0])
            except ValueError:
                w = None
            lead = complex(mu[int(np.nanargmax(np.abs(mu)))])
            rows.append(dict(Gamma=float(G), mu1=float(abs(lead)), mu1_imag=abs(lead.imag), stable=bool(st), width=w,
                             period_defect=float(orb.residual), min_zeta0=float(np.min(x[lat.n_nodes:]))))
    return dict(branch=br, rows=rows, start=start, seconds=seconds, lattice=lat)


def _state_differences(lat, Gamma, a, b):
    """max-norm distance of orbit ``a``'s section state from ``b``'s, and from ``b``'s mirror image.

    The kink's symmetry on a symmetric Neumann lattice: the state at x, t equals the mirrored
    state at L - x, t + T/2 (the two flat phases swap), so the mirror image of ``b`` is ``b``
    advanced by half a period with the nodes reversed."""
    direct = float(max(np.max(np.abs(a.w0 - b.w0)), np.max(np.abs(a.zeta0 - b.zeta0))))
    half = b.period / 2.0
    run = tps.simulate(lat, Gamma, 0.0, b.w0, b.zeta0, t_start=b.t_start, t_end=b.t_start + half,
                       method=b.method, stuck0=b.get("stuck0"))
    mirrored = float(max(np.max(np.abs(a.w0 - run.w[::-1])), np.max(np.abs(a.zeta0 - run.zeta[::-1]))))
    return direct, mirrored


def independent_points(result, gammas):
    """Shooting from its default start at each Gamma of ``gammas`` against the branch (list of dict).

    The branch state is interpolated linearly between its two neighbouring points in Gamma and
    refined by shooting from there (``refined``); the independent solve's leading multiplier is
    compared with the refined one's, and its state with the refined state (max norm).
    """
    lat, br = result["lattice"], result["branch"]
    t0 = result["start"].t_start
    p = br.parameter_values
    out = []
    with one_blas_thread():
        for G in gammas:
            ind = tps.lattice_kink(lat, Gamma=G, e=0.0, t_start=t0)
            k = int(np.clip(np.searchsorted(p, G) if p[-1] > p[0] else np.searchsorted(-p, -G), 1, p.size - 1))
            a, b = p[k - 1], p[k]
            s = (G - a) / (b - a) if b != a else 0.0
            guess = (1 - s) * br.states[k - 1] + s * br.states[k]
            n = lat.n_nodes
            ref = tps.find_periodic_orbit(lat, Gamma=G, M=2, e=0.0, guess=(guess[:n], np.maximum(guess[n:], 0.0)),
                                          t_start=t0)
            row = dict(Gamma=G, independent_converged=bool(ind.converged), branch_converged=bool(ref.converged))
            if ind.converged and ref.converged:
                direct, mirrored = _state_differences(lat, G, ind, ref)
                row.update(mu1_independent=float(abs(ind.multipliers[0])), mu1_branch=float(abs(ref.multipliers[0])),
                           mu1_difference=float(abs(abs(ind.multipliers[0]) - abs(ref.multipliers[0]))),
                           state_difference=min(direct, mirrored),
                           same_as=("a different orbit" if min(direct, mirrored) > 1e-6 else
                                    "the branch orbit" if direct <= mirrored else
                                    "its mirror image (x -> L - x, half a period later)"))
            out.append(row)
    return out


def plot(result, path):
    import matplotlib
    import matplotlib.pyplot as plt
    rows = result["rows"]
    G = np.array([r["Gamma"] for r in rows])
    mu = np.array([r["mu1"] for r in rows])
    w = np.array([np.nan if r["width"] is None else r["width"] for r in rows])
    st = np.array([r["stable"] for r in rows])
    with matplotlib.rc_context({"figure.figsize": (7.0, 5.0)}):
        fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True)
        ax1.plot(G, w, "-", color="0.6", lw=0.8)
        ax1.plot(G[st], w[st], "o", ms=3, label="stable")
        ax1.plot(G[~st], w[~st], "x", ms=4, label="unstable")
        ax1.set_ylabel("front width")
        ax1.legend(fontsize=8)
        ax2.plot(G, mu, "-", color="0.6", lw=0.8)
        ax2.plot(G[st], mu[st], "o", ms=3)
        ax2.plot(G[~st], mu[~st], "x", ms=4)
        ax2.axhline(1.0, color="k", lw=0.5)
        for kind, value in result["branch"].special_points:
            for ax in (ax1, ax2):
                ax.axvline(value, color="C3", lw=0.8, ls=":")
        ax2.set_xlabel(r"$\Gamma$")
        ax2.set_ylabel(r"largest $|\mu|$")
        dx = result["lattice"].nodes[1] - result["lattice"].nodes[0]
        ax1.set_title(f"e = 0 kink, dx = {dx:g}, L = {LENGTH:g}", fontsize=9)
        fig.tight_layout()
        fig.savefig(path, dpi=130)
        plt.close(fig)


def mirrored_branch(dx=2.0, bounds=BOUNDS, Gamma0=4.1, branch=None, **kw):
    """The symmetric kink continued on the mirrored half-period map (dict: ``branch``, ``rows``, ``seconds``).

    Rows: ``Gamma``, the leading multiplier of G (``mu_G``, its real part and modulus), the
    period map's ``mu1 = |mu_G|^2`` and ``stable``.  A stored ``branch`` is read instead.
    """
    from tps_solver.solvers.shooting.symmetric import MirroredHalfPeriodMap

    kw.setdefault("bothsides", True)
    kw.setdefault("max_points", 200)
    lat = _lattice(dx)
    start = time.perf_counter()
    if branch is None:
        with one_blas_thread():
            orb = tps.lattice_kink(lat, Gamma=Gamma0, e=0.0, symmetric=True)
            if not orb.converged:
                raise RuntimeError(f"no symmetric kink at Gamma = {Gamma0}: {orb.message}")
            G = MirroredHalfPeriodMap(lat, Gamma0, 0.0, orb.period, orb.t_start, stuck=orb.stuck0)
            branch = tps.continue_branch((G, G.pack(orb.w0, orb.zeta0)), "Gamma", bounds, **kw)
    rows = []
    for k, g in enumerate(branch.parameter_values):
        mu = np.asarray(branch.multipliers[k])
        lead = complex(mu[np.argmax(np.abs(mu))]) if mu.size else complex("nan")
        rows.append(dict(Gamma=float(g), mu_G_real=f"{lead.real:.6f}", mu_G_abs=abs(lead), mu1=abs(lead) ** 2,
                         stable=bool(branch.stable[k])))
    return dict(branch=branch, rows=rows, seconds=time.perf_counter() - start)


def _retrace(values, mu1, tol=1e-3):
    """Index of the turning point after which the branch retraces itself, or None.

    After the largest parameter value the branch is a retrace when its later points repeat earlier
    ones (the same parameter and |mu1| to ``tol``); the point at the turn is where the corrector
    jumped (at the non-smooth section), so the trusted part ends before it."""
    p, m = np.asarray(values, float), np.asarray(mu1, float)
    k = int(np.argmax(p))
    later = [(p[j], m[j]) for j in range(k + 1, p.size)]
    earlier = [(p[j], m[j]) for j in range(k)]
    repeats = sum(any(abs(a - c) < 1e-2 and abs(b - d) < tol for c, d in earlier) for a, b in later)
    return k if later and repeats >= 0.5 * len(later) else None


def mirrored_text(res, dx, old_branch=None):
    """The REPORT paragraph and table of :func:`mirrored_branch` (``old_branch``: the period map's, to compare).

    A corrector that jumps (a parameter step ten times the median before it: the non-smooth point where
    a node touches the plate at the section) ends the trusted part of the branch; what follows is
    reported, not used."""
    br = res["branch"]
    rows = res["rows"]
    cut = _retrace(br.parameter_values, [r["mu1"] for r in rows])
    keep = len(rows) if cut is None else cut
    sps = [sp for sp in br.special_points if cut is None or getattr(sp, "index", 0) < cut]
    uniq = []
    for sp in sps:
        if not any(sp[0] == u[0] and abs(sp[1] - u[1]) < 1e-5 for u in uniq):
            uniq.append(sp)
    meaning = {"period_doubling": "mu_G passes -1: the front's translation (the mirror-antisymmetric mode) "
                                  "changes stability, the symmetric kink pins or depins",
               "branch_point": "mu_G passes +1 within the symmetric kinks", "fold": "a fold of symmetric kinks"}
    said = "; ".join(f"{kind} at Gamma = {value:.7g} ({meaning.get(kind, kind)})" for kind, value in uniq) or "none"
    jump = ""
    if cut is not None:
        p = br.parameter_values
        jump = (f" At Gamma = {p[cut - 1]:.5g} the corrector jumped to {p[cut]:.5g} (near where a node reaches "
                f"the plate at the section and the map is not smooth) and then retraced the branch downwards "
                f"(the same points and special points again); only the {cut} points before the jump are used.")
    old = ""
    if old_branch is not None:
        bps = [v for kind, v in old_branch.special_points if kind == "branch_point"]
        if bps:
            same = any(kind == "period_doubling" and abs(v - bps[0]) < 1e-3 for kind, v in uniq)
            old = (f" The period map's branch above types a branch point at Gamma = {bps[0]:.7g}; "
                   + ("G has a period doubling there: the branch point is the depinning of the symmetric kink "
                      "(its translation mode), not a new family of symmetric kinks." if same
                      else "G has no special point within 1e-3 of it."))
    stable = [r for r in rows[:keep] if r["stable"]]
    window = (f" Stable at the computed points from Gamma = {min(r['Gamma'] for r in stable):.4g} to "
              f"{max(r['Gamma'] for r in stable):.4g} (the period doublings bound the window)." if stable
              else " Unstable everywhere on the branch.")
    part = rows[:keep]
    stride = max(1, len(part) // 30)
    table = part[::stride] + ([part[-1]] if (len(part) - 1) % stride else [])
    return "\n".join([
        "### The symmetric kink on the mirrored half-period map", "",
        f"The same kink (dx = {dx:g}) continued as a fixed point of G = S o P_(T/2) (`tps.continue_branch` on "
        "`MirroredHalfPeriodMap`; `mirrored_branch` in `python -m validation.kink_branch`, "
        f"{res['seconds']:.0f} s). G's multipliers are signed square roots of the period map's. Special points: "
        f"{said}.{window}{jump}{old}", "",
        markdown_table(table, [(k, k) for k in ("Gamma", "mu_G_real", "mu_G_abs", "mu1", "stable")]),
    ])


def e_branch(dx=2.0, Gamma=4.1, bounds=(0.0, 0.5), max_points=20, step=0.005, max_step=0.02):
    """The symmetric e = 0 kink continued in the restitution e on G (rows: e, mu_G, mu1, stable, seconds)."""
    from tps_solver.solvers.shooting.symmetric import MirroredHalfPeriodMap

    lat = _lattice(dx)
    start = time.perf_counter()
    rows = []

    def cb(state):
        rows.append(dict(e=float(state.parameter_value), stable=bool(state.stable),
                         seconds=time.perf_counter() - start))
        print(f"  e = {state.parameter_value:.6g}, stable {state.stable}, {rows[-1]['seconds']:.0f} s", flush=True)

    with one_blas_thread():
        orb = tps.lattice_kink(lat, Gamma=Gamma, e=0.0, symmetric=True)
        G = MirroredHalfPeriodMap(lat, Gamma, 0.0, orb.period, orb.t_start, stuck=orb.stuck0)
        br = tps.continue_branch((G, G.pack(orb.w0, orb.zeta0)), "e", bounds, step=step, max_step=max_step,
                                 max_points=max_points, callback=cb)
    out = []
    for k, e in enumerate(br.parameter_values):
        mu = np.asarray(br.multipliers[k])
        lead = complex(mu[np.argmax(np.abs(mu))]) if mu.size else complex("nan")
        out.append(dict(e=float(e), mu_G_real=f"{lead.real:.6f}", mu_G_imag=f"{lead.imag:.2e}", mu1=abs(lead) ** 2,
                        stable=bool(br.stable[k])))
    return dict(branch=br, rows=out, seconds=time.perf_counter() - start, Gamma=Gamma, dx=dx)


def e_branch_section(res):
    br = res["branch"]
    sp = ", ".join(f"{kind} at e = {value:.6g}" for kind, value in br.special_points) or "none"
    return "\n".join([
        f"The symmetric e = 0 kink (Gamma = {res['Gamma']:g}, dx = {res['dx']:g}, length {LENGTH:g}) continued in "
        "the restitution e as a fixed point of the mirrored half-period map (`python -m validation.kink_branch "
        f"--e-branch`, {res['seconds']:.0f} s, at most {len(res['rows'])} points: at e > 0 every landing chatters "
        f"before it sticks, and a point costs minutes). Branch status {br.status}: {br.message}. Special points: "
        f"{sp}.", "",
        markdown_table(res["rows"], [(k, k) for k in ("e", "mu_G_real", "mu_G_imag", "mu1", "stable")]),
    ])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=2.0)
    ap.add_argument("--check", type=float, nargs="+", default=[3.95, 4.2, 4.5])
    ap.add_argument("--reuse", action="store_true", help="measure the stored branch instead of recomputing it")
    ap.add_argument("--reuse-mirrored", action="store_true", help="read the stored mirrored branch")
    ap.add_argument("--e-branch", action="store_true", help="only the branch in e (section kink_ebranch)")
    args = ap.parse_args(argv)
    if args.e_branch:
        res = e_branch(args.dx)
        os.makedirs(DATA, exist_ok=True)
        res["branch"].save(os.path.join(DATA, f"ebranch_dx{args.dx:g}.npz"))
        publish("kink_ebranch", e_branch_section(res))
        return
    stored_m = os.path.join(DATA, f"mirrored_dx{args.dx:g}.npz")
    cost_m = stored_m.replace(".npz", "_seconds.json")
    if args.reuse_mirrored and os.path.exists(stored_m):
        mres = mirrored_branch(args.dx, branch=tps.load_branch(stored_m))
        mres["seconds"] = json.load(open(cost_m))["seconds"] if os.path.exists(cost_m) else float("nan")
    else:
        mres = mirrored_branch(args.dx)
        os.makedirs(DATA, exist_ok=True)
        mres["branch"].save(stored_m)
        with open(cost_m, "w") as fh:
            json.dump({"seconds": mres["seconds"]}, fh)
    stored = os.path.join(DATA, f"branch_dx{args.dx:g}.npz")
    if args.reuse and os.path.exists(stored):
        res = gamma_branch(args.dx, branch=tps.load_branch(stored))
    else:
        res = gamma_branch(args.dx, verbose=True)
        os.makedirs(DATA, exist_ok=True)
        res["branch"].save(stored)                                    # the branch, kept before the checks
    br = res["branch"]
    cost = (f"the stored branch of an earlier run, measured here in {res['seconds']:.0f} s" if args.reuse
            and os.path.exists(stored) else f"{res['seconds']:.0f} s")
    changes = [(a, b) for a, b in zip(res["rows"][:-1], res["rows"][1:]) if a["stable"] != b["stable"]]
    typed = [sp for sp in br.special_points if sp[0] == "branch_point"]
    change_text = " ".join(
        f"The kink loses or gains stability between Gamma = {a['Gamma']:.4g} (|mu1| = {a['mu1']:.4g}) and "
        f"{b['Gamma']:.4g} (|mu1| = {b['mu1']:.4g}), with the leading multiplier "
        f"{'real' if max(a['mu1_imag'], b['mu1_imag']) < 1e-8 else 'complex'} and Gamma monotone there"
        + (f": continue_branch types it as a branch point (a multiplier through +1 while Gamma goes on) at "
           f"Gamma = {typed[0][1]:.6g}, where another family of orbits meets this one (not computed here)."
           if typed else ": a multiplier through +1 on a branch that goes on (a branch point; this stored "
           "branch predates the typing).")
        for a, b in changes) or "The stability does not change along the branch."
    if changes:
        change_text += (" Where shooting from its own default start finds a different orbit than the branch "
                        "(table below), it is another kink of the same lattice and Gamma.")
    checks = independent_points(res, args.check)
    os.makedirs(FIGURES, exist_ok=True)
    fig = os.path.join(FIGURES, "kink_branch.png")
    plot(res, fig)
    sp = ", ".join(f"{kind} at Gamma = {value:.6g}" for kind, value in br.special_points) or "none"
    text = [
        f"The e = 0 kink on a planar Neumann lattice (dx = {args.dx:g}, length {LENGTH:g}) continued in Gamma from "
        f"4.1 (`tps.continue_branch` on the shooting problem; `python -m validation.kink_branch --dx {args.dx:g}`, "
        f"{cost}). Branch status {br.status}: {br.message}. {len(res['rows'])} points, Gamma "
        f"from {min(br.parameter_values):.4g} to {max(br.parameter_values):.4g}; special points: {sp}. "
        "Figure: `validation/figures/kink_branch.png`. " + change_text + " min_zeta0 is the smallest height "
        "at shooting's fixed section t_start: where it reaches 0 a node touches the plate at the section and "
        "the period map is not smooth there, which ends the branch (a limit of the section, not of the kink).",
        "",
        markdown_table(res["rows"], [(k, k) for k in ("Gamma", "mu1", "mu1_imag", "stable", "width",
                                                      "period_defect", "min_zeta0")]), "",
        "Independent solves (shooting from its default start) against the branch (the branch state interpolated "
        "in Gamma and refined by shooting):", "",
        markdown_table(checks, [(k, k) for k in ("Gamma", "independent_converged", "branch_converged",
                                                "mu1_independent", "mu1_branch", "mu1_difference",
                                                "state_difference", "same_as")]),
        "", mirrored_text(mres, args.dx, br),
    ]
    publish("kink_branch", "\n".join(text))


if __name__ == "__main__":
    main()
