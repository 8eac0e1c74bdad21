r"""Free runs: the free set of the exact integrator decomposed run by run, eqs. (53), (55)-(56), (63).

Stuck nodes hold :math:`w = \zeta = 0`: they are Dirichlet points that cut the lattice into
independent *runs* of contiguous free nodes.  The lattice operator is tridiagonal, so the
operator of the free set, :math:`\underline L_{FF}`, is block diagonal with one block per run,
and a run's flight depends on its own nodes only.  :class:`RunModes` diagonalises
:math:`\underline L_{FF}` run by run instead of as one matrix (the reference,
:class:`~tps_solver.solvers.fda.exact.Modes`):

* on a uniform planar lattice of spacing :math:`h` a run of :math:`m` nodes has closed-form
  modes (:class:`ClosedRun`), by its two end types -- ``"D"`` (a stuck neighbour, :math:`u = 0`
  beyond the end) or ``"N"`` (the lattice's Neumann end, the half-cell row
  :math:`2(u_1 - u_0)/h^2` of (63)):

  ======  ===============================================  =====================================
  ends    mode :math:`k` at local node :math:`j`             :math:`\theta_k`
  ======  ===============================================  =====================================
  D, D    :math:`\sin(\theta_k (j + 1))`                    :math:`(k + 1)\pi/(m + 1)`
  N, D    :math:`\cos(\theta_k j)`                          :math:`(k + 1/2)\pi/m`
  D, N    :math:`\cos(\theta_k (m - 1 - j))`                :math:`(k + 1/2)\pi/m`
  N, N    :math:`\cos(\theta_k j)`                          :math:`k\pi/(m - 1)`
  ======  ===============================================  =====================================

  with eigenvalues :math:`\lambda_k = -(4/h^2)\sin^2(\theta_k/2)`; the mode matrix and its inverse
  are applied by a DST-I, DCT-II/III or DCT-I (``scipy.fftpack``) in :math:`O(m\log m)`, and since
  :math:`|V_{jk}| \le 1` the derivative bounds of the certified search use
  :math:`\sum_k|V_{jk}|x_k \le \sum_k x_k` (one number per run, :math:`O(m)`);
* elsewhere (pinned ends, axisymmetric or non-uniform lattices) a run is decomposed densely
  by :class:`~tps_solver.solvers.fda.exact.Modes` on its own nodes (:class:`DenseRun`), cached
  by its node range, so an event re-decomposes only the run it cut or merged.

The operator products of the search (:math:`\underline L_{FF}\underline w_F`,
:math:`\underline L_{SF}\underline w_F` and their absolute values) are tridiagonal,
:math:`O(n)` (:class:`Tridiagonal`, :class:`Block`).
"""
import weakref
from collections import OrderedDict

import numpy as np
from scipy import fftpack as fft      # the same transforms as scipy.fft, less call overhead

__all__ = ["free_runs", "uniform_spacing", "Tridiagonal", "Block", "ClosedRun", "DenseRun", "RunModes", "RunCache",
           "clear_caches"]


def free_runs(free):
    """Start and stop (exclusive) node indices of the runs of contiguous True in ``free``.

    Parameters
    ----------
    free : ndarray of bool, shape (n,)

    Returns
    -------
    starts, stops : ndarray of int, shape (k,)

    Examples
    --------
    >>> free_runs(np.array([True, True, False, True, False, False, True]))
    (array([0, 3, 6]), array([2, 4, 7]))
    """
    d = np.diff(np.concatenate(([0], np.asarray(free, dtype=np.int8), [0])))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def uniform_spacing(lattice, rtol=1e-12):
    """The spacing of a uniform planar lattice, or None (axisymmetric or non-uniform).

    Examples
    --------
    >>> from tps_solver import Lattice
    >>> uniform_spacing(Lattice.planar(n_nodes=5, length=4.0))
    1.0
    >>> uniform_spacing(Lattice.axisymmetric(n_nodes=5)) is None
    True
    """
    if lattice.geometry != "planar":
        return None
    h = np.diff(lattice.nodes)
    h0 = float(lattice.spacing)
    if not np.all(np.abs(h - h0) <= rtol * h0):
        return None
    return h0


