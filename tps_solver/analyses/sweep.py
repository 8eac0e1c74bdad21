r"""Parameter sweeps on any :class:`concurrent.futures.Executor`, resumable through a store.

:func:`sweep` evaluates a pure task ``task(**p)`` for every parameter dict
``p`` and returns the results in the order of the parameters:

* **Executors.**  ``executor=None`` (default) runs a local process pool
  (``spawn`` start method, so it is safe next to threads); ``"serial"`` runs in
  this process; any :class:`concurrent.futures.Executor` is used as given (and
  not shut down); a ``dask.distributed.Client`` is served through
  ``client.get_executor()`` (``pip install tps-solver[dask]``).  Tasks and
  results travel by pickle, so the task must be a module-level function (or
  another picklable callable) of keyword arguments.
* **Store.**  ``store=path`` is a directory holding one small file per finished
  point, ``<key>.npz``, a result file of :mod:`tps_solver.core.archive` (sealed by a SHA-256,
  no pickles) holding the point's ``key``, ``params`` and ``result`` (a result of the package
  by its codec; numbers, strings, arrays, lists, tuples and dicts of them by the generic
  encoder; anything else cannot be stored and is an error), where ``key`` is a
  SHA-256 of a canonical encoding of ``p`` (floats by their exact hex form,
  arrays by dtype, shape and bytes).  Files are written atomically (a
  temporary file in the same directory, then :func:`os.replace`) by the calling
  process as results arrive, so an interrupted sweep leaves only complete
  points behind and a rerun computes only the missing ones.  ``sweep.json``
  records the task's name; a store written by another task is refused, and a damaged
  ``sweep.json`` is named in a ``ValueError``.  A damaged
  point file, or one copied over another point's (its stored key differs), is reported
  on the ``tps_solver.sweep`` logger and the point is computed again.
* **Progress.**  A tqdm bar when tqdm is installed (``pip install
  tps-solver[progress]``), otherwise log records on the ``tps_solver``
  logger (:class:`tps_solver.core.progress.Progress`, the package's one progress display); ``callback(state)`` is called in this process
  after every computed point.
* **Interruption.**  A ``KeyboardInterrupt`` (Ctrl-C, or raised by the
  callback) cancels the points not yet started, terminates the workers of the
  default pool (a point that hangs or spins included, so the process can exit) and raises
  :class:`SweepInterrupted`, a ``KeyboardInterrupt`` carrying the partial
  results; the finished points are in the store.  With ``on_error="raise"``
  an exception raised by the task cancels the points not yet started, waits
  for the running ones, stores every finished point and is re-raised with a
  note naming the failing point.  If the calling process is killed outright
  (``kill -9``, the out-of-memory killer), the workers of the default pool
  notice that their parent is gone within about a second and exit (a
  daemon thread of each worker polls :func:`os.getppid`; POSIX, and only
  while the task releases the GIL now and then, as Python code and most
  NumPy calls do); the points stored so far are kept, and a rerun computes
  the rest.  Workers of an executor passed in are the executor's business.
* **Faults.**  With ``on_error="record"`` (the default) a point whose task
  raises an ``Exception`` (or calls ``sys.exit``: a :class:`TaskExit`) is a failed point: its place in the results holds a
  :class:`FailedPoint` (its ``params`` and the ``error`` as
  ``"Type: message"``), the other points go on, whatever the executor, and
  the failure is reported on the ``tps_solver.sweep`` logger (one record per
  failed point and a summary at the end; no :mod:`warnings`).  The results
  are a :class:`SweepResults`, a ``list`` whose ``failed`` attribute lists the
  indices of the failed points.  Failed points are never stored, so a rerun
  retries them.  Faults of the sweep itself (a result that cannot be stored,
  a full disk, a callback that raises) are not points' failures: they stop
  the sweep as with ``on_error="raise"``.  A worker process that dies (a
  crash of native code) breaks a process pool: the points it could not
  finish are failed points too.  A store file that is damaged (bit flips,
  truncation: the SHA-256 seal or the zip structure no longer checks) or
  that holds another point (copied or renamed over this one: its stored key,
  or the key of its stored params, differs) is never returned: it is
  reported on the ``tps_solver.sweep`` logger and the point is computed
  again (and its file rewritten).
* **Threads.**  With ``threads=n`` (default 1 when threadpoolctl is installed,
  ``pip install tps-solver[threads]``) every worker *process* caps its
  BLAS/OpenMP pools at ``n`` threads before running a task, and a serial sweep
  runs under ``threadpoolctl.threadpool_limits(n)`` (restored afterwards).
  On few cores multithreaded BLAS inside parallel workers only
  oversubscribes, and one thread count everywhere keeps BLAS reductions, and
  so the results, bit-identical whatever the executor.  Thread-based
  executors (``ThreadPoolExecutor``, Dask with ``processes=False``) share the
  caller's pools, which are left alone.
"""
import concurrent.futures as cf
import contextlib
import hashlib
import itertools
import json
import logging
import math
import multiprocessing
import numbers
import os
import pickle
import tempfile
import threading
import time
import traceback
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tps_solver.core import archive
from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_int, check_real
from tps_solver.core.costs import check_cost
from tps_solver.model.restitution import RestitutionLaw
from tps_solver.core.progress import Progress, progress_state

