"""tps_solver.sweep under faults: failing tasks, damaged store files, a parent killed with SIGKILL."""
import logging
import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
import time
import uuid
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from tps_solver.analyses.sweep import FailedPoint, SweepResults, load_store, param_key, sweep

LOGGER = "tps_solver.sweep"


# ---------------------------------------------------------------- tasks (module level: picklable)
def faulty_task(x, log_dir, fail_on=(), delay=0.0):
    """x**2 after ``delay`` seconds; one file per call in log_dir (tagged by its "gen" file); raises for x in fail_on."""
    d = Path(log_dir)
    gen = (d / "gen").read_text() if (d / "gen").exists() else "1"
    (d / f"call-{x}-{gen}-{uuid.uuid4().hex}").write_text("")
    if delay:
        time.sleep(delay)
    if x in fail_on:
        raise ArithmeticError(f"planned failure at x = {x}")
    return x * x


def _calls(log_dir, gen=None):
    names = [p.name.split("-") for p in Path(log_dir).glob("call-*")]
    return sorted(int(n[1]) for n in names if gen is None or n[2] == str(gen))


def _messages(caplog):
    return [r.getMessage() for r in caplog.records if r.name == LOGGER]


# --------------------------------------------------------------------------- on_error
@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_failed_points_are_recorded_not_stored_and_retried(tmp_path, caplog, executor):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    params = {"x": [0, 1, 2, 3, 4, 5], "log_dir": [str(log)], "fail_on": [(1, 4)]}
    caplog.set_level(logging.WARNING, logger=LOGGER)
    if executor == "pool":
        with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as ex:
            res = sweep(faulty_task, params, executor=ex, store=store, progress=False)
    else:
        res = sweep(faulty_task, params, executor="serial", store=store, progress=False)
    assert isinstance(res, SweepResults) and isinstance(res, list)
    assert res.failed == [1, 4]
    assert [res[i] for i in (0, 2, 3, 5)] == [0, 4, 9, 25]
    for i in (1, 4):
        assert isinstance(res[i], FailedPoint)
        assert res[i].params == {"x": i, "log_dir": str(log), "fail_on": (1, 4)}
        assert res[i].error == f"ArithmeticError: planned failure at x = {i}"
        assert "planned failure" in res[i].traceback
        with pytest.raises(TypeError, match="failed .*ArithmeticError"):
            res[i]["anything"]
    assert _calls(log) == [0, 1, 2, 3, 4, 5]                       # the other points went on
    assert len(list(store.glob("*.npz"))) == 4                     # failed points are not stored
    msgs = _messages(caplog)
    assert sum("the task failed at params" in m for m in msgs) == 2
    assert any("2 of 6 points failed (indices [1, 4])" in m for m in msgs)
    # a rerun retries the failed points only (they fail again: the task is deterministic)
    (log / "gen").write_text("2")
    caplog.clear()
    again = sweep(faulty_task, params, executor="serial", store=store, progress=False)
    assert again == res and again.failed == [1, 4]
    assert _calls(log, gen=2) == [1, 4]


