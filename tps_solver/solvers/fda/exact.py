r"""Exact propagation between contacts, eqs. (55)-(56), and a certified contact search.

Between two events the free nodes :math:`F` obey the linear system (53) with
the stuck nodes held at :math:`w = \zeta = 0`:

.. math::  \dot{\underline w}_F = \underline L_{FF}\,\underline w_F + g(t)\,\underline\sigma_F,
           \qquad \dot{\underline\zeta}_F = \underline w_F .

:class:`Modes` diagonalises :math:`\underline L_{FF} = V\Lambda V^{-1}` (the
lattice operator is symmetrisable, see :mod:`.lattice`; pinned ends add exact
zero modes through the harmonic lift), so that with :math:`\tau = t - t_c`,
:math:`\underline a = V^{-1}\underline w_F(t_c^+)` and
:math:`\underline s = V^{-1}\underline\sigma_F`

.. math::
    \underline w_F(t) &= V\big[e^{\Lambda\tau}\underline a + \underline s\odot
                         \mathcal W_\Lambda(\tau)\big], \\
    \underline\zeta_F(t) &= \underline\zeta_F(t_c) + V\big[\tau\varphi_1(\Lambda\tau)\underline a
                         + \underline s\odot\mathcal Z_\Lambda(\tau)\big],

where :math:`\mathcal W_\lambda(\tau) = \int_0^\tau e^{\lambda(\tau-u)}g(t_c+u)\,du`
and :math:`\mathcal Z_\lambda = \int_0^\tau\mathcal W_\lambda` are closed forms
(:func:`forced_response`).  For :math:`\lambda = 0` they are the flat-layer
:math:`W(t) - W(t_c)` and :math:`Z(t) - Z(t_c) - W(t_c)\tau` of (55)-(56); with no
stuck node :math:`\underline\sigma` is the null mode and (55) is recovered exactly.
With stuck nodes :math:`\underline\sigma_F` is no longer a null vector and the
other modes are forced too; the formula stays exact ("re-decompose the free
sub-lattice").  By default (``modes="runs"``) the free set is decomposed run by run
(:mod:`.runs`: stuck nodes cut the lattice into independent runs of free nodes, with
closed-form modes on a uniform planar lattice), so an event costs :math:`O(n\log n)`
instead of an :math:`O(n^3)` eigendecomposition; :class:`Modes` of the whole free set
(``modes="free_set"``) is the reference.

Contact search: certified, it cannot step over a double crossing (docs/design.md, hazards 4-5)
----------------------------------------------------------------------------------
Each candidate event is a function :math:`f_j(t) \ge 0` that ends the flight when
it reaches zero: :math:`\zeta_j` for a free node (impact) and :math:`-a_j` for a
stuck node, :math:`a_j = g + (\underline L\underline w)_j` its free acceleration
(lift-off).  From the modal form, for every :math:`t` later in the segment,

.. math::  |w_j^{(m)}(t)| \le D_{m,j}(t_1) = \sum_k |V_{jk}|\Big[|\lambda_k|^m e^{\lambda_k\tau_1}|a_k|
             + (m+1)(1 + \Gamma^{-1})\max(1,|\lambda_k|)^{m-1}|s_k|\Big], \quad t \ge t_1,

(:meth:`Segment.derivative_bound`), since :math:`e^{\lambda\tau}` decreases and
:math:`|g^{(p)}| \le 1 + 1/\Gamma`.  With :math:`A_j \ge |f_j''|` the lower
Taylor bound :math:`f_j + f_j'h - A_j h^2/2` is positive up to the *safe step*
:math:`h_j`, so no zero -- single or double -- can lie in :math:`(t, t+h_j)`.
The search advances by :math:`\min_j h_j`; near a transversal zero this is a
Newton-like step from below and converges quadratically.  A node rising with
:math:`w_j \ge 0` is also safe while the lower bound of :math:`w_j` stays positive,
and a node that has just lifted off (:math:`w = a = 0`, :math:`\dot a > 0`) is safe
for :math:`3\dot a/D_{3,j}`.  Once a candidate satisfies :math:`f'^2 \ge 2.5 A f`
(:math:`f' < 0`), it is strictly decreasing up to the root bound
:math:`u = 2f/(|f'| + \sqrt{f'^2 - 2Af})`, so its root there is unique and is
polished by ``brentq`` (absolute tolerance ``1e-15`` in the local time).
Every other candidate whose safe step does not cover the bracket must satisfy
the same condition; the earliest root and all candidates reaching zero within
``time_tol`` of it form one simultaneous contact set (54).
"""
import math
from collections import OrderedDict

import numpy as np
from scipy.linalg import eigh
from scipy.optimize import brentq

from tps_solver.core import jit
from tps_solver.core.checks import check_choice, check_int, check_positive
from tps_solver.model.flight import phi1, phi2, phi2_expm1
from tps_solver.solvers.fda.base import Integrator, Step
from tps_solver.solvers.fda.events import event_sets, tridiagonal
from tps_solver.solvers.fda.runs import RunCache, RunModes

__all__ = ["candidate_group", "forced_response", "Modes", "Segment", "ExactPropagator", "COMPILED_MIN_NODES"]