__all__ = ["sweep", "param_range", "param_key", "load_store", "SweepInterrupted", "SweepResults", "FailedPoint"]

_LOG = logging.getLogger("tps_solver.sweep")
_MANIFEST = "sweep.json"
_STORE_FORMAT = 2
_ON_ERROR = ("record", "raise")
_PARENT_POLL = 0.5                  # seconds between two checks of a default-pool worker that its parent lives
# The sweep's own cost per point (not the task's), measured on the project machine and halved (lower
# bounds): its key (SHA-256 of the canonical params, 15 us), a parameter dict of the product (about
# 1 kB with its key), a sealed store file (0.65 ms), a serial point's BLAS-thread cap (0.4 ms).
_KEY_SECONDS = 7e-6
_POINT_BYTES = 1000.0
_STORE_SECONDS = 3e-4
_THREADS_SECONDS = 2e-4


class StorePoint(Bunch):
    """One finished point of a sweep store: ``key``, ``params``, ``result`` (internal)."""


archive.register("StorePoint", StorePoint)


class SweepInterrupted(KeyboardInterrupt):
    """Raised by :func:`sweep` on ``KeyboardInterrupt``; carries the partial results.

    Attributes
    ----------
    results : list
        In the order of the parameters; ``None`` where a point did not finish.
    finished : ndarray of bool, shape (n_points,)
        True where ``results`` holds a finished point.
    store : pathlib.Path or None
        The store holding every finished point (rerun :func:`sweep` to finish).

    Examples
    --------
    >>> def area(width, height):
    ...     if width > 1.5:
    ...         raise KeyboardInterrupt             # as if Ctrl-C were pressed here
    ...     return width * height
    >>> try:
    ...     sweep(area, {"width": [1.0, 2.0], "height": [3.0]}, executor="serial", progress=False)
    ... except SweepInterrupted as exc:
    ...     print(exc.results, exc.finished.tolist(), exc.store)
    [3.0, None] [True, False] None
    """

    def __init__(self, message, results, finished, store):
        super().__init__(message)
        self.results = results
        self.finished = finished
        self.store = store


@dataclass(frozen=True, eq=True)
class FailedPoint:
    """A point of a :func:`sweep` whose task raised (``on_error="record"``); stands in for its result.

    Failed points are not stored: a rerun of the sweep on the same store
    retries them.  Indexing one raises a ``TypeError`` naming the point and
    its error, so code that expected a result fails with the reason.

    Attributes
    ----------
    params : dict
        The keyword arguments of the failed call.
    error : str
        The exception raised, as ``"Type: message"``.
    traceback : str
        The formatted traceback (for a worker process, with the worker's
        traceback as the cause); not part of ``repr`` or equality.

    Examples
    --------
    >>> def inverse(x):
    ...     return 1.0 / x
    >>> res = sweep(inverse, {"x": [2.0, 0.0]}, executor="serial", progress=False)
    >>> res
    [0.5, FailedPoint(params={'x': 0.0}, error='ZeroDivisionError: float division by zero')]
    >>> res.failed, res[1].error
    ([1], 'ZeroDivisionError: float division by zero')
    """

    params: dict
    error: str
    traceback: str = field(default="", repr=False, compare=False)

    @classmethod
    def from_exception(cls, params, exc):
        """The failed point ``params`` that raised ``exc`` (internal helper of :func:`sweep`).

        Examples
        --------
        >>> FailedPoint.from_exception({"x": 1}, ValueError("bad x")).error
        'ValueError: bad x'
        """
        text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
        return cls(dict(params), f"{type(exc).__name__}: {exc}", text)

    def __getitem__(self, item):
        raise TypeError(f"the sweep point params = {self.params!r} failed ({self.error}) and has no result "
                        f"to index with {item!r}; check results.failed, or pass on_error='raise' to sweep()")


