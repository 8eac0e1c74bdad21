"""``flat_basins``: the compiled ensemble (``engine="compiled"``, the ``fast`` extra) against the reference.

The same samples (seed 0, the default box, 1024 samples, ``periods=200``, M = 2) are classified by
both engines in one process with one BLAS thread, interleaved ``--repeat`` times; the minimum wall
time of each is reported (the machine is shared), with the ratio and whether the two give the
same labels, phases, transient lengths and attractors (points to 1e-12, multipliers to 1e-6).
The compiled kernels are compiled (or loaded from their cache) before the timings.

Run (from the repository root)::

    PYTHONPATH=. python benchmarks/basins_benchmark.py [--repeat 2] [--samples 1024] [--write]

``--write`` writes the table to ``validation/sections/compiled.md`` (regenerate REPORT.md with
``python validation/report.py``).
"""
import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

import tps_solver as tps

#: (Gamma, e): sticking e = 0, the paper's parameters (chatter), a bouncing e, a chaotic one
CASES = [(4.1, 0.0), (2.5, 0.45), (4.75, 0.2), (3.3, 0.8)]


def same_classification(a, b):
    """Whether two BasinResults classify every sample alike (labels, phases, transients, attractors)."""
    if not (np.array_equal(a.labels, b.labels) and np.array_equal(a.phases, b.phases)
            and np.array_equal(a.n_cycles, b.n_cycles) and a.status == b.status):
        return False
    if [x.label for x in a.attractors] != [x.label for x in b.attractors]:
        return False
    return all(np.allclose(x.points, y.points, rtol=0, atol=1e-12)
               and np.allclose(x.multipliers, y.multipliers, rtol=0, atol=1e-6)
               for x, y in zip(a.attractors, b.attractors))


def compare(n_samples=1024, repeat=2, periods=200, cases=CASES):
    """Rows ``Gamma, e, t_reference, t_compiled, ratio, same, status, top`` (one per case)."""
    tps.flat_basins(2.5, 0.45, n_samples=2, periods=20, engine="compiled")      # compile or load the cache
    rows = []
    for Gamma, e in cases:
        best = {"reference": np.inf, "compiled": np.inf}
        res = {}
        for _ in range(repeat):
            for engine in ("reference", "compiled"):
                tic = time.perf_counter()
                res[engine] = tps.flat_basins(Gamma, e, n_samples=n_samples, periods=periods, engine=engine)
                best[engine] = min(best[engine], time.perf_counter() - tic)
        a, b = res["compiled"], res["reference"]
        top = a.attractors[0].label if a.attractors else "irregular"
        rows.append(dict(Gamma=Gamma, e=e, t_reference=best["reference"], t_compiled=best["compiled"],
                         ratio=best["reference"] / best["compiled"], same=same_classification(a, b),
                         status=a.status, top=top))
    return rows


def section(rows, n_samples, periods):
    from validation.report import markdown_table

    cols = [("Gamma", "Gamma"), ("e", "e"), ("reference s", "t_reference"), ("compiled s", "t_compiled"),
            ("speed-up", lambda r: f"{r['ratio']:.1f}x"), ("same classification", lambda r: "yes" if r["same"] else "NO"),
            ("status", "status"), ("most frequent attractor", "top")]
    return ("## Compiled kernels (the fast extra)\n\n"
            f"`flat_basins`, {n_samples} samples, periods = {periods}, M = 2, seed 0, one BLAS thread, minimum "
            "wall time of interleaved runs (`PYTHONPATH=. python benchmarks/basins_benchmark.py --write`). "
            "`engine=\"reference\"`: every sample through `ClosedFormBall` (the numpy/Python path, and the "
            "path without numba); `engine=\"compiled\"`: one ensemble of numba kernels "
            "(`tps_solver/model/ball_kernel.py`), the same event rules and arithmetic. 'same classification': "
            "labels, phases, transient lengths, status and attractors (points to 1e-12, multipliers to 1e-6) "
            "identical.\n\n" + markdown_table(rows, cols) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--periods", type=int, default=200)
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    with threadpool_limits(1):
        rows = compare(args.samples, args.repeat, args.periods)
    text = section(rows, args.samples, args.periods)
    print(text)
    if args.write:
        from validation.report import write_section
        print("wrote", write_section("compiled", text))


if __name__ == "__main__":
    main()
