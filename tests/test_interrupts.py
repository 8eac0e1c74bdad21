"""Ctrl-C (SIGINT) in the middle of every long entry point returns status 5 with the state so far.

Each case runs in a subprocess. The SIGINT is sent by the process to itself (``os.kill``) from the
call's own progress callback at a chosen report (the third, say), so it arrives at a chosen stage of
the work whatever the machine's load: no timer races the call.  The test reads the result line the
subprocess prints.
"""
import json
import subprocess
import sys

import pytest

PROBE = r'''
import sys, json, os, signal, time
import numpy as np
import tps_solver as tps

# a run started in the background without job control (nohup, `&` in a script) inherits SIGINT
# ignored, and Python then installs no handler: restore what an interactive user has
signal.signal(signal.SIGINT, signal.default_int_handler)


def fire(k):
    """A callback that sends SIGINT to this process at its k-th call."""
    calls = [0]

    def cb(state=None):
        calls[0] += 1
        if calls[0] == k:
            os.kill(os.getpid(), signal.SIGINT)
    return cb

def slow_square(x):
    time.sleep(0.05)
    return x * x


def run(case):
    fl = tps.FlatLayer(2.5, e=0.45)
    if case == "simulate":
        lat = tps.Lattice.planar(n_nodes=41, length=40.0)
        t = fl.t0 + 1.0
        w = np.full(41, fl.velocity(t)); z = np.full(41, fl.height(t)); z[:20] += 0.3
        r = tps.simulate(lat, 2.5, 0.45, w, z, t_start=t, t_end=t + 2000 * fl.period, method="exact",
                         callback=fire(3))
        return dict(status=r.status, message=r.message)
    if case == "check_stability":
        r = tps.check_stability(fl, periods=5000, n_nodes=41, callback=fire(3))
        return dict(status=5 if r.interrupted else 0, message=r.message)
    if case == "shooting":
        lat = tps.Lattice.planar(n_nodes=41, length=40.0)
        r = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=200, multipliers=False, callback=fire(3))
        return dict(status=r.status, message=r.message)
    if case == "find_periodic_orbit":
        lat = tps.Lattice.planar(n_nodes=41, length=40.0)
        r = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=0, max_iter=500, multipliers=False, symmetric=False,
                             callback=fire(2))
        return dict(status=r.status, message=r.message)
    if case == "mirrored":
        lat = tps.Lattice.planar(n_nodes=161, length=40.0)
        r = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=0, multipliers=False, symmetric=True, callback=fire(2))
        return dict(status=r.status, message=r.message)
    if case == "sweep":
        from tps_solver.analyses.sweep import SweepInterrupted
        try:
            tps.sweep(slow_square, {"x": list(range(400))}, executor="serial", progress=False, callback=fire(5))
        except SweepInterrupted as exc:          # the sweep's documented answer: the results so far
            done = int(exc.finished.sum())
            return dict(status=5 if 0 < done < 400 else -1, message=f"interrupted: {exc}")
        return dict(status=0, message="finished")
    if case == "tps":
        r = tps.solve_oscillon(n_harmonics=60, n_nodes=40, r_max=800.0, scheme="picard", max_iter=100000,
                               continuation=False, tol=1e-300, callback=fire(3))
        return dict(status=r.status, message=r.message)
    if case == "branch":
        r = tps.continue_branch(fl, "Gamma", (2.3, 3.2), max_points=10**6, step=1e-7, max_step=1e-6, min_step=1e-9,
                                callback=fire(3))
        return dict(status=r.status, message=r.message)
    if case == "branch_cycle":
        cyc = tps.solve_lattice_cycle(tps.Lattice.planar(n_nodes=8, length=140.0), Gamma=2.5, M=2, e=0.45, t0=None)
        r = tps.continue_branch(cyc, "spacing", (8.0, 60.0), direction=1, step=0.01, max_step=0.02,
                                max_points=10**5, callback=fire(3))
        return dict(status=r.status, message=r.message)
    if case == "basins":
        # the compiled ensemble (the default where numba is installed) is ~40x faster than the
        # reference: enough samples that neither finishes before the signal
        from tps_solver.core import jit
        from tps_solver.core.progress import Progress
        update, cb = Progress.update, fire(3)          # SIGINT at the third chunk of samples

        def counted(self, n=1):
            update(self, n)
            cb()
        Progress.update = counted
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
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    lines = [line for line in out.splitlines() if line.startswith("RESULT ")]
    assert lines, f"no result line; stderr: {err[-500:]}"
    result = json.loads(lines[-1][len("RESULT "):])
    assert result["status"] == 5, result
    assert "interrupted" in result["message"]