_EPS = np.finfo(float).eps
#: smallest lattice on which ``ExactPropagator(compiled=None)`` uses the compiled kernels
COMPILED_MIN_NODES = 17


def forced_response(lam, t_c, tau, Gamma):
    r"""Modal response to the plate-frame gravity, the damped analogue of (56).

    .. math::
        \mathcal W_\lambda(\tau) &= \int_0^\tau e^{\lambda(\tau-u)}\,g(t_c+u)\,du
            = \operatorname{Im}\frac{e^{it_c}(e^{i\tau} - e^{\lambda\tau})}{i - \lambda}
              - \frac{\tau\varphi_1(\lambda\tau)}{\Gamma},\\
        \mathcal Z_\lambda(\tau) &= \int_0^\tau \mathcal W_\lambda
            = \operatorname{Im}\frac{e^{it_c}}{i-\lambda}\Big(\frac{e^{i\tau}-1}{i}
              - \tau\varphi_1(\lambda\tau)\Big) - \frac{\tau^2\varphi_2(\lambda\tau)}{\Gamma},

    with :math:`g(t) = \sin t - 1/\Gamma` (16).  For :math:`\lambda = 0`:
    :math:`\mathcal W = W(t_c+\tau) - W(t_c)`, :math:`\mathcal Z = Z(t_c+\tau) - Z(t_c) - W(t_c)\tau`.

    Parameters
    ----------
    lam : ndarray of float, shape (k,)
        Eigenvalues (<= 0).
    t_c : float
        Segment start.
    tau : float
        Time since the segment start (>= 0).
    Gamma : float

    Returns
    -------
    W, Z : ndarray of float, shape (k,)

    Examples
    --------
    >>> W, Z = forced_response(np.array([0.0]), 0.0, np.pi, 2.5)
    >>> round(float(W[0]), 12) == round(2.0 - np.pi / 2.5, 12)
    True
    """
    lam = np.asarray(lam, dtype=float)
    z = lam * tau
    p1 = tau * phi1(z)
    rot = complex(math.cos(t_c), math.sin(t_c)) / (1j - lam)
    eit = complex(math.cos(tau), math.sin(tau))
    W = (rot * (eit - np.exp(z))).imag - p1 / Gamma
    Z = (rot * ((eit - 1.0) / 1j - p1)).imag - tau * tau * phi2(z) / Gamma
    return W, Z


class Modes:
    r"""Eigendecomposition of the free sub-lattice operator :math:`\underline L_{FF}`.

    Coupled nodes: :math:`\underline L_{cc} = V_c^{-1}S_{cc}` is diagonalised
    through the symmetric :math:`V_c^{-1/2}S_{cc}V_c^{-1/2}` (``eigh``).
    Autonomous (pinned-end) nodes have zero rows; each contributes an exact
    zero mode :math:`(e_a, H e_a)` with the harmonic lift
    :math:`H = -\underline L_{cc}^{+}\underline L_{ca}`, so that
    :math:`V = [[I, 0], [H, Q]]` and :math:`V^{-1} = [[I, 0], [-Q^{-1}H, Q^{-1}]]`.

    Parameters
    ----------
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)

    Attributes
    ----------
    index : ndarray of int, shape (n_free,)
        Node indices of the free set (row order of ``V``).
    lam : ndarray of float, shape (n_free,)
        Eigenvalues, <= 0 (round-off null modes set to exactly 0).
    V, Vinv, absV : ndarray of float, shape (n_free, n_free)
    s : ndarray of float, shape (n_free,)
        Modal coefficients of :math:`\underline\sigma_F`.

    Examples
    --------
    Three nodes with Neumann ends: the eigenvalues of ``[[-2, 2, 0], [1, -2, 1], [0, 2, -2]]``
    are -4, -2, 0, and gravity drives only the uniform (zero) mode:

    >>> from tps_solver import Lattice
    >>> md = Modes(Lattice.planar(n_nodes=3, length=2.0), np.ones(3, dtype=bool))
    >>> md.lam.round(12).tolist(), md.forced.tolist()
    ([-4.0, -2.0, 0.0], [2])
    """

    def __init__(self, lattice, free):
        idx = np.flatnonzero(free)
        self.index = idx
        nf = idx.size
        aut = lattice.autonomous[idx]
        ia, ic = np.flatnonzero(aut), np.flatnonzero(~aut)
        L = lattice.operator
        V = np.zeros((nf, nf))
        Vinv = np.zeros((nf, nf))
        lam = np.zeros(nf)
        na = ia.size
        if ic.size:
            nodes_c = idx[ic]
            vol = lattice.volumes[nodes_c]
            rs = np.sqrt(vol)
            S = lattice.flux[np.ix_(nodes_c, nodes_c)]
            mu, U = eigh(S / rs[:, None] / rs[None, :])
            scale = max(1.0, float(np.max(np.abs(mu))))
            mu[np.abs(mu) <= 1e-12 * scale] = 0.0
            mu = np.minimum(mu, 0.0)
            Q = U / rs[:, None]
            Qinv = U.T * rs[None, :]
            lam[na:] = mu
            V[np.ix_(ic, np.arange(na, nf))] = Q
            Vinv[np.ix_(np.arange(na, nf), ic)] = Qinv
            if na:
                Lca = L[np.ix_(nodes_c, idx[ia])]
                inv_mu = np.zeros_like(mu)
                inv_mu[mu != 0.0] = 1.0 / mu[mu != 0.0]
                QinvH = -(inv_mu[:, None] * (Qinv @ Lca))      # Q^{-1} H
                H = Q @ QinvH
                V[np.ix_(ic, np.arange(na))] = H
                Vinv[np.ix_(np.arange(na, nf), ia)] = -QinvH
        if na:
            V[ia, np.arange(na)] = 1.0
            Vinv[np.arange(na), ia] = 1.0
        self.lam = lam
        self.V = V
        self.Vinv = Vinv
        self.absV = np.abs(V)
        self.s = Vinv @ np.ones(nf)
        # modes driven by gravity; round-off projections (|s_k| <= 1e-15 max|s|) contribute < 1e-15
        self.forced = np.flatnonzero(np.abs(self.s) > 1e-15 * np.abs(self.s).max(initial=0.0))
        self.abs_lam = np.abs(lam)
        self.L_FF = L[np.ix_(idx, idx)]
        self.absL_FF = np.abs(self.L_FF)
        stuck = np.flatnonzero(~free)
        self.stuck = stuck
        self.L_SF = L[np.ix_(stuck, idx)]
        self.absL_SF = np.abs(self.L_SF)