class Tridiagonal:
    r"""The lattice operator :math:`\underline L` as its three diagonals (it is tridiagonal, see :mod:`.lattice`).

    Parameters
    ----------
    operator : ndarray of float, shape (n, n)

    Raises
    ------
    ValueError
        If ``operator`` has an entry off its three central diagonals.

    Examples
    --------
    >>> from tps_solver import Lattice
    >>> L = Lattice.planar(n_nodes=4, length=3.0).operator
    >>> tri = Tridiagonal(L)
    >>> u = np.array([1.0, -2.0, 0.5, 3.0])
    >>> bool(np.array_equal(tri.apply(u), L @ u)), bool(np.allclose(tri.apply_abs(u), np.abs(L) @ u))
    (True, True)
    """

    def __init__(self, operator):
        L = np.asarray(operator, dtype=float)
        n = L.shape[0]
        self.n = n
        self.diag = np.diag(L).copy()
        self.upper = np.concatenate((np.diag(L, 1), [0.0]))       # L[i, i+1]
        self.lower = np.concatenate(([0.0], np.diag(L, -1)))      # L[i, i-1]
        off = L.copy()
        i = np.arange(n)
        off[i, i] = 0.0
        off[i[:-1], i[:-1] + 1] = 0.0
        off[i[1:], i[1:] - 1] = 0.0
        if np.any(off != 0.0):
            raise ValueError("operator must be tridiagonal (a one-dimensional lattice)")
        self.abs_diag, self.abs_upper, self.abs_lower = np.abs(self.diag), np.abs(self.upper), np.abs(self.lower)

    @staticmethod
    def _apply(lo, d, up, u):
        out = d * u
        out[1:] += lo[1:] * u[:-1]
        out[:-1] += up[:-1] * u[1:]
        return out

    def apply(self, u):
        r""":math:`\underline L u` for ``u`` of shape (n,)."""
        return self._apply(self.lower, self.diag, self.upper, u)

    def apply_abs(self, u):
        r""":math:`|\underline L| u` for ``u`` of shape (n,)."""
        return self._apply(self.abs_lower, self.abs_diag, self.abs_upper, u)


class Block:
    r"""The block :math:`\underline L_{RC}` (rows ``R``, columns ``C``) of a :class:`Tridiagonal`, applied in O(n).

    ``block @ x`` is ``L[np.ix_(rows, cols)] @ x`` for ``x`` of shape (len(cols),): ``x`` is
    scattered into a zero vector, multiplied, and gathered.

    Examples
    --------
    >>> from tps_solver import Lattice
    >>> L = Lattice.planar(n_nodes=5, length=4.0).operator
    >>> R, C = np.array([1, 4]), np.array([0, 2, 3])
    >>> x = np.array([1.0, 2.0, -1.0])
    >>> bool(np.allclose(Block(Tridiagonal(L), R, C) @ x, L[np.ix_(R, C)] @ x))
    True
    """

    def __init__(self, tri, rows, cols, absolute=False):
        self.tri, self.rows, self.cols, self.absolute = tri, rows, cols, absolute

    def __matmul__(self, x):
        u = np.zeros(self.tri.n)
        u[self.cols] = x
        out = self.tri.apply_abs(u) if self.absolute else self.tri.apply(u)
        return out[self.rows]


