"""The second fault battery: unbounded calls refused before any heavy work, raw inputs checked where
they are taken, honest flags, Ctrl-C and hung workers (see validation/fault_battery.py).

Every refusal is decided from an estimate before the work starts: each case here takes well under
2 s.  Interrupts are raised by a callback at a chosen point, never by a timer.
"""
import json
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import costs

FLAT = tps.FlatLayer(2.5, e=0.45)


def _flat_state(n):
    t = FLAT.t0 + 1.0
    return np.full(n, FLAT.velocity(t)), np.full(n, FLAT.height(t)), t


def _square(x):
    return x * x


def _exits(x):
    if x == 2:
        sys.exit(3)
    return x * x


# ------------------------------------------------------------------ sweeps
def test_a_sweep_over_a_huge_product_is_refused_before_expanding_it():
    tic = time.perf_counter()
    with pytest.raises(ValueError, match=r"params \(the number of points\) = 100000000 is out of "
                                         r"reach for sweep: estimated memory"):
        tps.sweep(_square, {"x": list(range(10**4)), "y": list(range(10**4))}, executor="serial",
                  progress=False)
    assert time.perf_counter() - tic < 2.0


def test_a_serial_store_of_a_million_points_is_refused_on_its_own_overhead(tmp_path):
    """The sweep's overhead alone (a key, a sealed file, a thread cap per point) is at least
    1e6 x 0.5 ms = 8 min: refused under a 5-minute limit, before any key is computed."""
    params = [{"x": float(i)} for i in range(10**6)]
    old = costs.set_limits(time=300.0)
    try:
        tic = time.perf_counter()
        with pytest.raises(ValueError, match=r"params \(the number of points\) = 1000000 is out of reach for sweep"):
            tps.sweep(_square, params, executor="serial", store=tmp_path, progress=False)
        assert time.perf_counter() - tic < 2.0
    finally:
        costs.set_limits(**old)


@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_sys_exit_in_one_point_is_a_failed_point_not_the_end_of_the_sweep(executor):
    if executor == "pool":
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(max_workers=1) as ex:
            res = tps.sweep(_exits, {"x": [1, 2, 3]}, executor=ex, progress=False, threads=None)
    else:
        res = tps.sweep(_exits, {"x": [1, 2, 3]}, executor="serial", progress=False)
    assert res.failed == [1]
    assert res[0] == 1 and res[2] == 9
    assert "sys.exit(3)" in res[1].error


@pytest.mark.parametrize("damage", [b'{"task": "tests.te', b"", b"\xff\xfe", b"[1, 2]"])
def test_a_damaged_store_index_is_named(tmp_path, damage):
    tps.sweep(_square, {"x": [1.0, 2.0]}, executor="serial", store=tmp_path, progress=False)
    (tmp_path / "sweep.json").write_bytes(damage)
    with pytest.raises(ValueError, match=r"its index .*sweep\.json' is damaged .* delete sweep\.json"):
        tps.sweep(_square, {"x": [1.0, 2.0]}, executor="serial", store=tmp_path, progress=False)


HUNG = r'''
import json, sys, threading, multiprocessing
import tps_solver as tps
from tps_solver.analyses.sweep import SweepInterrupted


def task(x):
    if x == 0:
        threading.Event().wait()          # hangs for ever
    return x * x


if __name__ == "__main__":
    n = 10
    def stop(state):
        if state.iteration == n - 1:      # every point but the hung one is done: Ctrl-C now
            raise KeyboardInterrupt
    try:
        tps.sweep(task, {"x": list(range(n))}, max_workers=2, progress=False, callback=stop)
        out = {"raised": False}
    except SweepInterrupted as exc:
        out = {"raised": True, "done": int(exc.finished.sum()),
               "alive": [p.pid for p in multiprocessing.active_children()]}
    print("RESULT " + json.dumps(out), flush=True)
'''


@pytest.mark.skipif(sys.platform == "win32", reason="spawned pool and POSIX signals")
def test_an_interrupted_pool_sweep_terminates_a_hung_worker_and_the_process_exits(tmp_path):
    script = tmp_path / "hung.py"
    script.write_text(HUNG)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        out, err = proc.communicate(timeout=120)     # a safety net only: the exit is what is tested
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err[-500:]
    result = json.loads([line for line in out.splitlines() if line.startswith("RESULT ")][-1][7:])
    assert result == {"raised": True, "done": 9, "alive": []}