class Segment:
    """Closed-form flight of the free nodes from a segment start (see module docstring).

    Parameters
    ----------
    modes : Modes
    t_c : float
        Segment start.
    w_free, zeta_free : ndarray of float, shape (n_free,)
        Post-event state of the free nodes.
    Gamma : float

    Examples
    --------
    A uniform launch follows the flat layer's flight (17):

    >>> from tps_solver import FlatLayer, Lattice
    >>> fl = FlatLayer(2.5, 2, e=0.45)
    >>> md = Modes(Lattice.planar(n_nodes=3, length=2.0), np.ones(3, dtype=bool))
    >>> seg = Segment(md, fl.t0, np.full(3, fl.velocity(fl.t0)), np.zeros(3), 2.5)
    >>> w, z = seg.state(1.0)
    >>> bool(np.allclose(w, fl.velocity(fl.t0 + 1.0)) and np.allclose(z, fl.height(fl.t0 + 1.0)))
    True
    """

    def __init__(self, modes, t_c, w_free, zeta_free, Gamma):
        self.modes = modes
        self.t_c = t_c
        self.a = modes.Vinv @ w_free
        self.zeta0 = zeta_free.copy()
        self.Gamma = Gamma
        # time-independent forcing part of the derivative bounds, m = 1, 2, 3 (kept with the modes)
        cache = modes.__dict__.setdefault("_forcing_bounds", {})
        self._forcing = cache.get(Gamma)
        self._runs = isinstance(modes, RunModes)
        if self._forcing is None:
            if self._runs:
                # s/(i - lam) and s/Gamma of the real form of forced_response (see coefficients)
                self._forcing = modes.forcing_bounds(Gamma)
                self._forcing["s_res"] = modes.s / (1j - modes.lam)
                self._forcing["sg"] = modes.s / Gamma
            else:
                G = 1.0 + 1.0 / Gamma
                big = np.maximum(1.0, modes.abs_lam)
                abs_s = np.abs(modes.s)
                self._forcing = {m: modes.absV @ ((m + 1) * G * big ** (m - 1) * abs_s) for m in (1, 2, 3)}
            cache[Gamma] = self._forcing
        self._abs_a = np.abs(self.a)
        if self._runs:
            # forced_response in real form: s e^{i t_c}/(i - lam) = rr + i ri, so that
            # s W = ri (cos tau - e^{lam tau}) + rr sin tau - (s/Gamma) tau phi1 and
            # s Z = ri (sin tau - tau phi1) + rr (1 - cos tau) - (s/Gamma) tau^2 phi2
            rot = complex(math.cos(t_c), math.sin(t_c)) * self._forcing["s_res"]
            self._rr, self._ri = rot.real, rot.imag
            self._a_ri = self.a - self._ri
            self._sg = self._forcing["sg"]

    def coefficients(self, tau, sl=None):
        """Modal coefficients (velocity, displacement) at local time ``tau`` (of the modes ``sl``, a slice)."""
        lam = self.modes.lam
        a = self.a
        if self._runs:
            sl = slice(None) if sl is None else sl
            lam, a_ri, rr, ri, sg = lam[sl], self._a_ri[sl], self._rr[sl], self._ri[sl], self._sg[sl]
            kern = self.modes.kernel
            if kern is not None:
                cw, cz = np.empty(lam.size), np.empty(lam.size)
                kern(lam, a_ri, rr, ri, sg, float(tau), cw, cz)
                return cw, cz
            z = lam * tau
            em1 = np.expm1(z)
            tp1 = tau * np.divide(em1, z, out=np.ones_like(z), where=z != 0.0)
            c, sn = math.cos(tau), math.sin(tau)
            omc = 2.0 * math.sin(0.5 * tau) ** 2
            cw = (em1 + 1.0) * a_ri + (c * ri + sn * rr) - sg * tp1
            cz = tp1 * a_ri + (sn * ri + omc * rr) - (tau * tau) * sg * phi2_expm1(z, em1)
            return cw, cz
        z = lam * tau
        em1 = np.expm1(z)
        cw = (em1 + 1.0) * a
        cz = tau * np.divide(em1, z, out=np.ones_like(z), where=z != 0.0) * a
        act = self.modes.forced
        W, Z = forced_response(lam[act], self.t_c, tau, self.Gamma)
        s = self.modes.s[act]
        cw[act] += s * W
        cz[act] += s * Z
        return cw, cz

    def state(self, tau):
        """Velocity and height of the free nodes at local time ``tau``."""
        cw, cz = self.coefficients(tau)
        V = self.modes.V
        if self._runs:                  # one transform of both columns per run
            out = V @ np.column_stack((cw, cz))
            return out[:, 0], self.zeta0 + out[:, 1]
        return V @ cw, self.zeta0 + V @ cz

    def node_height(self, j, tau):
        """Height of free node number ``j`` (row of ``V``) at local time ``tau``."""
        md = self.modes
        if isinstance(md, RunModes):          # only the run holding node j
            r = md.run_index(j)
            o = md.offsets
            _, cz = self.coefficients(tau, slice(o[r], o[r + 1]))
            return self.zeta0[j] + md.runs[r].row(j - o[r]) @ cz
        _, cz = self.coefficients(tau)
        return self.zeta0[j] + md.V[j] @ cz

    def bounds12(self, tau):
        """``(D_1, D_2)`` in one matrix product (see :meth:`derivative_bound`)."""
        md = self.modes
        if self._runs and md.closed and md.kernel is not None:
            A, B = np.empty(md.lam.size), np.empty(md.lam.size)
            md.bounds_kernel(md.abs_lam, self._abs_a, float(tau), md.offsets, self._forcing[1], self._forcing[2],
                             A, B)
            return A, B
        lam = self.modes.abs_lam
        decay = np.exp(-lam * tau) * self._abs_a
        D = self.modes.absV @ np.column_stack((lam * decay, lam * lam * decay))
        return D[:, 0] + self._forcing[1], D[:, 1] + self._forcing[2]

    def derivative_bound(self, tau, m):
        r"""Bound :math:`D_{m}` on :math:`|w^{(m)}|` of every free node, valid for all later times."""
        lam = self.modes.abs_lam
        kern = getattr(self.modes, "bound_kernel", None)
        if kern is not None:
            out = np.empty(lam.size)
            kern(lam, self._abs_a, float(tau), m, self.modes.offsets, self._forcing[m], out)
            return out
        return self.modes.absV @ (lam ** m * np.exp(-lam * tau) * self._abs_a) + self._forcing[m]