class SweepResults(list):
    """The results of :func:`sweep`: a ``list`` in the order of the parameters, plus ``failed``.

    Compares equal to a plain list of the same items.

    Attributes
    ----------
    failed : list of int
        Increasing indices of the points whose task raised; their items are
        :class:`FailedPoint` (empty when every point succeeded).

    Examples
    --------
    >>> def root(x):
    ...     if x < 0:
    ...         raise ValueError(f"x = {x} < 0")
    ...     return x ** 0.5
    >>> res = sweep(root, {"x": [4.0, -1.0, 9.0]}, executor="serial", progress=False)
    >>> res.failed, res[0], res[2], res[1].error
    ([1], 2.0, 3.0, 'ValueError: x = -1.0 < 0')
    >>> sweep(root, {"x": [4.0]}, executor="serial", progress=False) == [2.0]
    True
    """

    def __init__(self, items=()):
        super().__init__(items)
        self.failed = []


# ------------------------------------------------------------------ parameters
def param_range(start, stop, step, name="value"):
    """The grid ``start, start + step, ...`` up to ``stop`` (included to 1e-9 steps), as a list.

    Values are rounded to 12 digits below the leading digit of ``step``, so
    ``2.3 + 0.1`` gives ``2.4`` (and the store key of 2.4).

    Parameters
    ----------
    start, stop : float
        Finite, ``stop >= start``.
    step : float
        Finite, > 0.
    name : str
        The parameter's name, used in error messages.

    Returns
    -------
    values : list of float

    Examples
    --------
    >>> param_range(2.3, 2.7, 0.1, "Gamma")
    [2.3, 2.4, 2.5, 2.6, 2.7]
    >>> param_range(2.3, 2.7, 0.0, "Gamma")
    Traceback (most recent call last):
    ...
    ValueError: Gamma: step must be a finite number > 0, got 0.0
    """
    start = check_real(start, f"{name}: start")
    stop = check_real(stop, f"{name}: stop")
    if not isinstance(step, numbers.Real) or not math.isfinite(step) or step <= 0:
        raise ValueError(f"{name}: step must be a finite number > 0, got {step!r}")
    if stop < start:
        raise ValueError(f"{name}: stop must be >= start = {start}, got {stop} (an empty range)")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    digits = max(0, 12 - math.floor(math.log10(step)))     # drop the round-off of k * step, keep 12 digits of step
    return [float(round(start + k * step, digits)) for k in range(n)]


def _check_value(value, where):
    """Reject non-finite numbers anywhere inside a parameter value."""
    if isinstance(value, (bool, np.bool_, str)) or value is None:
        return
    if isinstance(value, numbers.Number):
        if not np.isfinite(value):
            raise ValueError(f"{where} must be finite, got {value!r}")
        return
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc" and not np.all(np.isfinite(value)):
            raise ValueError(f"{where} must contain only finite values (no NaN or inf)")
        return
    if isinstance(value, (list, tuple)):
        for v in value:
            _check_value(v, where)
        return
    if isinstance(value, dict):
        for k, v in value.items():
            _check_value(v, f"{where}[{k!r}]")


