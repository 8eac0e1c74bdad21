"""Ctrl-C (SIGINT) in the middle of every long entry point returns status 5 with the state so far.

Each case runs in a subprocess that says "ready" just before the call; the test sends SIGINT
1.5 s later, while the call is running (every call lasts far longer than that), and reads the result line the subprocess prints.
"""
import json
import signal
import subprocess
import sys
import time

import pytest

PROBE = r'''
import sys, json, time
import numpy as np
import tps_solver as tps

def slow_square(x):
    time.sleep(0.05)
    return x * x


def run(case):
    fl = tps.FlatLayer(2.5, e=0.45)
    if case == "simulate":
        lat = tps.Lattice.planar(n_nodes=41, length=40.0)
        t = fl.t0 + 1.0
        w = np.full(41, fl.velocity(t)); z = np.full(41, fl.height(t)); z[:20] += 0.3
        print("ready", flush=True)
        r = tps.simulate(lat, 2.5, 0.45, w, z, t_start=t, t_end=t + 2000 * fl.period, method="exact")
        return dict(status=r.status, message=r.message)
    if case == "check_stability":
        print("ready", flush=True)
        r = tps.check_stability(fl, periods=5000, n_nodes=41)
        return dict(status=5 if r.interrupted else 0, message=r.message)
    if case == "shooting":
        lat = tps.Lattice.planar(n_nodes=41, length=40.0)
        print("ready", flush=True)
        r = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=200, multipliers=False)
        return dict(status=r.status, message=r.message)
    if case == "find_periodic_orbit":
        lat = tps.Lattice.planar(n_nodes=41, length=40.0)
        print("ready", flush=True)
        r = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=0, max_iter=500, multipliers=False, symmetric=False)
        return dict(status=r.status, message=r.message)
    if case == "mirrored":
        lat = tps.Lattice.planar(n_nodes=161, length=40.0)
        print("ready", flush=True)
        r = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=0, multipliers=False, symmetric=True)
        return dict(status=r.status, message=r.message)
    if case == "sweep":
        from tps_solver.analyses.sweep import SweepInterrupted
        print("ready", flush=True)
        try:
            tps.sweep(slow_square, {"x": list(range(400))}, executor="serial", progress=False)
        except SweepInterrupted as exc:          # the sweep's documented answer: the results so far
            done = int(exc.finished.sum())
            return dict(status=5 if 0 < done < 400 else -1, message=f"interrupted: {exc}")
        return dict(status=0, message="finished")
    if case == "tps":
        print("ready", flush=True)
        r = tps.solve_oscillon(n_harmonics=60, n_nodes=40, r_max=800.0, scheme="picard", max_iter=100000,
                               continuation=False, tol=1e-300)
        return dict(status=r.status, message=r.message)
    if case == "branch":
        print("ready", flush=True)
        r = tps.continue_branch(fl, "Gamma", (2.3, 3.2), max_points=10**6, step=1e-7, max_step=1e-6, min_step=1e-9)
        return dict(status=r.status, message=r.message)
    if case == "branch_cycle":
        cyc = tps.solve_lattice_cycle(tps.Lattice.planar(n_nodes=8, length=140.0), Gamma=2.5, M=2, e=0.45, t0=None)
        print("ready", flush=True)
        r = tps.continue_branch(cyc, "spacing", (8.0, 60.0), direction=1, step=0.01, max_step=0.02,
                                max_points=10**5)
        return dict(status=r.status, message=r.message)
    if case == "basins":
        print("ready", flush=True)
        # the compiled ensemble (the default where numba is installed) is ~40x faster than the
        # reference: enough samples that neither finishes before the signal
        from tps_solver.core import jit
        r = tps.flat_basins(2.5, 0.45, n_samples=200000 if jit.enabled() else 4000, periods=400,
                            executor="serial")
        return dict(status=r.status, message=r.message, n=int(r.n_samples))

case = sys.argv[1]
try:
    out = run(case)
except KeyboardInterrupt as exc:
    out = dict(status="raised KeyboardInterrupt", message=repr(exc)[:300])
except Exception as exc:
    out = dict(status="raised " + type(exc).__name__, message=str(exc)[:300])
print("RESULT " + json.dumps(out), flush=True)
'''

CASES = ["simulate", "check_stability", "shooting", "find_periodic_orbit", "mirrored", "tps", "branch",
         "branch_cycle", "basins", "sweep"]


@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT to a subprocess is POSIX")
@pytest.mark.parametrize("case", CASES)
def test_sigint_returns_status_5_with_an_honest_message(case, tmp_path):
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    proc = subprocess.Popen([sys.executable, str(script), case], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(1.5)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    lines = [line for line in out.splitlines() if line.startswith("RESULT ")]
    assert lines, f"no result line; stderr: {err[-500:]}"
    result = json.loads(lines[-1][len("RESULT "):])
    assert result["status"] == 5, result
    assert "interrupted" in result["message"]
