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