def _expand(params):
    """Validate ``params`` (list of dicts, or dict of lists meaning their product) -> list of dicts."""
    if isinstance(params, dict):
        if not params:
            raise ValueError("params must be a non-empty dict of non-empty lists, got {}")
        keys, values = [], []
        for key, vals in params.items():
            if not isinstance(key, str):
                raise ValueError(f"params keys must be str (keyword names), got {key!r}")
            if isinstance(vals, np.ndarray):
                vals = list(vals) if vals.ndim == 1 else None
            elif isinstance(vals, (list, tuple, range)):
                vals = list(vals)
            else:
                vals = None
            if vals is None:
                raise ValueError(f"params[{key!r}] must be a list (or 1-D array) of values, "
                                 f"got {type(params[key]).__name__}")
            if not vals:
                raise ValueError(f"params[{key!r}] must hold at least one value (an empty range)")
            for v in vals:
                _check_value(v, f"params[{key!r}]")
            keys.append(key)
            values.append(vals)
        n_points = math.prod(len(v) for v in values)
        check_cost("sweep", "params (the product of the lists' lengths)", n_points, _POINT_BYTES * n_points,
                   _KEY_SECONDS * n_points, hint="sweep fewer values, or several smaller sweeps into one store")
        return [dict(zip(keys, combo)) for combo in itertools.product(*values)]
    if not isinstance(params, (list, tuple)):
        raise ValueError(f"params must be a list of dicts or a dict of lists, got {type(params).__name__}")
    if not params:
        raise ValueError("params must hold at least one parameter dict, got an empty list")
    out = []
    for i, p in enumerate(params):
        if not isinstance(p, dict):
            raise ValueError(f"params[{i}] must be a dict of keyword arguments, got {type(p).__name__}")
        for key, v in p.items():
            if not isinstance(key, str):
                raise ValueError(f"params[{i}] keys must be str (keyword names), got {key!r}")
            _check_value(v, f"params[{i}][{key!r}]")
        out.append(dict(p))
    return out


def _canonical(value, where):
    """A JSON-able encoding of ``value`` that is stable across runs and platforms."""
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)):
        return {"b": bool(value)}
    if isinstance(value, numbers.Integral):
        return {"i": int(value)}
    if isinstance(value, numbers.Real):
        return {"f": float(value).hex()}
    if isinstance(value, numbers.Complex):
        return {"c": [float(value.real).hex(), float(value.imag).hex()]}
    if isinstance(value, str):
        return {"s": value}
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biufc":
            raise ValueError(f"{where} is an array of dtype {value.dtype}; only numeric arrays can be keyed")
        arr = np.ascontiguousarray(value)
        return {"a": [arr.dtype.str, list(arr.shape), hashlib.sha256(arr.tobytes()).hexdigest()]}
    if isinstance(value, (list, tuple)):
        return {"l": [_canonical(v, where) for v in value]}
    if isinstance(value, dict):
        return {"d": [[str(k), _canonical(v, f"{where}[{k!r}]")] for k, v in sorted(value.items(), key=str)]}
    if isinstance(value, RestitutionLaw) and value.parameters:
        return {"law": [type(value).__name__, _canonical(value.parameters, where)]}
    raise ValueError(f"{where} has type {type(value).__name__}, which cannot be keyed in a store "
                     f"(use numbers, str, bool, None, numeric arrays, or lists/dicts of them)")


def param_key(p):
    """Stable hash of a parameter dict: the name of its file in a store.

    Parameters
    ----------
    p : dict
        Keyword arguments of one task call.

    Returns
    -------
    key : str
        32 hex digits; equal dicts (same keys, same values bit for bit, same
        types) give equal keys in every run.

    Examples
    --------
    >>> param_key({"Gamma": 2.5, "e": 0.45}) == param_key({"e": 0.45, "Gamma": 2.5})
    True
    >>> param_key({"Gamma": 2.5}) == param_key({"Gamma": 2.5000000000000004})
    False
    """
    if not isinstance(p, dict):
        raise ValueError(f"p must be a dict of keyword arguments, got {type(p).__name__}")
    enc = _canonical(p, "params")
    return hashlib.sha256(json.dumps(enc, sort_keys=True).encode()).hexdigest()[:32]