def _safe_step(f, fp, A):
    r"""Largest h with :math:`f + f'h - Ah^2/2 > 0` on (0, h) (0 where f <= 0 and f' <= 0).

    Uses :math:`h = 2f/(\sqrt{f'^2 + 2Af} - f')` for :math:`f' < 0` (no cancellation)
    and :math:`(f' + \sqrt{f'^2 + 2Af})/A` otherwise.
    """
    f = np.maximum(f, 0.0)
    root = np.sqrt(fp * fp + 2.0 * A * f)
    den = root - fp
    neg = np.divide(2.0 * f, den, out=np.zeros_like(f), where=den > 0.0)
    return np.where(fp >= 0.0, (fp + root) / A, neg)


def candidate_group(h, upper, ok, m):
    r"""The nodes that may reach the plate first, grown to a closed set, or None.

    Starting from the node ``m`` with the smallest lower bound, the set is every node whose
    lower bound ``h`` lies below the largest upper bound ``upper`` of the set, repeated until it
    stops growing.  ``None`` when a member has no certified bracket (``ok`` False): the caller
    then takes a smaller step.

    Parameters
    ----------
    h, upper : ndarray of float, shape (n,)
        Lower and upper bounds of each candidate's first crossing time.
    ok : ndarray of bool, shape (n,)
        Whether each upper bound is certified.
    m : int
        Index of the smallest lower bound.

    Returns
    -------
    group : ndarray of int or None

    Examples
    --------
    >>> candidate_group(np.array([0.0, 0.5, 2.0]), np.array([1.0, 1.5, 3.0]), np.ones(3, bool), 0)
    array([0, 1])
    >>> candidate_group(np.array([0.0, 0.5]), np.array([1.0, 1.5]), np.array([True, False]), 0) is None
    True
    """
    span = upper[m]
    while True:
        group = np.flatnonzero(h < span)
        if group.size == 0:
            group = np.array([m])
        if not np.all(ok[group]):
            return None
        new_span = float(np.max(upper[group]))
        if new_span <= span:
            return group
        span = new_span