class ClosedRun:
    r"""Closed-form modes of a run of ``m`` nodes on a uniform planar lattice (module docstring).

    Parameters
    ----------
    m : int
        Nodes of the run, >= 1 (>= 2 with two Neumann ends).
    ends : str
        ``"DD"``, ``"ND"``, ``"DN"`` or ``"NN"`` (left, right).
    h : float
        Lattice spacing.

    Attributes
    ----------
    lam : ndarray of float, shape (m,)
        Eigenvalues, <= 0.
    s : ndarray of float, shape (m,)
        Modal coefficients of the uniform vector (gravity); round-off ones set to 0.

    Examples
    --------
    The Dirichlet run of 3 nodes: eigenvalues :math:`-(2 \mp \sqrt 2)/h^2` and -2/h^2:

    >>> run = ClosedRun(3, "DD", 1.0)
    >>> np.round(run.lam, 12).tolist()
    [-0.585786437627, -2.0, -3.414213562373]
    >>> u = np.array([0.3, -1.0, 2.0])
    >>> bool(np.allclose(run.synthesis(run.analysis(u)), u))
    True
    """

    def __init__(self, m, ends, h):
        self.m, self.ends, self.h = int(m), ends, float(h)
        k = np.arange(m, dtype=float)
        if ends == "DD":
            theta = (k + 1.0) * np.pi / (m + 1)
        elif ends in ("ND", "DN"):
            theta = (k + 0.5) * np.pi / m
        elif ends == "NN":
            if m < 2:
                raise ValueError(f"m must be >= 2 for a run with two Neumann ends, got {m}")
            theta = k * np.pi / (m - 1)
        else:
            raise ValueError(f"ends must be one of 'DD', 'ND', 'DN', 'NN', got {ends!r}")
        self._theta = theta
        self.lam = -(4.0 / (h * h)) * np.sin(0.5 * theta) ** 2
        if ends == "NN":
            self.lam[0] = 0.0
            self._norm = np.full(m, 2.0 / (m - 1))       # 1 / N_k, N_k = (m - 1)/2, (m - 1) at k = 0, m - 1
            self._norm[[0, -1]] = 1.0 / (m - 1)
        s = self.analysis(np.ones(m))
        s[np.abs(s) <= 1e-15 * np.abs(s).max(initial=0.0)] = 0.0
        self.s = s
        self._forcing = {}

    def analysis(self, u):
        r"""Modal coefficients :math:`V^{-1}u` of ``u``, shape (m,)."""
        m, ends = self.m, self.ends
        if ends == "DD":
            return fft.dst(u, 1) / (m + 1)
        if ends == "ND":
            return fft.dct(u, 3) / m
        if ends == "DN":
            return fft.dct(u[::-1], 3) / m
        return fft.dct(u, 1) * (0.5 * self._norm)

    def synthesis(self, c):
        r""":math:`Vc` for modal coefficients ``c`` of shape (m,) or (m, k)."""
        ends = self.ends
        if ends == "DD":
            return 0.5 * fft.dst(c, 1, axis=0)
        if ends == "ND":
            return 0.5 * fft.dct(c, 2, axis=0)
        if ends == "DN":
            return 0.5 * fft.dct(c, 2, axis=0)[::-1]
        c = np.array(c, dtype=float)
        c[0] *= 2.0
        c[-1] *= 2.0
        return 0.5 * fft.dct(c, 1, axis=0)

    def row(self, j):
        """Row ``j`` of the mode matrix (the modes at local node ``j``), shape (m,)."""
        ends = self.ends
        if ends == "DD":
            return np.sin(self._theta * (j + 1))
        if ends == "DN":
            j = self.m - 1 - j
        return np.cos(self._theta * j)

    def matrix(self):
        """The mode matrix ``V`` (columns are the modes), shape (m, m): for tests."""
        return self.synthesis(np.eye(self.m))

    def forcing(self, Gamma):
        r"""The forcing parts of the derivative bounds :math:`D_1, D_2, D_3` (see :class:`~.exact.Segment`), shape (3, m)."""
        out = self._forcing.get(Gamma)
        if out is None:
            G = 1.0 + 1.0 / Gamma
            big = np.maximum(1.0, np.abs(self.lam))
            abs_s = np.abs(self.s)
            out = np.array([self.abs_bound((p + 1) * G * big ** (p - 1) * abs_s) for p in (1, 2, 3)])
            self._forcing[Gamma] = out
        return out

    def abs_bound(self, x):
        r"""An upper bound of :math:`|V|x` for ``x >= 0`` of shape (m,) or (m, k): :math:`\sum_k x_k` (:math:`|V_{jk}| \le 1`)."""
        out = np.empty((self.m,) + x.shape[1:])
        out[...] = x.sum(axis=0)
        return out