# ------------------------------------------------------------------- the store
def _check_overhead(params, store, executor, threads):
    """Refuse a sweep whose own overhead (keys, store files, thread caps) is out of reach, before
    its points are expanded (the task's cost is the task's business)."""
    if isinstance(params, dict) and all(hasattr(v, "__len__") for v in params.values()):
        n = math.prod(len(v) for v in params.values())
    elif isinstance(params, (list, tuple)):
        n = len(params)
    else:
        return                                      # malformed: _expand says how
    n_new = n
    if store is not None and Path(store).is_dir():  # points already stored cost only their key
        n_new = max(n - sum(1 for f in os.scandir(store) if f.name.endswith(".npz")), 0)
    serial = isinstance(executor, str) and executor == "serial"
    check_cost("sweep", "params (the number of points)", n, _POINT_BYTES * n,
               _KEY_SECONDS * n + n_new * ((_STORE_SECONDS if store is not None else 0.0)
                                           + (_THREADS_SECONDS if serial and threads is not None else 0.0)),
               hint="the sweep's own cost per point: its key, its store file, a serial point's thread "
                    "cap; sweep fewer points, or several smaller sweeps into one store")


def _task_name(task):
    func = getattr(task, "func", task)          # functools.partial
    name = f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', type(func).__name__)}"
    if func is not task:
        name += "(partial " + repr(sorted(getattr(task, "keywords", {}).items())) + ")"
    return name


def _open_store(store, task):
    path = Path(store)
    if path.exists() and not path.is_dir():
        raise ValueError(f"store must be a directory (or a path to create), got the file {str(path)!r}")
    path.mkdir(parents=True, exist_ok=True)
    manifest = path / _MANIFEST
    name = _task_name(task)
    if manifest.exists():
        try:
            info = json.loads(manifest.read_text())
            if not isinstance(info, dict):
                raise ValueError(f"a JSON object was expected, got {type(info).__name__}")
        except (ValueError, UnicodeDecodeError) as exc:   # json.JSONDecodeError is a ValueError
            raise ValueError(f"store {str(path)!r}: its index {str(manifest)!r} is damaged ({exc}); the point "
                             f"files are checked one by one, so delete {_MANIFEST} to reuse them for this task, "
                             "or use another store directory") from None
        if info.get("task") != name:
            raise ValueError(f"store {str(path)!r} holds results of task {info.get('task')!r}, "
                             f"not {name!r}; use another store directory")
    else:
        _atomic_write(path, _MANIFEST, json.dumps({"task": name, "format": _STORE_FORMAT}).encode())
    return path


def _atomic_write(directory, filename, data):
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{filename}.", suffix=f".{uuid.uuid4().hex[:8]}.tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, directory / filename)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _load_point(name):
    # the codecs of the result types stored are those of the modules imported in this process
    # (tps_solver.analyses.files imports them all; it cannot be imported here: basins uses sweep)
    try:
        return archive.load(name, kind="StorePoint")
    except ValueError as exc:
        if "unknown kind of result" in str(exc):
            raise ValueError(f"{exc}; import tps_solver.analyses.files (or the module of that result type) "
                             f"before reading the store") from None
        raise


def _read_point(path, key):
    name = path / f"{key}.npz"
    if not name.exists():
        return False, None
    try:
        rec = _load_point(name)
        if rec.key != key:
            raise ValueError(f"{name} holds the point {rec.key}, not {key} (a file copied over another)")
        if param_key(rec.params) != key:
            raise ValueError(f"{name} holds params whose key is {param_key(rec.params)}, not {key}")
    except ValueError as exc:     # a damaged or misplaced file: report it and recompute the point
        _LOG.warning("store file %s.npz refused (%s); recomputing the point", key, exc)
        return False, None
    return True, rec.result


def load_store(store):
    """Every finished point of a store.

    Parameters
    ----------
    store : str or os.PathLike
        A directory written by :func:`sweep`.

    Returns
    -------
    points : list of (dict, object)
        ``(params, result)`` pairs, sorted by key (not in any sweep's order).

    Examples
    --------
    >>> import tempfile
    >>> def area(width, height):
    ...     return width * height
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = sweep(area, {"width": [2.0], "height": [3.0, 5.0]}, executor="serial", store=d, progress=False)
    ...     print(sorted(result for _, result in load_store(d)))
    [6.0, 10.0]
    >>> load_store(".")
    Traceback (most recent call last):
    ...
    ValueError: store must be a directory written by sweep(), got '.'
    """
    path = Path(store)
    if not (path / _MANIFEST).exists():
        raise ValueError(f"store must be a directory written by sweep(), got {str(store)!r}")
    out = []
    for f in sorted(path.glob("*.npz")):
        rec = _load_point(f)
        if f.name != f"{rec.key}.npz":
            raise ValueError(f"{f} holds the point {rec.key} (a file copied over another); rerun sweep() "
                             f"to compute it again")
        out.append((rec.params, rec.result))
    return out


