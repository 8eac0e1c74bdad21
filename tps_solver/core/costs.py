r"""Cost before computing: memory and time estimates, refusals, BLAS threads.

Estimates and refusals
----------------------
Every entry point whose cost grows with a size parameter (``n_harmonics``,
``n_nodes``, ``N``) estimates its peak memory and its run time *before* it
allocates anything and calls :func:`check_cost`, which raises a
:class:`ValueError` naming the parameter, its value and the estimate when the
memory estimate exceeds :func:`memory_limit` or the time estimate exceeds the time
limit.  Both limits can be changed with :func:`set_limits` (``None``: the
automatic memory limit, 80 % of the memory the operating system reports as
available; one hour of run time).  The estimates are deliberately *optimistic*
(a fast, idle machine), so a refusal means the call is out of reach, not merely
slow.

The estimators (:func:`tps_cost`, :func:`lattice_cost`, :func:`cycle_cost`,
:func:`harmonics_cost`) return ``(bytes, seconds)``.  A module that owns an
allocation calls e.g. ``check_cost("FlatLayer.harmonics", "N", N, *harmonics_cost(N))``
first.

BLAS threads
------------
On few cores a multithreaded BLAS makes *small* dense kernels slower: thread
start-up and, on a loaded machine, oversubscription cost more than the work.
Measured on the project's 2-core machine (OpenBLAS 0.3, load average about 10 from
other jobs), one thread against two:

==============================================  ============  ============
kernel                                          1 thread      2 threads
==============================================  ============  ============
``scipy.linalg.eigh``, 200 x 200 (best of 21)   9.2 ms        26 ms
``scipy.linalg.eigh``, 800 x 800 (best of 7)    519 ms        4362 ms
FDA radial benchmark, 200 nodes (s/period,      0.018         0.036
best of 5; ``validation.fda_benchmark``)
==============================================  ============  ============

:func:`blas_threads` limits the BLAS pool for a block of code through
``threadpoolctl`` (an optional dependency, imported lazily; without it the block
runs unchanged).  :func:`~tps_solver.simulate`, :func:`~tps_solver.check_stability`
and :func:`~tps_solver.solve_lattice_cycle` run under ``blas_threads(1)`` when the
lattice has at most :data:`SMALL_DENSE` nodes; nested blocks cost nothing.

The progress display is :class:`tps_solver.core.progress.Progress`.

Examples
--------
>>> nbytes, seconds = tps_cost(30, 8)
>>> nbytes < 1e8 and seconds < 10
True
>>> check_cost("solve_kink", "n_harmonics", 10**6, *tps_cost(10**6, 8))
Traceback (most recent call last):
...
ValueError: n_harmonics = 1000000 is out of reach for solve_kink: estimated ...
"""
import contextlib
import os
import sys

__all__ = ["check_cost", "memory_limit", "time_limit", "set_limits", "tps_cost", "lattice_cost",
           "cycle_cost", "harmonics_cost", "blas_threads", "small_dense", "SMALL_DENSE",
           "format_bytes", "format_seconds", "simulate_cost", "thickness_cost", "period_map_seconds",
           "shooting_maps"]


#: Lattices up to this many nodes run their dense kernels with one BLAS thread (one thread was
#: faster at every size measured, up to 800; see the module docstring).
SMALL_DENSE = 1000

_LIMITS = {"memory": None, "time": 3600.0}
_ACTIVE = []             # thread limits of the enclosing blas_threads blocks
_CONTROLLER = []         # [threadpoolctl.ThreadpoolController, len(sys.modules) when it scanned]

# Optimistic rates of an idle core (measured on the project machine, then rounded up).
_EXP_RATE = 1.0e8        # complex exponentials / transcendental evaluations per second
_FLOP_RATE = 5.0e9       # dense flops per second


def format_bytes(n):
    """``n`` bytes as a short human-readable string, e.g. ``'6.9 GB'``.

    Examples
    --------
    >>> format_bytes(512), format_bytes(1500), format_bytes(6.9e9)
    ('512 B', '1.5 kB', '6.9 GB')
    """
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000.0 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"  # pragma: no cover


