"""tps_solver.sweep: executors give bit-identical results, the store resumes, bad input is refused."""
import multiprocessing
import uuid
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from tps_solver.analyses.files import load as tps_load
from tps_solver.analyses.sweep import SweepInterrupted, load_store, param_key, param_range, sweep


# ---------------------------------------------------------------- tasks (module level: picklable)
def flat_task(Gamma, e):
    """A pure numeric task (numpy only, so worker processes start fast): LAPACK, libm, reductions."""
    A = np.array([[Gamma, e, 1.0], [e * e, 1.0 / Gamma, np.sin(Gamma)], [np.exp(-e), 0.5, Gamma * e]])
    return np.concatenate((np.linalg.svd(A, compute_uv=False), np.linalg.solve(A, [1.0, e, Gamma]),
                           [np.sum(np.cos(np.linspace(0.0, Gamma, 1001)) ** 2)]))


def counting_task(x, log_dir, fail_on=None):
    """x**2; leaves one file per call in log_dir (tagged by its "gen" file); raises at x == fail_on once."""
    d = Path(log_dir)
    gen = (d / "gen").read_text() if (d / "gen").exists() else "1"
    (d / f"call-{x}-{gen}-{uuid.uuid4().hex}").write_text("")
    if x == fail_on and not (d / "failed-once").exists():
        (d / "failed-once").write_text("")
        raise RuntimeError(f"planned failure at x = {x}")
    return x * x


def _calls(log_dir, gen=None):
    names = [p.name.split("-") for p in Path(log_dir).glob("call-*")]
    return sorted(int(n[1]) for n in names if gen is None or n[2] == str(gen))


GRID = {"Gamma": [2.5, 2.55, 2.6], "e": [0.45, 0.5]}


def _serial_reference():
    return sweep(flat_task, GRID, executor="serial", progress=False)


