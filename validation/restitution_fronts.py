"""Kinks and oscillons with a speed-dependent restitution: what a time-stepped front does.

Section 2 of the existence map (:func:`validation.existence_map.front_run`: a kink on a planar
Neumann lattice of length 40, an oscillon core of radius 2 on an axisymmetric lattice of radius
20, dx = 0.4, built from the two phases of the f/2 state that attracts the single ball and
time-stepped period by period) with the viscoelastic law :class:`~tps_solver.ViscoelasticRestitution`
in place of a constant e, side by side with the constant e that the law's flat orbit has (single
bounce) or with e = 0 (where the far field chatters and sticks, the law's e -> 0 limit).  The
cases sit inside the law's stable f/2 window (``validation/restitution_flat.py``) or, for b = 5,
where the law's flat orbit bounces and chatters to rest once per period.

``main`` writes ``validation/sections/restitution_fronts.md``; run
``python -m validation.restitution_fronts`` (about 15 minutes on one core).
"""
import argparse
import time

from tps_solver import FlatLayer
from tps_solver.model.restitution import ViscoelasticRestitution
from validation.existence_map import front_run
from validation.report import markdown_table, one_blas_thread, publish

#: (b, Gamma) of the viscoelastic law: three inside the stable single-bounce window, two with a
#: bounce-and-chatter-to-rest far field.
CASES = ((0.5, 2.15), (0.6, 2.4), (1.0, 3.25), (5.0, 4.6), (5.0, 5.0))


def comparison_e(law, Gamma, M=2):
    """The constant e to compare with: the law's flat single-bounce e, else 0 (a sticking far field)."""
    try:
        return FlatLayer(Gamma, M, e=law, pattern="bounce").e, "e(v) of the flat bounce"
    except ValueError:
        return 0.0, "e = 0 (the far field sticks)"


def fates(cases=CASES, geometries=("kink", "oscillon"), periods=10, dx=0.4):
    """One row per (case, geometry, restitution): verdict, front speed and cost (list of dict)."""
    rows = []
    with one_blas_thread():
        for b, G in cases:
            law = ViscoelasticRestitution(b)
            e_c, why = comparison_e(law, G)
            for geom in geometries:
                for label, e in ((f"law b = {b:g}", law), (f"constant e = {e_c:.4g}", e_c)):
                    t0 = time.perf_counter()
                    r = front_run(geom, Gamma=G, e=e, dx=dx, periods=periods, keep_state=False)
                    rows.append(dict(b=b, Gamma=G, geometry=geom, restitution=label, compared_with=why,
                                     verdict=r["verdict"], speed=r.get("speed"), pattern=r.get("pattern"),
                                     invader=r.get("invader"), periods_run=r.get("periods_run"),
                                     seconds=time.perf_counter() - t0))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=10)
    args = ap.parse_args(argv)
    start = time.perf_counter()
    rows = fates(periods=args.periods)
    total = time.perf_counter() - start
    same = sum(1 for i in range(0, len(rows), 2) if rows[i]["verdict"] == rows[i + 1]["verdict"])
    text = [
        "Kinks and oscillons time-stepped with the viscoelastic restitution law, against the constant e "
        f"of the law's flat orbit (`python -m validation.restitution_fronts`, {args.periods} periods, dx = 0.4, "
        f"{total:.0f} s on one core; the construction and verdicts of the existence map's section 2).", "",
        markdown_table(rows, [(k, k) for k in ("b", "Gamma", "geometry", "restitution", "pattern", "verdict",
                                              "speed", "periods_run", "seconds")]), "",
        f"**Measured.** {same} of {len(rows) // 2} pairs have the same fate with the law as with the constant e "
        "(speed: the front speed in viscous lengths per period).",
    ]
    differ = [(rows[i], rows[i + 1]) for i in range(0, len(rows), 2) if rows[i]["verdict"] != rows[i + 1]["verdict"]]
    for a, c in differ:
        text.append(f"- b = {a['b']:g}, Gamma = {a['Gamma']:g}, {a['geometry']}: {a['verdict']} with the law, "
                    f"{c['verdict']} with {c['restitution']}.")
    settled = [r for r in rows if r["restitution"].startswith("law") and r["verdict"] in ("settles", "stationary")]
    text.append("" if settled else "\nNo front settled with the law in these cases: the speed-dependent "
                "restitution does not create kinks or oscillons here.")
    publish("restitution_fronts", "\n".join(text))
    return rows


if __name__ == "__main__":
    main()