class ExactPropagator(Integrator):
    """Event search with exact modal propagation (``method="exact"``).

    Options
    -------
    time_tol : float
        Simultaneity window of a contact set and floor of the safe step (default 1e-12).
    max_steps : int
        Bound on search steps between two events (raises ``RuntimeError``).
    cache_size : int
        Number of free-set decompositions kept.
    compiled : bool or None
        With ``modes="runs"``: the per-event hot path by compiled kernels (:mod:`.run_kernels`):
        the modal coefficients, the start of the search, the search steps, the derivative bounds
        and, when every run has closed-form modes, the bracket, the Newton polish and its order
        repair, and the contact and lift-off sets; default: when numba is enabled
        (:mod:`tps_solver.core.jit`) and the lattice has at least :data:`COMPILED_MIN_NODES`
        nodes.  ``False``: the numpy reference (the same events to about 1e-13).
    modes : {"runs", "free_set"}
        ``"runs"`` (default): the free set decomposed run by run (:mod:`.runs`: closed-form
        modes on uniform planar lattices, O(n log n) per event); ``"free_set"``: one dense
        eigendecomposition of the whole free set per new free set (:class:`Modes`, O(n^3)),
        the reference.

    Examples
    --------
    The next event of a uniformly launched flat layer is the landing of all nodes
    one period ``T = 4 pi`` later:

    >>> from tps_solver import FlatLayer, Lattice
    >>> fl = FlatLayer(2.5, 2, e=0.45)
    >>> prop = ExactPropagator(Lattice.planar(n_nodes=3, length=2.0), 2.5, 0.45)
    >>> step = prop.advance(fl.t0, np.full(3, fl.velocity(fl.t0)), np.zeros(3), np.zeros(3, dtype=bool),
    ...                     t_stop=fl.t0 + fl.period + 1.0)
    >>> bool(abs(step.t - fl.t0 - 4 * np.pi) < 1e-12), step.contact.tolist()
    (True, [0, 1, 2])
    """

    name = "exact"
    OPTIONS = {"time_tol": 1e-12, "max_steps": 200000, "cache_size": 64, "modes": "runs", "compiled": None}

    def __init__(self, lattice, Gamma, e, **options):
        super().__init__(lattice, Gamma, e, **options)
        self.time_tol = check_positive(self.options["time_tol"], "time_tol")
        self.max_steps = check_int(self.options["max_steps"], "max_steps", minimum=1)
        self._cache = OrderedDict()
        self._cache_size = check_int(self.options["cache_size"], "cache_size", minimum=1)
        self._runs = None
        if check_choice(self.options["modes"], "modes", ("runs", "free_set")) == "runs":
            self._runs = RunCache.of(lattice, Modes, tri=tridiagonal(lattice))
        # default: compiled from COMPILED_MIN_NODES nodes on (numba's start in a fresh process, about
        # 2 s, is more than the kernels save on smaller lattices in most runs)
        self.compiled = jit.compiled_option(self.options["compiled"], lattice.n_nodes >= COMPILED_MIN_NODES)
        # imported on first use (inside the driver's loop)
        self._kernel = self._step_kernel = self._bounds_kernel = self._sets_kernel = self._bracket_kernel = None
        self._start_kernel = self._sum_kernel = self._bound_kernel = None
        #: compiled :func:`~.events.pulled_off` of the driver (with the run path's kernels), or None
        self.pulled_off_kernel = None
        if self.compiled and self._runs is not None:
            from tps_solver.solvers.fda.run_kernels import tri_pulled_off
            self.pulled_off_kernel = tri_pulled_off
        self._n_free_set = 0
        # absolute time until which a node released at rest is exempt from contact detection
        self._guard = np.full(lattice.n_nodes, -np.inf)

    @property
    def n_decompositions(self):
        """Dense eigendecompositions computed (free sets, or runs without closed form)."""
        return self._n_free_set + (self._runs.n_decompositions if self._runs is not None else 0)

    def modes(self, free):
        """Cached :class:`Modes` (or :class:`~.runs.RunModes`) of the free set ``free`` (bool mask)."""
        key = np.packbits(free).tobytes()
        if self._runs is not None:          # kept per lattice, across propagators (period maps)
            if self.compiled and self._kernel is None:
                from tps_solver.solvers.fda import run_kernels as rk
                self._kernel, self._step_kernel = rk.run_coefficients, rk.step_candidates
                self._bounds_kernel, self._sets_kernel = rk.closed_bounds12, rk.tri_event_sets
                self._bracket_kernel = rk.closed_bracket
                self._start_kernel, self._sum_kernel = rk.search_start, rk.closed_abs_sum
                self._bound_kernel = rk.closed_bound
            m = self._runs.modes(free, key)
            m.kernel, m.step_kernel = self._kernel, self._step_kernel
            m.bounds_kernel, m.sets_kernel = self._bounds_kernel, self._sets_kernel
            m.bracket_kernel = self._bracket_kernel if m.closed else None
            m.start_kernel = self._start_kernel
            m.sum_kernel = self._sum_kernel if m.closed else None
            m.bound_kernel = self._bound_kernel if m.closed else None
            return m
        m = self._cache.get(key)
        if m is None:
            m = Modes(self.lattice, free)
            self._n_free_set += 1
            self._cache[key] = m
            if len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return m

    def advance(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """Propagate to the next event or to ``t_stop`` (see :meth:`Integrator.advance`)."""
        return Step(*self._locate(t, w, zeta, stuck, t_stop, t_eval))

    def _locate(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """The next event as ``(t_new, w, zeta, contact, liftoff, samples)`` (pre-event state)."""
        Gamma = self.Gamma
        free = ~stuck
        md = self.modes(free)
        F, S = md.index, md.stuck
        seg = Segment(md, t, w[F], zeta[F], Gamma)
        L_FF, L_SF, absL_SF = md.L_FF, md.L_SF, md.absL_SF
        absL_FF = md.absL_FF
        has_stuck = S.size > 0
        t_eval = np.asarray(t_eval, dtype=float)
        samples = []
        nf = F.size
        t0 = t
        tau = 0.0
        tau_stop = t_stop - t0
        floor = 16 * _EPS * max(1.0, abs(t0) + abs(t_stop))
        # nodes at rest on the plate that are free: released stuck nodes (a = 0, da/dt > 0) are
        # certified for 3 (da/dt) / D_3, and exempted from contact detection until their height
        # exceeds the modal round-off (a guard, not a certificate; see the module docstring)
        wF, zF = w[F].copy(), zeta[F].copy()
        g0 = math.sin(t0) - 1.0 / Gamma
        start = getattr(md, "start_kernel", None)
        if start is not None:
            tri = L_FF.tri
            accF, jerk, eps_a, at_plate = np.empty(nf), np.zeros(nf), np.zeros(nf), np.empty(nf, dtype=bool)
            eps_w, eps_z, n_plate = start(wF, zF, F, tri.lower, tri.diag, tri.upper, g0, math.cos(t0), accF, jerk,
                                          eps_a, at_plate)
        else:
            accF = L_FF @ wF + g0
            eps_w = 64 * _EPS * (1.0 + np.abs(wF).max(initial=0.0))
            eps_z = 64 * _EPS * (1.0 + np.abs(zF).max(initial=0.0) + np.abs(wF).max(initial=0.0))
            at_plate = (zF == 0.0) & (np.abs(wF) <= eps_w)
            n_plate = np.count_nonzero(at_plate)
            if n_plate:
                eps_a = 64 * _EPS * (1.0 + abs(g0) + absL_FF @ np.abs(wF))
                jerk = L_FF @ accF + math.cos(t0)
        if n_plate:
            C = seg.derivative_bound(0.0, 3)
            # released within the simultaneity window: a >= -time_tol * da/dt (to round-off)
            rel = at_plate & (jerk > 0.0) & (np.abs(accF) <= eps_a + self.time_tol * jerk)
            delay = np.maximum(-accF[rel], 0.0) / jerk[rel]
            self._guard[F[rel]] = t0 + delay + np.maximum(3.0 * jerk[rel] / C[rel],
                                                          np.cbrt(6.0 * eps_z / jerk[rel]))
        release = self._guard[F] - t0
        step_kernel = getattr(md, "step_kernel", None)
        tri = L_FF.tri if step_kernel is not None else None
        steps = 0
        while True:
            steps += 1
            if steps > self.max_steps:
                raise RuntimeError(f"contact search made {self.max_steps} steps without an event "
                                   f"near t = {t0 + tau:.15g} (grazing contact?)")
            t_now = t0 + tau
            if tau > 0.0:
                wF, zF = seg.state(tau)
            g = math.sin(t_now) - 1.0 / Gamma
            dg = math.cos(t_now)
            A, B = seg.bounds12(tau)
            if step_kernel is not None:
                if steps == 1:
                    f, fp, Abound, h = np.empty((4, nf + S.size))        # rewritten in place at each step
                step_kernel(zF, wF, A, B, release - tau, eps_w, g, dg, F, S, tri.lower, tri.diag, tri.upper,
                            f, fp, Abound, h)
            else:
                f, fp, Abound, h = self._candidates(zF, wF, A, B, release - tau, eps_w, g, dg, L_FF, L_SF,
                                                    absL_SF, has_stuck)
            if h.size == 0:
                hm = np.inf
            else:
                m = int(np.argmin(h))
                hm = float(h[m])
            if tau + hm >= tau_stop:
                self._sample(seg, F, S, t0, tau, tau_stop, t_eval, samples, w.size)
                self.n_steps += steps
                wF, zF = seg.state(tau_stop) if tau_stop > 0 else (wF, zF)
                return (t_stop,) + self._full(F, w.size, wF, zF) + (
                    np.empty(0, int), np.empty(0, int), samples)
            event = None
            if fp[m] < 0.0 and fp[m] ** 2 >= 2.5 * Abound[m] * max(f[m], 0.0):
                event = self._bracket(seg, md, f, fp, Abound, h, tau, nf)
            if event is None and hm <= floor:
                event = (tau + hm, None)
            if event is not None:
                tau_c, _ = event
                self._sample(seg, F, S, t0, tau, tau_c, t_eval, samples, w.size)
                self.n_steps += steps
                out = self._finish(seg, md, t0, tau_c, w.size, samples)
                if out[3].size == 0 and out[4].size == 0:     # guarantee progress
                    if m < nf:
                        out = out[:3] + (F[[m]], out[4], samples)
                    else:
                        out = out[:4] + (S[[m - nf]], samples)
                return out
            self._sample(seg, F, S, t0, tau, tau + hm, t_eval, samples, w.size)
            tau += hm

    @staticmethod
    def _candidates(zF, wF, A, B, rel, eps_w, g, dg, L_FF, L_SF, absL_SF, has_stuck):
        """Candidates ``f``, slopes ``fp``, bounds and safe steps ``h`` of one search step (free rows, then stuck)."""
        accF = L_FF @ wF + g
        h_contact = _safe_step(zF, wF, A)
        # rising nodes (w >= 0 to round-off) are safe while w's lower bound stays positive
        h_rise = np.where(wF >= -eps_w, _safe_step(np.maximum(wF, 0.0), accF, B), 0.0)
        h_contact = np.maximum(np.maximum(h_contact, h_rise), rel)
        if not has_stuck:
            return zF, wF, A, h_contact
        # lift-off candidates: f = -a for stuck nodes
        accS = g + L_SF @ wF
        daccS = dg + L_SF @ accF
        CS = 1.0 + absL_SF @ B
        h_lift = _safe_step(-accS, -daccS, CS)
        return (np.concatenate((zF, -accS)), np.concatenate((wF, -daccS)), np.concatenate((A, CS)),
                np.concatenate((h_contact, h_lift)))

    # ------------------------------------------------------------ internals
    def _full(self, F, n, wF, zF):
        w = np.zeros(n)
        z = np.zeros(n)
        w[F] = wF
        z[F] = zF
        return w, z

    def _sample(self, seg, F, S, t0, tau_a, tau_b, t_eval, samples, n):
        if t_eval.size == 0:
            return
        sel = (t_eval > t0 + tau_a) & (t_eval <= t0 + tau_b)
        for te in t_eval[sel]:
            wF, zF = seg.state(te - t0)
            samples.append((float(te),) + self._full(F, n, wF, zF))

    def _candidate_value(self, seg, md, j, tau):
        """f_j at local time tau: zeta for free rows, -acceleration for stuck rows."""
        nf = md.index.size
        if j < nf:
            return seg.node_height(j, tau)
        wF, _ = seg.state(tau)
        g = math.sin(seg.t_c + tau) - 1.0 / self.Gamma
        if isinstance(md, RunModes):
            node = md.stuck[j - nf]
            u = np.zeros(self.lattice.n_nodes)
            u[md.index] = wF
            return -(g + float(md.L_SF.tri.apply(u)[node]))
        return -(g + md.L_SF[j - nf] @ wF)

    def _all_values(self, seg, md, tau):
        """All candidate functions at local time tau (heights, then minus stuck accelerations)."""
        wF, zF = seg.state(tau)
        g = math.sin(seg.t_c + tau) - 1.0 / self.Gamma
        return np.concatenate((zF, -(g + md.L_SF @ wF)))

    def _bracket(self, seg, md, f, fp, A, h, tau, nf):
        """Monotone brackets for the leading candidates; None if not all certified."""
        kern = getattr(md, "bracket_kernel", None)
        if kern is not None:
            tri = md.L_SF.tri
            segv = (md.lam, seg._a_ri, seg._rr, seg._ri, seg._sg, seg.zeta0)
            tau_c, group = kern(f, fp, A, h, float(tau), self.time_tol, segv, md.theta, md.end_code, md.offsets,
                                md.row_of, md.stuck, tri.lower, tri.diag, tri.upper, float(seg.t_c),
                                float(self.Gamma), nf)
            return None if tau_c < 0.0 else (tau_c, group)
        fpos = np.maximum(f, 0.0)
        disc = fp * fp - 2.0 * A * fpos
        ok = (fp < 0.0) & (fp * fp >= 2.5 * A * fpos)
        with np.errstate(invalid="ignore", divide="ignore"):
            upper = np.where(ok, 2.0 * fpos / (-fp + np.sqrt(np.maximum(disc, 0.0))), np.inf)
        m = int(np.argmin(h))
        group = candidate_group(h, upper, ok, m)
        if group is None:
            return None
        # earliest root: start from the smallest Newton estimate, then repair order
        newton = fpos[group] / -fp[group]
        lead = int(group[np.argmin(newton)])
        tau_hi = tau + upper[lead]
        tau_c = self._root(seg, md, lead, tau, tau_hi, f[lead], fp[lead], A[lead])
        for _ in range(group.size if group.size > 1 or not isinstance(md, RunModes) else 0):
            if isinstance(md, RunModes) and group.size <= 8:
                vals = np.array([self._value_slope(seg, md, int(j), tau_c)[0] for j in group])
            else:
                vals = self._all_values(seg, md, tau_c)[group]
            early = vals < -self.time_tol * np.abs(fp[group]) - 64 * _EPS
            if not np.any(early):
                break
            j = int(group[np.argmin(vals / -fp[group])])
            tau_c = self._root(seg, md, j, tau, tau_c, f[j], fp[j], A[j])
        return tau_c, group

    def _root(self, seg, md, j, lo, hi, f_lo, fp_lo, A):
        """The root of candidate ``j`` in its certified monotone bracket ``[lo, hi]`` (local times)."""
        if isinstance(md, RunModes):
            return self._newton_root(seg, md, j, lo, hi, f_lo, fp_lo, A)
        flo = self._candidate_value(seg, md, j, lo)
        fhi = self._candidate_value(seg, md, j, hi)
        if flo <= 0.0:
            return lo
        if fhi >= 0.0:          # round-off at the certified upper bound
            return hi
        return brentq(lambda s: self._candidate_value(seg, md, j, s), lo, hi,
                      xtol=1e-15, rtol=4 * _EPS, maxiter=200)

    def _value_slope(self, seg, md, j, tau):
        """``(f_j, f_j')`` at local time ``tau`` (run modes): height and velocity of a free row,
        minus the free acceleration and its rate of a stuck row."""
        nf = md.index.size
        if j < nf:
            r = md.run_index(j)
            o = md.offsets
            cw, cz = seg.coefficients(tau, slice(o[r], o[r + 1]))
            row = md.runs[r].row(j - o[r])
            return seg.zeta0[j] + row @ cz, row @ cw
        t = seg.t_c + tau
        g = math.sin(t) - 1.0 / self.Gamma
        tri = md.L_SF.tri
        node = int(md.stuck[j - nf])
        near = range(max(node - 2, 0), min(node + 3, tri.n))
        w = dict(zip(near, self._node_velocities(seg, md, near, tau)))

        def acc(k):                     # free acceleration of a free neighbour k (0 for a stuck one)
            if w[k] is None:
                return 0.0
            out = g + tri.diag[k] * w[k]
            for i, c in ((k - 1, tri.lower[k]), (k + 1, tri.upper[k])):
                if i in w and w[i] is not None:
                    out += c * w[i]
            return out

        f, fp = g, math.cos(t)
        for k, c in ((node - 1, tri.lower[node]), (node + 1, tri.upper[node])):
            if k in w and w[k] is not None:
                f += c * w[k]
                fp += c * acc(k)
        return -f, -fp

    def _node_velocities(self, seg, md, nodes, tau):
        """Velocities of lattice ``nodes`` at local time ``tau`` (None for a stuck node), run modes."""
        rows = np.searchsorted(md.index, nodes)
        o = md.offsets
        coef = {}
        out = []
        for node, j in zip(nodes, rows):
            if j >= md.index.size or md.index[j] != node:
                out.append(None)
                continue
            r = md.run_index(j)
            if r not in coef:
                coef[r] = seg.coefficients(tau, slice(o[r], o[r + 1]))[0]
            out.append(float(md.runs[r].row(j - o[r]) @ coef[r]))
        return out

    def _newton_root(self, seg, md, j, lo, hi, f_lo, fp_lo, A):
        r"""Newton's method kept inside the bracket (bisection when a step leaves it).

        With :math:`|f''| \le A` on the bracket, the step :math:`s = f/f'` leaves an error of at
        most :math:`A s^2/(2|f'|)`; the iteration stops once that is below 1e-16 (or the step below
        the ``brentq`` tolerance ``1e-15 + 4 eps |tau|``), so the root is as accurate as the
        ``brentq`` polish of the reference path, mostly in two or three evaluations.
        """
        if f_lo <= 0.0:
            return lo
        x, f, fp = lo, f_lo, fp_lo
        for _ in range(200):
            if fp < 0.0:
                step = f / fp
                x_new = x - step
                if lo < x_new < hi and A * step * step <= -1e-16 * fp:
                    return x_new
            else:
                x_new = 0.5 * (lo + hi)
            if not lo < x_new < hi:
                x_new = 0.5 * (lo + hi)
            if abs(x_new - x) <= 1e-15 + 4 * _EPS * abs(x_new) or hi - lo <= 1e-15 + 4 * _EPS * abs(hi):
                return x_new
            x = x_new
            f, fp = self._value_slope(seg, md, j, x)
            if f == 0.0:
                return x
            if f > 0.0:
                lo = x
            else:
                hi = x
        return x

    def _finish(self, seg, md, t0, tau_c, n, samples):
        """State at the event and the simultaneous sets (54)."""
        F, S = md.index, md.stuck
        wF, zF = seg.state(tau_c)
        t_c = t0 + tau_c
        g = math.sin(t_c) - 1.0 / self.Gamma
        sets = getattr(md, "sets_kernel", None)
        if sets is not None:
            if md.sum_kernel is not None:
                amp = np.empty(F.size)
                md.sum_kernel(seg._abs_a, md.offsets, amp)
            else:
                amp = md.absV @ seg._abs_a
            eps_z = 64 * _EPS * (1.0 + np.abs(seg.zeta0) + amp * max(1.0, tau_c))
            tri = md.L_SF.tri
            contact, liftoff = np.empty(F.size, dtype=np.int64), np.empty(S.size, dtype=np.int64)
            nc, nl = sets(g, math.cos(t_c), wF, zF, F, S, tri.lower, tri.diag, tri.upper, self.time_tol, eps_z,
                          contact, liftoff)
            contact, liftoff = contact[:nc], liftoff[:nl]
            contact = contact[self._guard[contact] <= t_c]
            w, z = self._full(F, n, wF, zF)
            return t_c, w, z, contact, liftoff, samples
        eps_z = 64 * _EPS * (1.0 + np.abs(seg.zeta0) + md.absV @ np.abs(seg.a) * max(1.0, tau_c))
        eps_a = 64 * _EPS * (1.0 + abs(g) + md.absL_SF @ np.abs(wF))
        contact, liftoff = event_sets(t_c, wF, zF, F, S, md.L_FF, md.L_SF, self.Gamma,
                                      self.time_tol, eps_z, eps_a, absL_FF=md.absL_FF)
        contact = contact[self._guard[contact] <= t_c]
        w, z = self._full(F, n, wF, zF)
        return t_c, w, z, contact, liftoff, samples