def test_rerun_after_recorded_failures_computes_only_them(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    flag = tmp_path / "broken"
    flag.write_text("")
    params = [{"x": x, "flag": str(flag), "log_dir": str(log)} for x in range(5)]
    res = sweep(flaky_task, params, executor="serial", store=store, progress=False)
    assert res.failed == [1, 3] and res[0] == 0 and res[2] == 4
    flag.unlink()                                                   # the fault is gone
    (log / "gen").write_text("2")
    again = sweep(flaky_task, params, executor="serial", store=store, progress=False)
    assert again == [0, 1, 4, 9, 16] and again.failed == []
    assert _calls(log, gen=2) == [1, 3]


def flaky_task(x, flag, log_dir):
    """x**2; fails for odd x while the file ``flag`` exists (a transient fault)."""
    return faulty_task(x, log_dir, fail_on=(1, 3) if Path(flag).exists() else ())


def test_duplicate_params_fail_together_and_are_called_once(tmp_path):
    p = {"x": 2, "log_dir": str(tmp_path), "fail_on": (2,)}
    res = sweep(faulty_task, [p, dict(p, x=1), p], executor="serial", progress=False)
    assert res.failed == [0, 2] and res[1] == 1 and res[0] == res[2]
    assert _calls(tmp_path) == [1, 2]


def crashing_task(x):
    """x**2, but the worker process dies at x == 1 (as native code crashing would)."""
    if x == 1:
        os._exit(3)
    return x * x


def test_a_crashed_worker_makes_failed_points_not_a_crashed_sweep(tmp_path):
    store = tmp_path / "store"
    res = sweep(crashing_task, {"x": [0, 1, 2, 3]}, store=store, max_workers=2, progress=False)
    assert 1 in res.failed and res[1].error.startswith("BrokenProcessPool")
    assert res.failed == [i for i, r in enumerate(res) if isinstance(r, FailedPoint)]
    assert all(res[i] == i * i for i in range(4) if i not in res.failed)
    assert len(list(store.glob("*.npz"))) == 4 - len(res.failed)


def test_on_error_raise_keeps_todays_behaviour(tmp_path):
    log = tmp_path / "log"
    log.mkdir()
    params = {"x": [0, 1, 2], "log_dir": [str(log)], "fail_on": [(1,)]}
    with pytest.raises(ArithmeticError, match="planned failure at x = 1") as info:
        sweep(faulty_task, params, executor="serial", on_error="raise", progress=False)
    assert any("the task failed at params" in note for note in info.value.__notes__)
    assert _calls(log) == [0, 1]


@pytest.mark.parametrize("bad", ["ignore", None, 1, "RAISE"])
def test_bad_on_error_is_refused(bad):
    with pytest.raises(ValueError, match=r"on_error must be one of 'record', 'raise', got"):
        sweep(faulty_task, {"x": [1], "log_dir": ["unused"]}, executor="serial", progress=False, on_error=bad)


# ------------------------------------------------------------- damaged or misplaced store files
def _fresh_store(tmp_path, xs):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    params = {"x": list(xs), "log_dir": [str(log)]}
    assert sweep(faulty_task, params, executor="serial", store=store, progress=False) == [x * x for x in xs]
    keys = [param_key({"x": x, "log_dir": str(log)}) for x in xs]
    return log, store, params, keys


def _rerun_recomputes(caplog, log, store, params, keys, bad, reported=None):
    """Rerun; the points ``bad`` (indices) must be recomputed, those ``reported`` (default ``bad``) reported."""
    reported = bad if reported is None else reported
    before = len(_calls(log))
    caplog.clear()
    res = sweep(faulty_task, params, executor="serial", store=store, progress=False)
    assert res == [x * x for x in params["x"]] and res.failed == []
    assert len(_calls(log)) - before == len(bad)
    msgs = _messages(caplog)
    for i in reported:
        assert any(f"store file {keys[i]}.npz refused" in m and "recomputing" in m for m in msgs), msgs
    assert len(msgs) == len(reported)
    assert sorted(r for _, r in load_store(store)) == sorted(x * x for x in params["x"])   # files rewritten


def test_bit_flipped_point_files_are_recomputed_and_reported(tmp_path, caplog):
    caplog.set_level(logging.WARNING, logger=LOGGER)
    log, store, params, keys = _fresh_store(tmp_path, [3])
    name = store / f"{keys[0]}.npz"
    good = name.read_bytes()
    rng = np.random.default_rng(20240611)
    spots = list(rng.integers(0, len(good), size=24)) + [0, len(good) - 1]     # anywhere, both ends too
    for pos, bit in zip(spots, rng.integers(0, 8, size=len(spots))):
        bad = bytearray(good)
        bad[pos] ^= 1 << int(bit)
        name.write_bytes(bytes(bad))
        _rerun_recomputes(caplog, log, store, params, keys, [0])
        assert name.read_bytes() != bytes(bad)


def test_truncated_point_files_are_recomputed_and_reported(tmp_path, caplog):
    caplog.set_level(logging.WARNING, logger=LOGGER)
    log, store, params, keys = _fresh_store(tmp_path, [3])
    name = store / f"{keys[0]}.npz"
    good = name.read_bytes()
    rng = np.random.default_rng(7)
    for size in [0, 1, len(good) - 1, len(good) // 2] + list(rng.integers(2, len(good) - 1, size=8)):
        name.write_bytes(good[:size])
        _rerun_recomputes(caplog, log, store, params, keys, [0])
    name.write_bytes(good + b"\x00")                                       # bytes appended: damaged too
    _rerun_recomputes(caplog, log, store, params, keys, [0])


def test_copied_or_swapped_point_files_are_recomputed_and_reported(tmp_path, caplog):
    caplog.set_level(logging.WARNING, logger=LOGGER)
    log, store, params, keys = _fresh_store(tmp_path, [2, 3, 5, 7])
    files = [store / f"{k}.npz" for k in keys]
    raw = [f.read_bytes() for f in files]
    files[0].write_bytes(raw[1])                                           # one copied over another
    _rerun_recomputes(caplog, log, store, params, keys, [0])
    files[2].write_bytes(raw[3])                                           # two swapped
    files[3].write_bytes(raw[2])
    _rerun_recomputes(caplog, log, store, params, keys, [2, 3])
    os.replace(files[1], files[0])                                         # one renamed over another
    _rerun_recomputes(caplog, log, store, params, keys, [0, 1], reported=[0])       # (1 is just missing)


def test_a_point_file_whose_params_do_not_give_its_key_is_recomputed(tmp_path, caplog):
    from tps_solver.analyses.sweep import StorePoint
    from tps_solver.core import archive

    caplog.set_level(logging.WARNING, logger=LOGGER)
    log, store, params, keys = _fresh_store(tmp_path, [2, 3])
    archive.save(StorePoint(key=keys[0], params={"x": 3, "log_dir": str(log)}, result=9), store / f"{keys[0]}.npz")
    _rerun_recomputes(caplog, log, store, params, keys, [0])


# ------------------------------------------------------------------------- kill -9 of the parent
_SCRIPT = textwrap.dedent("""
    import importlib, sys
    if __name__ == "__main__":
        module, log, store = sys.argv[1:4]
        from tps_solver.analyses.sweep import sweep
        task = importlib.import_module(module).faulty_task
        sweep(task, {"x": list(range(8)), "log_dir": [log], "delay": [0.4]}, store=store, max_workers=2,
              progress=False)
""")


def _proc_stat(pid):
    """(state, ppid, start time) of ``pid`` from /proc, or None when there is no such process."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    fields = text.rsplit(")", 1)[1].split()
    return fields[0], int(fields[1]), fields[19]


def _descendants(root):
    """{pid: start time} of every living descendant of ``root`` (from /proc)."""
    parent = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            st = _proc_stat(int(entry.name))
            if st is not None:
                parent[int(entry.name)] = st
    out, frontier = {}, [root]
    while frontier:
        p = frontier.pop()
        for pid, (_, ppid, start) in parent.items():
            if ppid == p and pid not in out:
                out[pid] = start
                frontier.append(pid)
    return out


def _alive(pid, start):
    st = _proc_stat(pid)
    return st is not None and st[2] == start and st[0] not in ("Z", "X")     # a zombie has exited


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_of_the_parent_leaves_no_workers_and_a_rerun_finishes(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    script = tmp_path / "run_sweep.py"
    script.write_text(_SCRIPT)
    here = Path(__file__).resolve().parent                              # this module, and the package above it
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(here), str(here.parent)] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    with open(tmp_path / "stderr.txt", "wb") as err:
        sub = subprocess.Popen([sys.executable, str(script), faulty_task.__module__, str(log), str(store)],
                               env=env, stdout=subprocess.DEVNULL, stderr=err)
    try:
        deadline = time.monotonic() + 60.0
        while len(list(store.glob("*.npz"))) < 2:                     # the workers are up and computing
            assert sub.poll() is None, (tmp_path / "stderr.txt").read_text()
            assert time.monotonic() < deadline, "the sweep did not start"
            time.sleep(0.05)
        children = _descendants(sub.pid)
        assert len(children) >= 2, children                           # 2 workers (and a resource tracker)
    finally:
        os.kill(sub.pid, signal.SIGKILL)
        sub.wait()
    killed_at = time.monotonic()
    while any(_alive(pid, start) for pid, start in children.items()):
        assert time.monotonic() - killed_at < 10.0, f"orphans left: {[p for p in children if _alive(p, children[p])]}"
        time.sleep(0.1)
    stored = {p.stem for p in store.glob("*.npz")}
    params = {"x": list(range(8)), "log_dir": [str(log)], "delay": [0.4]}
    keys = [param_key({"x": x, "log_dir": str(log), "delay": 0.4}) for x in range(8)]
    assert 2 <= len(stored) < 8 and stored <= set(keys)
    (log / "gen").write_text("2")
    res = sweep(faulty_task, params, store=store, max_workers=2, progress=False)
    assert res == [x * x for x in range(8)] and res.failed == []
    assert _calls(log, gen=2) == [x for x, k in zip(range(8), keys) if k not in stored]