# ------------------------------------------------------------------- execution
def _run(task, params, threads, caller_pid):
    """Run one point: ``task(**params)``; in a worker process, first cap its BLAS threads.

    The cap is set (not restored) only in processes other than the caller's,
    so thread-based executors never change the caller's thread pools.
    """
    if threads is not None and os.getpid() != caller_pid:
        from threadpoolctl import threadpool_limits
        threadpool_limits(limits=threads)
    return _call(task, params)


class TaskExit(RuntimeError):
    """A task called ``sys.exit`` (raised ``SystemExit``): a failure of its point, not the sweep's end."""


def _call(task, params):
    """``task(**params)``, with ``SystemExit`` turned into :class:`TaskExit` (an ``Exception``)."""
    try:
        return task(**params)
    except SystemExit as exc:
        raise TaskExit(f"the task called sys.exit({exc.code!r})") from None


def _terminate_workers(ex):
    """Terminate the worker processes of an owned process pool (a hung or spinning point included).

    ``shutdown(wait=False)`` leaves running workers alive, and the interpreter's exit joins them:
    a point that never returns would keep the process from exiting.
    """
    procs = list((getattr(ex, "_processes", None) or {}).values())
    ex.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(5.0)
        if proc.is_alive():
            proc.kill()
            proc.join(5.0)


def _watch_parent(parent_pid):
    """Initializer of the default pool's workers: exit (``os._exit``) as soon as the parent is gone.

    A daemon thread polls :func:`os.getppid` every half second; a killed
    parent (``kill -9``) reparents the worker, which then exits instead of
    running on as an orphan.
    """
    def watch():
        while True:
            if os.getppid() != parent_pid:
                os._exit(1)
            time.sleep(_PARENT_POLL)

    threading.Thread(target=watch, name="tps_solver-sweep-parent-watch", daemon=True).start()


def _limits(threads):
    """Context capping this process's BLAS threads (serial runs), or a no-op."""
    if threads is None:
        return contextlib.nullcontext()
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=threads)


def _resolve_threads(threads):
    try:
        import threadpoolctl  # noqa: F401
        have = True
    except ImportError:
        have = False
    if isinstance(threads, str) and threads == "auto":
        return 1 if have else None
    if threads is None:
        return None
    threads = check_int(threads, "threads", minimum=1)
    if not have:
        raise ValueError("threads needs threadpoolctl (pip install tps-solver[threads]); "
                         "pass threads=None to leave BLAS threads alone")
    return threads


def _resolve_executor(executor, max_workers):
    """-> (executor or None for serial, owned)."""
    if isinstance(executor, str):
        if executor != "serial":
            raise ValueError(f"executor must be None, 'serial', a concurrent.futures.Executor or a "
                             f"dask.distributed.Client, got {executor!r}")
        return None, False
    if executor is None:
        workers = (os.cpu_count() or 1) if max_workers is None else check_int(max_workers, "max_workers")
        return cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                      initializer=_watch_parent, initargs=(os.getpid(),)), True
    if isinstance(executor, cf.Executor):
        return executor, False
    if callable(getattr(executor, "get_executor", None)) and callable(getattr(executor, "submit", None)):
        return executor.get_executor(), False           # dask.distributed.Client
    raise ValueError(f"executor must be None, 'serial', a concurrent.futures.Executor or a "
                     f"dask.distributed.Client, got {type(executor).__name__}")