class DenseRun:
    """A run decomposed densely (:class:`~tps_solver.solvers.fda.exact.Modes` on its nodes).

    Parameters
    ----------
    modes : Modes
        The decomposition of the run's free set (only the run's nodes free).

    Examples
    --------
    A run touching a pinned end (an autonomous node: an exact zero mode):

    >>> from tps_solver import Lattice
    >>> from tps_solver.solvers.fda.exact import Modes
    >>> lat = Lattice.planar(n_nodes=5, length=4.0, boundary="pinned")
    >>> run = RunCache(lat, Modes).run(0, 2)
    >>> type(run).__name__, np.round(np.sort(run.lam), 12).tolist()
    ('DenseRun', [-2.0, 0.0])
    """

    def __init__(self, modes):
        self.m = modes.index.size
        self.md = modes
        self.lam = modes.lam
        s = modes.s.copy()
        mask = np.zeros(self.m, dtype=bool)
        mask[modes.forced] = True
        s[~mask] = 0.0
        self.s = s
        self._forcing = {}

    forcing = ClosedRun.forcing

    def analysis(self, u):
        return self.md.Vinv @ u

    def synthesis(self, c):
        return self.md.V @ c

    def row(self, j):
        return self.md.V[j]

    def matrix(self):
        return self.md.V

    def abs_bound(self, x):
        return self.md.absV @ x


#: end types of a closed run as the integers of the compiled root polish (:mod:`.run_kernels`)
_END_CODES = {"DD": 0, "ND": 1, "DN": 2, "NN": 3}


class _RunOp:
    """``op @ c`` applying a per-run map to the concatenated modal (or nodal) vector ``c``."""

    def __init__(self, runs, offsets, method):
        self.runs, self.offsets, self.method = runs, offsets, method

    def __matmul__(self, c):
        c = np.asarray(c, dtype=float)
        if len(self.runs) == 1:
            return np.asarray(getattr(self.runs[0], self.method)(c), dtype=float)
        out = np.empty(c.shape)
        o = self.offsets
        for r, run in enumerate(self.runs):
            out[o[r]:o[r + 1]] = getattr(run, self.method)(c[o[r]:o[r + 1]])
        return out