def _assert_identical(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes()          # bit for bit


# ------------------------------------------------------------------------------- results
def test_serial_results_in_params_order_and_match_direct_calls():
    res = _serial_reference()
    points = [dict(Gamma=G, e=e) for G in GRID["Gamma"] for e in GRID["e"]]    # product, last key fastest
    assert len(res) == 6
    for p, r in zip(points, res):
        assert r.tobytes() == flat_task(**p).tobytes()
    # a list of dicts keeps its own order, duplicates included
    rev = sweep(flat_task, points[::-1] + [points[0]], executor="serial", progress=False)
    _assert_identical(rev, res[::-1] + [res[0]])


def test_process_pool_bit_identical_and_resumable_after_interrupt(tmp_path):
    ref = _serial_reference()
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    params = {"x": list(range(8)), "log_dir": [str(log)]}

    def stop(state):
        if state.iteration == 3:
            raise KeyboardInterrupt

    with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as ex:
        _assert_identical(sweep(flat_task, GRID, executor=ex, progress=False), ref)
        with pytest.raises(SweepInterrupted) as info:
            sweep(counting_task, params, executor=ex, store=store, callback=stop, progress=False)
        assert int(info.value.finished.sum()) == 3 == len(list(store.glob("*.npz")))
    # leaving the block waited for the calls already queued in the workers (they cannot be cancelled)
    (log / "gen").write_text("2")                  # calls of the rerun are tagged 2
    res = sweep(counting_task, params, store=store, max_workers=1, progress=False)    # the default pool
    assert res == [x * x for x in range(8)]
    stored_first = sorted(x for x in range(8) if info.value.finished[x])
    assert _calls(log, gen=2) == sorted(set(range(8)) - set(stored_first))


def test_thread_pool_matches_serial_and_the_callers_blas_pools_are_left_alone():
    threadpoolctl = pytest.importorskip("threadpoolctl")
    before = [d["num_threads"] for d in threadpoolctl.threadpool_info()]
    ref = _serial_reference()
    with ThreadPoolExecutor(max_workers=2) as ex:
        _assert_identical(sweep(flat_task, GRID, executor=ex, progress=False), ref)
    assert [d["num_threads"] for d in threadpoolctl.threadpool_info()] == before


def test_dask_local_cluster_is_bit_identical_to_serial():
    distributed = pytest.importorskip("dask.distributed")
    ref = _serial_reference()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        via_executor = sweep(flat_task, GRID, executor=client.get_executor(), progress=False)
        via_client = sweep(flat_task, GRID, executor=client, progress=False)
    _assert_identical(via_executor, ref)
    _assert_identical(via_client, ref)


# ---------------------------------------------------------------------------- the store
def test_rerun_after_a_task_failure_computes_only_the_missing_points(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    params = {"x": [1, 2, 3, 4, 5, 6], "log_dir": [str(log)], "fail_on": [4]}
    with pytest.raises(RuntimeError, match="planned failure at x = 4") as info:
        sweep(counting_task, params, executor="serial", store=store, progress=False, on_error="raise")
    assert any("3 of 6 finished points kept" in note for note in info.value.__notes__)
    assert _calls(log) == [1, 2, 3, 4]
    assert len(list(store.glob("*.npz"))) == 3
    res = sweep(counting_task, params, executor="serial", store=store, progress=False)
    assert res == [1, 4, 9, 16, 25, 36]
    assert _calls(log) == [1, 2, 3, 4, 4, 5, 6]          # the rerun called the task for 4, 5, 6 only
    assert sweep(counting_task, params, executor="serial", store=store, progress=False) == res
    assert len(_calls(log)) == 7                           # a finished sweep calls nothing
    assert sorted(r for _, r in load_store(store)) == sorted(res)


def test_keyboard_interrupt_keeps_finished_points_and_rerun_finishes(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    params = [{"x": x, "log_dir": str(log)} for x in range(6)]
    seen = []

    def stop_after_two(state):
        seen.append((state.iteration, state.total, state.params["x"], state.result))
        if state.iteration == 2:
            raise KeyboardInterrupt

    with pytest.raises(SweepInterrupted) as info:
        sweep(counting_task, params, executor="serial", store=store, callback=stop_after_two, progress=False)
    exc = info.value
    assert isinstance(exc, KeyboardInterrupt)
    assert exc.results == [0, 1, None, None, None, None]
    assert exc.finished.tolist() == [True, True, False, False, False, False]
    assert "after 2 of 6 points" in str(exc) and Path(exc.store) == store
    assert seen == [(1, 6, 0, 0), (2, 6, 1, 1)]
    seen.clear()
    res = sweep(counting_task, params, executor="serial", store=store, callback=lambda s: seen.append((s.iteration,)),
                progress=False)
    assert res == [x * x for x in range(6)]
    assert _calls(log) == [0, 1, 2, 3, 4, 5]               # each point computed exactly once overall
    assert [s[0] for s in seen] == [3, 4, 5, 6]            # done counts the stored points too


def test_store_files_are_complete_archives_keyed_by_params(tmp_path):
    store = tmp_path / "s"
    sweep(flat_task, {"Gamma": [2.5], "e": [0.45]}, executor="serial", store=store, progress=False)
    files = sorted(p.name for p in store.iterdir())
    key = param_key({"Gamma": 2.5, "e": 0.45})
    assert files == [f"{key}.npz", "sweep.json"]            # no temporary files left
    rec = tps_load(store / f"{key}.npz", kind="StorePoint")
    assert rec.key == key
    assert rec["params"] == {"Gamma": 2.5, "e": 0.45}
    assert rec["result"].tobytes() == flat_task(2.5, 0.45).tobytes()
    assert load_store(store)[0][0] == {"Gamma": 2.5, "e": 0.45}
    with pytest.raises(ValueError, match="store .* holds results of task"):
        sweep(counting_task, {"x": [1], "log_dir": [str(tmp_path)]}, executor="serial", store=store,
              progress=False)


def test_param_key_is_stable_and_type_exact():
    k = param_key({"Gamma": 2.5, "e": 0.45, "M": 2, "model": "point", "cutoff": None})
    assert k == "5c73e9c7e99b7bcabfb4cb8dcf848192"             # pinned: keys must not change across versions
    assert param_key({"M": 2}) != param_key({"M": 2.0})
    assert param_key({"a": np.arange(3.0)}) == param_key({"a": np.arange(3.0)})
    assert param_key({"a": np.arange(3.0)}) != param_key({"a": np.arange(3)})
    with pytest.raises(ValueError, match=r"params\['f'\] has type"):
        param_key({"f": object()})


def test_progress_bar_and_callback_run(capsys):
    pytest.importorskip("tqdm")
    got = []
    res = sweep(flat_task, GRID, executor="serial", progress=True, callback=lambda s: got.append((s.iteration, s.total)))
    assert len(res) == 6 and got == [(i, 6) for i in range(1, 7)]
    assert "6/6" in capsys.readouterr().err


# ------------------------------------------------------------------------------ bad input
@pytest.mark.parametrize("params, match", [
    ([], "at least one parameter dict"),
    ({}, "non-empty dict"),
    ({"Gamma": []}, r"params\['Gamma'\] must hold at least one value"),
    ({"Gamma": [2.5, float("nan")]}, r"params\['Gamma'\] must be finite"),
    ({"Gamma": np.array([2.5, np.inf])}, r"params\['Gamma'\] must be finite"),
    ([{"e": 0.45}, {"e": float("inf")}], r"params\[1\]\['e'\] must be finite"),
    ({"Gamma": 2.5}, r"params\['Gamma'\] must be a list"),
    ([0.45], r"params\[0\] must be a dict"),
])
def test_bad_params_raise_naming_the_parameter(params, match):
    with pytest.raises(ValueError, match=match):
        sweep(flat_task, params, executor="serial", progress=False)


@pytest.mark.parametrize("executor", [42, "threads", object()])
def test_an_executor_that_is_not_one_is_refused(executor):
    with pytest.raises(ValueError, match="executor must be None, 'serial', a concurrent.futures.Executor"):
        sweep(flat_task, GRID, executor=executor, progress=False)


def test_other_bad_arguments():
    with pytest.raises(ValueError, match="task must be a callable"):
        sweep(3, GRID, executor="serial")
    with pytest.raises(ValueError, match="task must be picklable"):
        sweep(lambda Gamma, e: Gamma, GRID, max_workers=1, progress=False)
    with pytest.raises(ValueError, match="callback must be callable"):
        sweep(flat_task, GRID, executor="serial", callback=1)
    with pytest.raises(ValueError, match="max_workers must be an integer >= 1"):
        sweep(flat_task, GRID, max_workers=0)
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        sweep(flat_task, GRID, executor="serial", threads=0)


def test_param_range():
    assert param_range(0.0, 0.3, 0.1, "e") == [0.0, 0.1, 0.2, 0.3]
    assert param_range(2.5, 2.5, 0.1, "Gamma") == [2.5]
    for step in (0.0, -0.1, float("nan")):
        with pytest.raises(ValueError, match="Gamma: step must be a finite number > 0"):
            param_range(2.3, 2.7, step, "Gamma")
    with pytest.raises(ValueError, match="Gamma: stop must be >= start"):
        param_range(2.7, 2.3, 0.1, "Gamma")
    with pytest.raises(ValueError, match="Gamma: start must be a finite real number"):
        param_range(float("inf"), 2.3, 0.1, "Gamma")


def test_damaged_or_misplaced_point_files_are_recomputed(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    params = {"x": [0, 1, 2, 3], "log_dir": [str(log)]}
    first = sweep(counting_task, params, executor="serial", store=store, progress=False)
    keys = [param_key({"x": x, "log_dir": str(log)}) for x in range(4)]
    raw = (store / f"{keys[0]}.npz").read_bytes()
    (store / f"{keys[0]}.npz").write_bytes(raw[: len(raw) // 2])                 # truncated
    flipped = bytearray((store / f"{keys[1]}.npz").read_bytes())
    flipped[len(flipped) // 3] ^= 0x04
    (store / f"{keys[1]}.npz").write_bytes(bytes(flipped))                      # a flipped byte
    (store / f"{keys[2]}.npz").write_bytes((store / f"{keys[3]}.npz").read_bytes())   # copied over
    with pytest.raises(ValueError, match="cannot be read|holds the point"):
        load_store(store)
    again = sweep(counting_task, params, executor="serial", store=store, progress=False)
    assert again == first == [0, 1, 4, 9]
    assert _calls(log, gen=None).count(3) == 1 and sorted(_calls(log)) == [0, 0, 1, 1, 2, 2, 3]
    assert sorted(r for _, r in load_store(store)) == [0, 1, 4, 9]