def sweep(task, params, executor=None, store=None, *, callback=None, progress=None, max_workers=None,
          threads="auto", on_error="record"):
    """Evaluate ``task(**p)`` for every parameter dict ``p``, in parallel and resumably.

    Parameters
    ----------
    task : callable
        A pure function of keyword arguments; picklable (a module-level
        function) unless ``executor="serial"``.  Equal parameters must give
        equal results: finished points are reused from ``store``.
    params : list of dict, or dict of lists
        The points.  A dict of lists means their Cartesian product, in
        ``itertools.product`` order (the last key varies fastest).  Values
        must be finite; see :func:`param_range` for stepped ranges.
    executor : None, "serial", concurrent.futures.Executor or dask.distributed.Client
        ``None``: a local process pool of ``max_workers`` (default
        ``os.cpu_count()``) spawned processes, shut down at the end (a
        script that uses it needs the ``if __name__ == "__main__":`` guard);
        ``"serial"``: this process, in order; an executor is used as given
        (a ``ProcessPoolExecutor``, ``client.get_executor()``, ...); a Dask
        ``Client`` is replaced by ``client.get_executor()``.
    store : str or os.PathLike, optional
        Directory of finished points (module docstring); points found there
        are not recomputed.
    callback : callable, optional
        ``callback(state)`` after every computed point, in this process: a
        :class:`~tps_solver.core.progress.ProgressState` with stage ``"sweep"``, ``iteration`` the points done (those
        loaded from the store too), ``total``, ``fraction``, ``params`` and ``result``.
    progress : bool, optional
        Show progress (tqdm if installed, else ``logging``); default True.
    max_workers : int, optional
        Size of the default process pool.
    threads : "auto", int or None
        BLAS/OpenMP threads per task via threadpoolctl; ``"auto"``: 1 if
        threadpoolctl is installed, else unlimited; ``None``: leave alone.
    on_error : {"record", "raise"}
        What a task that raises an ``Exception`` does: ``"record"`` (default)
        makes its point a :class:`FailedPoint` (not stored, logged on the
        ``tps_solver.sweep`` logger) and the sweep goes on; ``"raise"``
        stops the sweep and re-raises it (module docstring, "Interruption").
        The progress bar counts failed points; ``callback`` is not called
        for them.

    Returns
    -------
    results : SweepResults
        A ``list``: ``task(**p)`` for every ``p``, in the order of ``params``,
        a :class:`FailedPoint` where the task raised; ``results.failed`` lists
        those indices.

    Raises
    ------
    SweepInterrupted
        On ``KeyboardInterrupt``; ``exc.results`` holds the partial results.
    ValueError
        On bad input: empty or non-finite parameters, a non-callable task, an
        executor that is not one, an ``on_error`` that is not one of its values; a sweep whose
        own cost (a key per point, a store file per new point, a serial point's thread cap:
        :func:`tps_solver.core.costs.check_cost`) is out of reach, before any point is expanded.
    Exception
        With ``on_error="raise"``, whatever the task raised, after the
        finished points were stored; whatever the store or the callback
        raised.

    Examples
    --------
    >>> def area(width, height):
    ...     return width * height
    >>> sweep(area, {"width": [1.0, 2.0], "height": [3.0, 5.0]}, executor="serial", progress=False)
    [3.0, 5.0, 6.0, 10.0]
    >>> sweep(area, [{"width": 2.0, "height": 0.5}], executor="serial", progress=False)
    [1.0]
    """
    if not callable(task):
        raise ValueError(f"task must be a callable of keyword arguments, got {type(task).__name__}")
    _check_overhead(params, store, executor, threads)
    points = _expand(params)
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable(done, total, params, result), got {type(callback).__name__}")
    if progress is not None and not isinstance(progress, (bool, np.bool_)):
        raise ValueError(f"progress must be True, False or None, got {progress!r}")
    if not isinstance(on_error, str) or on_error not in _ON_ERROR:
        raise ValueError(f"on_error must be one of {', '.join(map(repr, _ON_ERROR))}, got {on_error!r}")
    threads = _resolve_threads(threads)
    if max_workers is not None:
        check_int(max_workers, "max_workers")
    ex, owned = _resolve_executor(executor, max_workers)
    if ex is not None and (owned or isinstance(ex, cf.ProcessPoolExecutor)):
        try:
            pickle.dumps(task)
        except Exception as exc:
            if owned:
                ex.shutdown(wait=False)
            raise ValueError(f"task must be picklable to run in worker processes (a module-level function, "
                             f"not a lambda or closure), got {task!r}: {exc}") from None
    path = _open_store(store, task) if store is not None else None
    keys = [param_key(p) for p in points]

    n = len(points)
    results = SweepResults([None] * n)
    finished = np.zeros(n, dtype=bool)
    positions = {}                                  # key -> indices (duplicates computed once)
    for i, k in enumerate(keys):
        positions.setdefault(k, []).append(i)
    todo = []
    for k, idx in positions.items():
        found, value = _read_point(path, k) if path is not None else (False, None)
        if found:
            for i in idx:
                results[i] = value
            finished[idx] = True
        else:
            todo.append(k)
    bar = Progress("sweep", total=n, enabled=progress is not False, initial=int(finished.sum()), unit="pt")

    def record(k, value):
        idx = positions[k]
        if path is not None:
            archive.save(StorePoint(key=k, params=points[idx[0]], result=value), path / f"{k}.npz")
        for i in idx:
            results[i] = value
        finished[idx] = True
        for i in idx:
            bar.update()
            if callback is not None:
                callback(progress_state("sweep", int(finished.sum()), fraction=float(finished.sum()) / n, total=n,
                                        params=points[i], result=value))

    def fail(k, exc):
        idx = positions[k]
        failure = FailedPoint.from_exception(points[idx[0]], exc)
        _LOG.warning("sweep: the task failed at params = %r (%s); the point is not stored, a rerun retries it",
                     failure.params, failure.error)
        for i in idx:
            results[i] = failure
            bar.update()
        results.failed = sorted(results.failed + idx)

    def summary():
        if results.failed:
            where = f"; rerun sweep() on the store {str(path)!r} to retry them" if path else ""
            _LOG.warning("sweep: %d of %d points failed (indices %s) and were not stored%s",
                         len(results.failed), n, results.failed, where)
        return results

    def interrupted(exc):
        done = int(finished.sum())
        where = f"; they are in the store {str(path)!r}, rerun sweep() to finish the rest" if path else ""
        return SweepInterrupted(f"sweep interrupted after {done} of {n} points{where}",
                                results, finished.copy(), path)

    try:
        if ex is None:
            for k in todo:
                p = points[positions[k][0]]
                try:
                    with _limits(threads):
                        value = _call(task, p)
                except KeyboardInterrupt as exc:
                    raise interrupted(exc) from exc
                except Exception as exc:
                    if on_error == "record":
                        fail(k, exc)
                        continue
                    exc.add_note(f"sweep: the task failed at params = {p!r}; "
                                 f"{int(finished.sum())} of {n} finished points kept")
                    raise
                try:
                    record(k, value)
                except KeyboardInterrupt as exc:
                    raise interrupted(exc) from exc
            return summary()
        pid = os.getpid()
        futures = {ex.submit(_run, task, points[positions[k][0]], threads, pid): k for k in todo}
        pending = set(futures)
        try:
            while pending:
                done, pending = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    if on_error == "record" and fut.cancelled():
                        fail(futures[fut], cf.CancelledError("the executor cancelled the point"))
                        continue
                    error = fut.exception() if on_error == "record" else None
                    if isinstance(error, Exception):
                        fail(futures[fut], error)
                    else:
                        record(futures[fut], fut.result())
        except KeyboardInterrupt as exc:
            for fut in pending:
                fut.cancel()
            if owned:
                _terminate_workers(ex)
                owned = False
            raise interrupted(exc) from exc
        except Exception as exc:
            for fut in pending:
                fut.cancel()
            cf.wait(pending)                     # the running points finish; keep them
            for fut in pending:
                if fut.done() and not fut.cancelled() and fut.exception() is None:
                    record(futures[fut], fut.result())
            failed = [futures[f] for f in futures if f.done() and not f.cancelled() and f.exception() is exc]
            what = f"the point params = {points[positions[failed[0]][0]]!r} raised" if failed else "stopped"
            exc.add_note(f"sweep: {what}; {int(finished.sum())} of {n} finished points kept")
            raise
        return summary()
    finally:
        bar.close()
        if owned:
            ex.shutdown(wait=True)