class RunModes:
    r"""The free set's modes, run by run: the interface of :class:`~tps_solver.solvers.fda.exact.Modes`.

    ``V``, ``Vinv`` and ``absV`` are operators (``op @ x``) applied run by run; ``absV @ x`` is
    an upper bound of :math:`|V|x` (exact for dense runs, the sum over the run's modes for
    closed-form runs), which is all the certified search needs.  ``L_FF``, ``L_SF`` and their
    absolute values are :class:`Block` operators.

    Parameters
    ----------
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)
    run_of : callable
        ``run_of(start, stop)`` -> a :class:`ClosedRun` or :class:`DenseRun` (cached by the caller).
    tri : Tridiagonal

    Examples
    --------
    Node 2 stuck on a 5-node Neumann lattice: runs {0, 1} (ends N, D) and {3, 4} (D, N),
    the same eigenvalues as the dense decomposition of the free set:

    >>> from tps_solver import Lattice
    >>> from tps_solver.solvers.fda.exact import Modes
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> free = np.array([True, True, False, True, True])
    >>> cache = RunCache(lat, Modes)
    >>> md = RunModes(lat, free, cache.run, cache.tri)
    >>> [(r.m, r.ends) for r in md.runs]
    [(2, 'ND'), (2, 'DN')]
    >>> bool(np.allclose(np.sort(md.lam), np.sort(Modes(lat, free).lam)))
    True
    """

    def __init__(self, lattice, free, run_of, tri):
        starts, stops = free_runs(free)
        self.runs = [run_of(int(a), int(b)) for a, b in zip(starts, stops)]
        lengths = stops - starts
        self.offsets = np.concatenate(([0], np.cumsum(lengths))).astype(np.int64)
        self.starts, self.stops = starts, stops
        idx = np.flatnonzero(free)
        self.index = idx
        self.stuck = np.flatnonzero(~free)
        if len(self.runs) == 1:
            self.lam, self.s = self.runs[0].lam, self.runs[0].s
        elif self.runs:
            self.lam = np.concatenate([r.lam for r in self.runs])
            self.s = np.concatenate([r.s for r in self.runs])
        else:
            self.lam, self.s = np.empty(0), np.empty(0)
        self.abs_lam = np.abs(self.lam)
        self.forced = np.flatnonzero(self.s)
        # compiled kernels (set by the propagator), or None: numpy
        self.kernel = self.step_kernel = self.bounds_kernel = self.sets_kernel = self.bracket_kernel = None
        self.start_kernel = self.sum_kernel = self.bound_kernel = None
        #: every run closed-form (the compiled bounds sum each run's modes)
        self.closed = all(isinstance(r, ClosedRun) for r in self.runs)
        if self.closed:         # the closed forms as arrays (compiled root polish): angles, end types
            self.theta = np.concatenate([r._theta for r in self.runs]) if self.runs else np.empty(0)
            self.end_code = np.array([_END_CODES[r.ends] for r in self.runs], dtype=np.int64)
            self.row_of = np.full(lattice.n_nodes, -1, dtype=np.int64)
            self.row_of[idx] = np.arange(idx.size)
        self.V = _RunOp(self.runs, self.offsets, "synthesis")
        self.Vinv = _RunOp(self.runs, self.offsets, "analysis")
        self.absV = _RunOp(self.runs, self.offsets, "abs_bound")
        S = self.stuck
        self.L_FF = Block(tri, idx, idx)
        self.absL_FF = Block(tri, idx, idx, absolute=True)
        self.L_SF = Block(tri, S, idx)
        self.absL_SF = Block(tri, S, idx, absolute=True)

    def forcing_bounds(self, Gamma):
        """``{p: D_p forcing part}`` for p = 1, 2, 3, arrays of shape (n_free,) (kept per run)."""
        if len(self.runs) == 1:
            f = self.runs[0].forcing(Gamma)
        elif self.runs:
            f = np.concatenate([r.forcing(Gamma) for r in self.runs], axis=1)
        else:
            f = np.zeros((3, 0))
        return {1: f[0], 2: f[1], 3: f[2]}

    def run_index(self, j):
        """Number of the run holding free row ``j``."""
        return int(np.searchsorted(self.offsets, j, side="right")) - 1


#: closed-form runs by (length, ends, spacing), shared by all propagators (O(m) memory each)
_CLOSED = OrderedDict()
_CLOSED_SIZE = 8192