def format_seconds(s):
    """``s`` seconds as a short string (s, min, h, days or years).

    Examples
    --------
    >>> format_seconds(30), format_seconds(600), format_seconds(7200)
    ('30 s', '10 min', '2 h')
    >>> format_seconds(86400 * 10), format_seconds(86400 * 365 * 5)
    ('10 days', '5 years')
    """
    s = float(s)
    if s < 120:
        return f"{s:.2g} s"
    if s < 7200:
        return f"{s / 60:.3g} min"
    if s < 86400 * 3:
        return f"{s / 3600:.3g} h"
    if s < 86400 * 365 * 3:
        return f"{s / 86400:.3g} days"
    return f"{s / (86400 * 365):.3g} years"


def _available_memory():
    """Bytes the OS reports as available (``MemAvailable``), or None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def memory_limit():
    """The memory limit in bytes: set by :func:`set_limits`, else 80 % of the available memory
    (4 GB if the OS does not say).

    Examples
    --------
    >>> old = set_limits(memory=2e9)
    >>> memory_limit()
    2000000000.0
    >>> _ = set_limits(**old)
    """
    if _LIMITS["memory"] is not None:
        return float(_LIMITS["memory"])
    avail = _available_memory()
    return 0.8 * avail if avail else 4e9


def time_limit():
    """The run-time limit in seconds (default 3600).

    Examples
    --------
    >>> time_limit()
    3600.0
    """
    return float(_LIMITS["time"])


def set_limits(memory=None, time=3600.0):
    """Set the limits used by :func:`check_cost`.

    Parameters
    ----------
    memory : float or None
        Bytes; ``None``: 80 % of the available memory, looked up at each check.
    time : float
        Seconds (``math.inf`` disables the time check).

    Returns
    -------
    dict
        The previous limits (pass them back as keywords to restore).

    Examples
    --------
    >>> old = set_limits(memory=1e6, time=10.0)
    >>> old
    {'memory': None, 'time': 3600.0}
    >>> check_cost("Lattice", "n_nodes", 1000, *lattice_cost(1000))
    Traceback (most recent call last):
    ...
    ValueError: n_nodes = 1000 is out of reach for Lattice: estimated memory 32 MB > limit 1 MB ...
    >>> _ = set_limits(**old)
    >>> time_limit()
    3600.0
    >>> set_limits(time=0)
    Traceback (most recent call last):
    ...
    ValueError: time must be a number of seconds > 0, got 0
    """
    old = dict(_LIMITS)
    if memory is not None and not (isinstance(memory, (int, float)) and memory > 0):
        raise ValueError(f"memory must be a number of bytes > 0 or None, got {memory!r}")
    if not (isinstance(time, (int, float)) and time > 0):
        raise ValueError(f"time must be a number of seconds > 0, got {time!r}")
    _LIMITS["memory"] = None if memory is None else float(memory)
    _LIMITS["time"] = float(time)
    return old


def check_cost(what, parameter, value, nbytes, seconds, hint=""):
    """Raise ``ValueError`` if the estimated cost of ``what`` exceeds the limits.

    Parameters
    ----------
    what : str
        The call, e.g. ``"solve_kink"``.
    parameter : str
        The size parameter that drives the cost (named in the message).
    value
        Its value.
    nbytes, seconds : float
        Estimated peak memory and run time.
    hint : str
        What to do instead (appended to the message).

    Returns
    -------
    tuple of float
        ``(nbytes, seconds)`` when within the limits.

    Examples
    --------
    >>> check_cost("solve_kink", "n_harmonics", 30, 1e6, 2.0)
    (1000000.0, 2.0)
    >>> check_cost("solve_kink", "n_harmonics", 30, 1e6, 7200.0, hint="use fewer nodes")
    Traceback (most recent call last):
    ...
    ValueError: n_harmonics = 30 is out of reach for solve_kink: estimated run time at least 2 h > limit 60 min (estimate 1 MB, 2 h); lower n_harmonics (use fewer nodes), or raise the limits ...
    """
    mem, tim = memory_limit(), time_limit()
    if nbytes > mem or seconds > tim:
        over = []
        if nbytes > mem:
            over.append(f"memory {format_bytes(nbytes)} > limit {format_bytes(mem)}")
        if seconds > tim:
            over.append(f"run time at least {format_seconds(seconds)} > limit {format_seconds(tim)}")
        raise ValueError(
            f"{parameter} = {value!r} is out of reach for {what}: estimated {', '.join(over)} "
            f"(estimate {format_bytes(nbytes)}, {format_seconds(seconds)}); lower {parameter}"
            + (f" ({hint})" if hint else "")
            + ", or raise the limits with tps_solver.core.costs.set_limits(memory=..., time=...)")
    return nbytes, seconds


# ------------------------------------------------------------------ estimators
def tps_cost(n_harmonics, n_nodes, newton_steps=60):
    """Estimated peak memory and time of a TPS solve (:func:`~tps_solver.solve_kink` and friends).

    Memory: about 40 complex arrays of shape (N, n_nodes) in the solver, plus the
    physical checks, which sample ``max(64 N, 2048)`` times in blocks of at most
    about 32 MB.  Time: each Newton step costs a few tens of Helmholtz solves of
    O(N n) work; the checks evaluate the series at ``64 N`` times, O(N^2 n).

    Parameters
    ----------
    n_harmonics, n_nodes : int
    newton_steps : int
        Newton steps assumed (continuation typically takes 15-60).

    Returns
    -------
    nbytes, seconds : float

    Examples
    --------
    With no Newton steps only the physical checks cost time, 2048 samples x 61 harmonics x 9:

    >>> tps_cost(30, 8, newton_steps=0)
    (8198720.0, 0.01124352)
    >>> tps_cost(30, 8)[1]           # + 60 steps x 20 solves x 50 N n / 1e8
    0.15524352
    """
    N, n = float(n_harmonics), float(n_nodes)
    n_times = max(64.0 * N, 2048.0)
    block = min(n_times, max(1.0, 32e6 / (16.0 * (2 * N + 1))))
    nbytes = 40 * 16.0 * N * n + 16.0 * block * (2 * N + 1) * 3 + 64.0 * n_times * n + 1e6
    seconds = (newton_steps * 20 * 50.0 * N * n + n_times * (2 * N + 1) * (1.0 + n)) / _EXP_RATE
    return nbytes, seconds


def lattice_cost(n_nodes):
    """Memory (four dense n x n float matrices) and time of building a :class:`~tps_solver.Lattice`.

    Examples
    --------
    >>> lattice_cost(1000)            # 4 x 8 x 1000**2 bytes, 4e6 flops at 5 Gflop/s
    (32000000.0, 0.0008)
    """
    n = float(n_nodes)
    return 4 * 8.0 * n * n, 4 * n * n / _FLOP_RATE


def cycle_cost(n_nodes, newton_steps=60):
    """Memory and time of :func:`~tps_solver.solve_lattice_cycle` (O(n^3) work per residual,
    evaluated in row blocks of at most about 512 MB, plus ``eigh`` and dense n x n matrices).

    Examples
    --------
    The time is O(n^3): twice the nodes, eight times the time.

    >>> cycle_cost(100)
    (73120000.0, 14.402...)
    >>> cycle_cost(200)[1] / cycle_cost(100)[1]
    8.0
    """
    n = float(n_nodes)
    rows = min(n, max(1.0, 512e6 / (48.0 * n * n)))
    block = 1.5 * 48.0 * n * n * rows
    nbytes = 10 * 8.0 * n * n + block + lattice_cost(n_nodes)[0]
    seconds = newton_steps * 3 * 8 * n ** 3 / _EXP_RATE + 10 * n ** 3 / _FLOP_RATE
    return nbytes, seconds


def harmonics_cost(N):
    """Memory (a few complex vectors of length 2N+1) and time of closed-form harmonics of order N.

    Examples
    --------
    >>> harmonics_cost(10)            # 4 complex vectors of 21 entries, 16 bytes each
    (1344.0, 8.4e-07)
    """
    N = float(N)
    return 4 * 16.0 * (2 * N + 1), 4 * (2 * N + 1) / _EXP_RATE


#: Lower bounds of the time stepper's cost, measured on the fastest case (a flat layer of
#: 9-101 nodes, point impacts: 1.1e-4 s per forcing cycle at 9 nodes, 3.1e-6 s per node and cycle
#: at 101 nodes), divided by ten: the refusal never stops a run that would have been fast.
SIMULATE_SECONDS_PER_CYCLE = 1.0e-5
SIMULATE_SECONDS_PER_NODE_CYCLE = 3.0e-7


#: How much slower than point impacts each method is, at least: the measured ratios on a flat layer
#: of 5 and 41 nodes (point 1.4e-4 to 3.3e-4 s per cycle; exact 1.2e-3 to 1.6e-3, ode 1.1e-2,
#: soft 2.4e-2 to 2.6e-2, soft-radau 0.42 to 0.51), divided by three or more.
SIMULATE_METHOD_FACTOR = {"point": 1.0, "exact": 3.0, "ode": 30.0, "soft": 30.0, "soft-radau": 300.0}
#: A recorded segment (``record_segments=True``): a tuple of three arrays of n values and a mask,
#: at least one per two forcing cycles (a layer lands at least once per f/2 period).
SEGMENT_BYTES_PER_NODE = 17.0
SEGMENT_BYTES = 400.0


def simulate_cost(n_nodes, n_cycles, n_eval=0, method=None, record_segments=False):
    r"""A lower bound on the memory and time of :func:`~tps_solver.simulate` over ``n_cycles``
    forcing cycles :math:`2\pi` (at least one event set per cycle and O(n) work per node and
    cycle), with ``n_eval`` output times.

    Parameters
    ----------
    n_nodes : int
    n_cycles : float
    n_eval : int
        Output times.
    method : str, optional
        A key of ``tps_solver.METHODS``: the time is :data:`SIMULATE_METHOD_FACTOR` times that of
        point impacts (None: point impacts, the fastest).
    record_segments : bool
        Memory of the segment record, one entry per two cycles at least.

    Examples
    --------
    >>> nbytes, seconds = simulate_cost(9, 1e3)        # a thousand cycles: milliseconds
    >>> int(nbytes), round(seconds, 6)
    (1000576, 0.0127)
    >>> simulate_cost(5, 2e9)[1] > 3600                # a billion periods: refused
    True
    >>> simulate_cost(5, 2e8, method="ode")[1] > 3600  # the ODE is 30x slower at least
    True
    """
    n, c = float(n_nodes), float(n_cycles)
    nbytes = 2 * 8.0 * n * float(n_eval) + 8.0 * 8 * n + 1e6
    if record_segments:
        nbytes += 0.5 * c * (SEGMENT_BYTES + SEGMENT_BYTES_PER_NODE * n)
    factor = SIMULATE_METHOD_FACTOR.get(method, 1.0)
    return nbytes, factor * c * (SIMULATE_SECONDS_PER_CYCLE + n * SIMULATE_SECONDS_PER_NODE_CYCLE)


#: Lower bounds of the thickness integrator (``solve_ivp`` DOP853 between events), measured on a
#: flat layer of 5 and 41 nodes (0.021-0.027 s per cycle, 1.3e-3 to 8.4e-3 s per event), divided by ten.
THICKNESS_SECONDS_PER_CYCLE = 2.0e-3
THICKNESS_SECONDS_PER_EVENT = 1.0e-4


def thickness_cost(n_nodes, n_cycles, max_events):
    r"""Lower bounds on the memory and time of the thickness model's integration over ``n_cycles``
    forcing cycles, and on the time its event bound ``max_events`` allows (the run stops there).

    Returns
    -------
    nbytes, seconds, seconds_of_the_event_bound : float

    Examples
    --------
    >>> nbytes, seconds, bound = thickness_cost(5, 1e3, 1e5)
    >>> round(seconds, 6), round(bound, 6)
    (2.0, 10.0)
    >>> thickness_cost(5, 10, 1e12)[2] > 3600          # a bound of 1e12 events is out of reach
    True
    """
    n, c = float(n_nodes), float(n_cycles)
    nbytes = 64.0 * 8 * 4 * n + 1e6
    return nbytes, c * THICKNESS_SECONDS_PER_CYCLE, float(max_events) * THICKNESS_SECONDS_PER_EVENT


# --------------------------------------------------------------- BLAS threads
def small_dense(n_nodes):
    """True if dense kernels of size ``n_nodes`` are faster on one BLAS thread (n <= SMALL_DENSE).

    Examples
    --------
    >>> small_dense(SMALL_DENSE), small_dense(SMALL_DENSE + 1)
    (True, False)
    """
    return n_nodes <= SMALL_DENSE


@contextlib.contextmanager
def blas_threads(n_threads=1, enabled=True):
    """Limit BLAS threads to ``n_threads`` inside the block (threadpoolctl; no-op without it).

    Parameters
    ----------
    n_threads : int
    enabled : bool
        ``False`` runs the block unchanged (e.g. for large lattices).

    Examples
    --------
    >>> import numpy as np
    >>> with blas_threads(1):
    ...     x = np.linalg.eigvalsh(np.eye(3))
    >>> x.tolist()
    [1.0, 1.0, 1.0]
    """
    if not enabled or _ACTIVE and _ACTIVE[-1] == n_threads:
        yield                      # disabled, or already limited to n_threads by an outer block
        return
    controller = _blas_controller()
    if controller is None:
        yield
        return
    with controller.limit(limits=n_threads, user_api="blas"):
        _ACTIVE.append(n_threads)
        try:
            yield
        finally:
            _ACTIVE.pop()


def _blas_controller():
    """threadpoolctl's controller of the loaded thread pools, or None without threadpoolctl.

    Scanning the loaded libraries costs about 2-4 ms (``threadpool_limits`` scans on every
    call), more than a short ``simulate`` run; the scan is kept and redone only when modules
    were imported since (a BLAS loaded later comes with an import).
    """
    n_modules = len(sys.modules)
    if not _CONTROLLER or _CONTROLLER[1] != n_modules:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:
            return None
        _CONTROLLER[:] = [ThreadpoolController(), len(sys.modules)]
    return _CONTROLLER[0]



# ------------------------------------------------------------------ period maps and shooting
#: Lower bounds of the exact method's time per period and squared node count once the nodes'
#: contacts are separate (a kink, a perturbed flat layer, every period map of a shooting Newton
#: step): measured on a perturbed flat layer at e = 0.45 (2.2e-5 to 4.1e-5 s at 201-801 nodes)
#: and on the e = 0 kink (1.5e-4 to 1.7e-4 s at 101-201 nodes, four events per node and period),
#: divided by ten.
EXACT_SECONDS_PER_NODE2_PERIOD = {"bounce": 2.0e-6, "stick": 1.5e-5}
#: Lower bound of the impact-and-stick TPS's discovery from the anticontinuum limit per cubed node
#: count (measured 35 s at 10 nodes and 375 s at 20, validation/stick_discovery.py, divided by ten).
DISCOVERY_SECONDS_PER_NODE3 = 3.5e-3


def period_map_seconds(n_nodes, period, method="exact", e=None):
    r"""A lower bound on the time of one FDA period of length ``period`` on ``n_nodes`` nodes whose
    contacts are separate (what a shooting Newton step maps).

    Parameters
    ----------
    n_nodes : int
    period : float
        The period :math:`2\pi M`.
    method : str
        A key of ``tps_solver.METHODS``; the quadratic bound applies to ``"exact"``.
    e : float or None
        The restitution (0: sticking orbits, four events per node and period).

    Examples
    --------
    >>> round(period_map_seconds(2001, 4 * 3.141592653589793, e=0.0), 1)     # 1.5e-5 n**2
    60.1
    >>> period_map_seconds(21, 4 * 3.141592653589793, e=0.45) < 0.01
    True
    """
    n = float(n_nodes)
    linear = simulate_cost(n_nodes, period / (2.0 * 3.141592653589793), method=method)[1]
    if method != "exact":
        return linear
    kind = "stick" if e is not None and not isinstance(e, str) and float(e) == 0.0 else "bounce"
    return max(linear, EXACT_SECONDS_PER_NODE2_PERIOD[kind] * n * n)


def shooting_maps(n_nodes, krylov_dim=None, max_iter=1):
    """The period maps of one Newton--GMRES step of the period map on ``n_nodes`` nodes (the first
    map and ``min(krylov_dim, 2 n) + 1`` more), or 1 when no step is taken.

    Examples
    --------
    >>> shooting_maps(2001), shooting_maps(5, krylov_dim=4), shooting_maps(2001, max_iter=0)
    (102, 6, 1)
    """
    if not max_iter:
        return 1
    m = 2 * int(n_nodes)
    k = min(m, 100) if krylov_dim is None else int(krylov_dim)
    return min(k, m) + 2