class RunCache:
    """Run decompositions of one lattice: closed forms by (length, ends), dense ones by node range.

    Parameters
    ----------
    lattice : Lattice
    decompose : callable
        ``decompose(lattice, free)`` -> the dense decomposition of a free set
        (:class:`~tps_solver.solvers.fda.exact.Modes`), used for runs without closed form.
    size : int
        Dense run decompositions kept (least recently used dropped).
    tri : Tridiagonal, optional
        The lattice operator's :class:`Tridiagonal` (formed here if not given).

    Attributes
    ----------
    n_decompositions : int
        Dense decompositions computed (closed forms are not counted).

    Examples
    --------
    Runs with closed forms are shared, not decomposed; a pinned end has none, so its run is
    decomposed densely once and then reused:

    >>> from tps_solver import Lattice
    >>> from tps_solver.solvers.fda.exact import Modes
    >>> cache = RunCache(Lattice.planar(n_nodes=6, length=5.0), Modes)
    >>> a, b = cache.run(0, 3), cache.run(3, 6)
    >>> type(a).__name__, a.ends, b.ends, cache.n_decompositions
    ('ClosedRun', 'ND', 'DN', 0)
    >>> pinned = RunCache(Lattice.planar(n_nodes=6, length=5.0, boundary="pinned"), Modes)
    >>> r = pinned.run(0, 3); r is pinned.run(0, 3), type(r).__name__, pinned.n_decompositions
    (True, 'DenseRun', 1)

    Notes
    -----
    :meth:`of` keeps one cache per lattice (weakly referenced), so the period maps of a
    shooting run share it; :meth:`modes` keeps the :class:`RunModes` of the free sets seen
    (least recently used dropped; about 100 n bytes each, at most about 150 MB in all).
    """

    _per_lattice = weakref.WeakKeyDictionary()

    @classmethod
    def of(cls, lattice, decompose, tri=None):
        """The cache of ``lattice`` (created on first use)."""
        cache = cls._per_lattice.get(lattice)
        if cache is None or cache.decompose is not decompose or cache.n != lattice.n_nodes:
            cache = cls._per_lattice[lattice] = cls(lattice, decompose, tri=tri)
        return cache

    def modes(self, free, key=None):
        """The :class:`RunModes` of the free set ``free`` (bool mask; ``key``: its packed bytes)."""
        if key is None:
            key = np.packbits(free).tobytes()
        m = self._free_sets.get(key)
        if m is None:
            m = self._free_sets[key] = RunModes(self.lattice, free, self.run, self.tri)
            if len(self._free_sets) > self._free_set_size:
                self._free_sets.popitem(last=False)
        else:
            self._free_sets.move_to_end(key)
        return m

    def __init__(self, lattice, decompose, size=256, tri=None):
        self.lattice = lattice
        self.decompose = decompose
        self.tri = Tridiagonal(lattice.operator) if tri is None else tri
        self.h = uniform_spacing(lattice)
        self.n = lattice.n_nodes
        self.size = int(size)
        self._dense = OrderedDict()
        self._free_sets = OrderedDict()
        self._free_set_size = int(min(4096, max(64, 1.25e8 // (80 * self.n))))
        self.n_decompositions = 0
        aut = lattice.autonomous
        self._ends = ("N" if not aut[0] else None, "N" if not aut[-1] else None)

    def run(self, start, stop):
        """The decomposition of the run of nodes ``start .. stop - 1``."""
        left = "D" if start > 0 else self._ends[0]
        right = "D" if stop < self.n else self._ends[1]
        m = stop - start
        if self.h is not None and left is not None and right is not None:
            key = (m, left + right, self.h)
            run = _CLOSED.get(key)
            if run is None:
                run = _CLOSED[key] = ClosedRun(m, left + right, self.h)
                if len(_CLOSED) > _CLOSED_SIZE:
                    _CLOSED.popitem(last=False)
            return run
        key = (start, stop)
        run = self._dense.get(key)
        if run is None:
            mask = np.zeros(self.n, dtype=bool)
            mask[start:stop] = True
            run = DenseRun(self.decompose(self.lattice, mask))
            self.n_decompositions += 1
            self._dense[key] = run
            if len(self._dense) > self.size:
                self._dense.popitem(last=False)
        else:
            self._dense.move_to_end(key)
        return run


def clear_caches():
    """Drop every kept run decomposition (closed forms and per-lattice caches), e.g. to time a cold start.

    Examples
    --------
    >>> clear_caches()
    >>> len(_CLOSED)
    0
    """
    _CLOSED.clear()
    RunCache._per_lattice.clear()
