r"""Exact single-contact periodic orbits of an FDA lattice (the TPS without truncation).

On a lattice with Neumann (no-flux) ends, the FDA (53)-(54) with one impact per
node and period, of the impulse :math:`J = T/\Gamma` fixed by the mean balance
(44), is linear between impacts, so its T-periodic response is available in
closed form.  With the symmetrisable lattice operator
:math:`A = \nu_c \underline L = V\Lambda V^{-1}` (``eigh`` of
:math:`D^{1/2} A D^{-1/2}`, D the cell volumes) and node k forced by
:math:`J[\delta_T(t - t_{c,k}) - 1/T] + \sin t`,

.. math::
    \underline w(t) = -\cos t\,\underline\sigma + J \sum_k R(t - t_{c,k})\,\underline e_k ,
    \qquad R(\tau) = V \operatorname{diag}\big(H(\lambda_p, \tau)\big) V^{-1},

    H(\lambda, \tau) = \frac{e^{\lambda\tau}}{1 - e^{\lambda T}} + \frac{1}{\lambda T}
    \quad (\tau \in (0, T)), \qquad H(0, \tau) = \tfrac12 - \tau/T ,

the zero-mean periodic response of :math:`y' = \lambda y + \delta_T - 1/T`; it
jumps by +1 at :math:`\tau = 0` (the value there is the jump's mean).  This is the
sum of the TPS Fourier series (38)-(39) with the Helmholtz solves (45) done by
:math:`(A - in\alpha)^{-1}`, to all orders: :math:`\hat H_n = 1/(T(in\alpha - \lambda))`.
The contact condition (46) becomes

.. math:: F_j = \cos t_0 - \cos t_{c,j} + J \sum_k R_{jk}(t_{c,j} - t_{c,k}) = 0 ,

with :math:`R' = A R - I/T`, solved by Newton with continuation in the coupling
(as in :mod:`tps_solver.solvers.tps`).  The result is the N -> infinity limit of
:func:`~tps_solver.solvers.tps.solve_lattice`: a reference for its convergence in N and,
integrated by the FDA, for the FDA itself (the periodicity defect must be
round-off).
"""
import math
import time

import numpy as np

from tps_solver.core import archive as io
from tps_solver.core import defaults
from tps_solver.core.checks import check_int, check_positive, check_real, check_restitution
from tps_solver.model.restitution import as_restitution
from tps_solver.core.costs import blas_threads, check_cost, cycle_cost, small_dense
from tps_solver.operators.lattice import Lattice
from tps_solver.operators.modal import ModalBasis, kernel, kernel_integral
from tps_solver.core.orbit import PeriodicOrbit, far_field
from tps_solver.solvers.tps.engine import TimePeriodicProblem, continuation as run_continuation, newton
from tps_solver.solvers.tps.problems import bouncing_far_field, decoupled_spacing
from tps_solver.solvers.tps.solvers import lattice_initial_tc, next_steps

#: Bytes of one block of the (rows x nodes x modes) tensors of the cycle residual (about six live
#: at once); up to about 220 nodes the whole tensor is one block and the Jacobian reuses it.
BLOCK_BYTES = 512e6

__all__ = ["LatticeCycle", "solve_lattice_cycle"]


class LatticeCycle(PeriodicOrbit):
    r"""Exact periodic orbit of a lattice (result of :func:`solve_lattice_cycle`).

    Attributes
    ----------
    converged, success : bool
    status : int
        A code of :data:`tps_solver.core.orbit.STATUS` (0 converged, 1 iteration limit,
        2 stagnation, 3 contact-time failure, 4 the branch ended at a fold, 5 interrupted).
    message : str
    nit : int
    residual : float
    residual_history : ndarray of float
    tc : ndarray of float, shape (n_nodes,)
    nodes, nodes_requested : ndarray of float, shape (n_nodes,)
        The lattice's nodes (the same: a coupling < 1 scales the operator, not the nodes).
    geometry : str
        The lattice's geometry ("planar" or "axisymmetric").
    coupling : float
        Coupling reached (1: the lattice as given).
    lattice, flat, Gamma, e, M, t0, period
        As in :class:`~tps_solver.core.orbit.PeriodicOrbit`.
    J : float
        The impulse per contact, T/Gamma (44).
    eigenvalues : ndarray of float, shape (n_nodes,)
        :math:`\lambda_p` of the coupled lattice operator :math:`A = \nu_c \underline L`.
    modes, modes_inv : ndarray of float, shape (n_nodes, n_nodes)
        :math:`V` and :math:`V^{-1}` with :math:`A = V\Lambda V^{-1}`.
    zeta_offset : ndarray of float, shape (n_nodes,)
        Constant that makes :math:`\zeta(t_c) = 0` at every node (40).
    continuation_path : ndarray of float, shape (k, 3)
        (coupling, Newton steps, residual) per accepted continuation point.
    time : float

    Examples
    --------
    The default lattice (8 nodes, spacing 20): every node leaves the plate once per period
    with the velocity jump J = T/Gamma = 4 pi / 2.5, at height zero:

    >>> from tps_solver import Lattice, solve_lattice_cycle
    >>> cyc = solve_lattice_cycle(Lattice.planar(n_nodes=8, length=140.0))
    >>> cyc.converged, cyc.status, cyc.coupling, round(cyc.J, 6), round(4 * math.pi / 2.5, 6)
    (True, 0, 1.0, 5.026548, 5.026548)
    >>> w = cyc.velocity(np.array([cyc.tc[0] - 1e-9, cyc.tc[0]]))[:, 0]
    >>> round(float(w[1] - w[0]), 6)
    5.026548
    >>> bool(np.max(np.abs(np.diag(cyc.height(cyc.tc)))) < 1e-12)
    True
    >>> round(float(cyc.eigenvalues[0]), 12), bool(abs(cyc.eigenvalues[-1]) < 1e-12)  # -4/20**2, zero mode
    (-0.01, True)
    """

    def velocity(self, t):
        """Node velocities w(t), exact; post-impact value at t = tc.

        Parameters
        ----------
        t : array_like of float, shape (n_times,)

        Returns
        -------
        ndarray of float, shape (n_times, n_nodes)
        """
        t = self.as_times(t)
        return np.concatenate([self._velocity_block(tb) for tb in _time_blocks(t, self.tc.size)], axis=0)

    def _velocity_block(self, t):
        tau = np.mod(t[:, None] - self.tc[None, :], self.period)      # (nt, k)
        Hk = kernel(self.eigenvalues[None, None, :], tau[:, :, None], self.period)  # (nt, k, p)
        # w_j = -cos t + J sum_k sum_p V_jp H_p(tau_k) Vinv_pk
        coef = np.einsum("tkp,pk->tp", Hk, self.modes_inv)
        w = -np.cos(t)[:, None] + self.J * coef @ self.modes.T
        at = tau == 0.0
        return w + np.where(at, 0.5 * self.J, 0.0)

    def height(self, t):
        """Node heights zeta(t), exact, with zeta(tc) = 0 at every node.

        Returns
        -------
        ndarray of float, shape (n_times, n_nodes)
        """
        t = self.as_times(t)
        return self._height_raw(t) - self.zeta_offset[None, :]

    def save(self, path):
        """Write the cycle to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return io.save(self, path)

    def _height_raw(self, t):
        return np.concatenate([self._height_block(tb) for tb in _time_blocks(t, self.tc.size)], axis=0)

    def _height_block(self, t):
        tau = np.mod(t[:, None] - self.tc[None, :], self.period)
        Hk = kernel_integral(self.eigenvalues[None, None, :], tau[:, :, None], self.period)
        coef = np.einsum("tkp,pk->tp", Hk, self.modes_inv)
        return -np.sin(t)[:, None] + self.J * coef @ self.modes.T


def _time_blocks(t, n):
    """Split ``t`` so that one (times x n x n) block stays within BLOCK_BYTES."""
    step = max(1, int(BLOCK_BYTES // (8 * 6 * n * n)))
    return [t[i:i + step] for i in range(0, max(t.size, 1), step)] if t.size else [t]


def _row_blocks(n):
    step = max(1, int(BLOCK_BYTES // (8 * 6 * n * n)))
    return [slice(i, min(i + step, n)) for i in range(0, n, step)]


class CycleProblem(TimePeriodicProblem):
    """F(tc) = 0 for the exact lattice cycle (the problem protocol of :mod:`tps_solver.solvers.tps.engine`)."""

    def __init__(self, lattice, flat, coupling):
        modes = ModalBasis(lattice, coupling)
        self.lam, self.V, self.Vinv = modes.lam, modes.V, modes.Vinv
        self.T = flat.period
        self.J = flat.period / flat.Gamma
        self.t0 = flat.t0
        self.level = -math.cos(flat.t0)
        self.coupling = coupling

    def _blocks(self, tc, derivative):
        """R_jk = sum_p V_jp H(lambda_p, tc_j - tc_k) Vinv_pk (``derivative``: R', H -> lambda H - 1/T,
        i.e. R' = A R - I/T), in row blocks so that the (rows, k, p) tensor stays within
        BLOCK_BYTES.  With a single block the tensor H is returned too (the Jacobian reuses it)."""
        n = tc.size
        blocks = _row_blocks(n)
        R = np.empty((n, n))
        H = None
        for rows in blocks:
            tau = np.mod(tc[rows, None] - tc[None, :], self.T)                  # (j, k)
            Hjk = kernel(self.lam[None, None, :], tau[:, :, None], self.T)          # (j, k, p)
            if len(blocks) == 1:
                H = Hjk
            if derivative:
                Hjk = self.lam[None, None, :] * Hjk - 1.0 / self.T
            R[rows] = np.einsum("jp,jkp,pk->jk", self.V[rows], Hjk, self.Vinv)
        return R, H

    def residual(self, tc):
        """F(tc) and, when it fits in one block, H(lambda_p, tc_j - tc_k) for the Jacobian."""
        R, H = self._blocks(tc, derivative=False)
        F = -np.cos(tc) + self.J * np.sum(R, axis=1) - self.level
        return F, H, None

    def jacobian_operator(self, tc, H, _phase):
        from scipy.sparse.linalg import aslinearoperator

        n = tc.size
        # R'(tau) = V diag(lam H - 1/T) V^{-1}  (= A R - I/T)
        if H is not None:
            dH = self.lam[None, None, :] * H - 1.0 / self.T
            Rp = np.einsum("jp,jkp,pk->jk", self.V, dH, self.Vinv)
        else:
            Rp = self._blocks(tc, derivative=True)[0]
        Jm = -self.J * Rp
        Jm[np.arange(n), np.arange(n)] += np.sin(tc) + self.J * np.sum(Rp, axis=1)
        slope = np.diag(Jm).copy()
        return aslinearoperator(Jm), slope


def solve_lattice_cycle(lattice, Gamma=defaults.GAMMA, M=defaults.M, e=None, t0=None, tc_initial=None, *,
                        r_core=defaults.R_CORE, tol=1e-12, max_iter=defaults.MAX_ITER, continuation=True,
                        callback=None):
    r"""Exact single-contact periodic orbit of an FDA lattice (see the module docstring).

    Parameters
    ----------
    lattice : tps_solver.solvers.fda.Lattice
        Neumann ends (planar) or axisymmetric.  Single-contact cycles exist only
        for spacings above about 13.6 (:data:`tps_solver.core.defaults.FOLD_SPACING_LATTICE`),
        e.g. ``Lattice.planar(**tps_solver.core.defaults.COARSE_LATTICE)``.
    Gamma, M, e, t0 : as in :func:`~tps_solver.solve_kink`.
        Default: ``e = 0.45`` (neither ``e`` nor ``t0`` given).  ``e`` may be a restitution law
        (:mod:`tps_solver.model.restitution`): every node of a single-contact cycle takes the
        impulse T/Gamma per period, so every node lands at the flat orbit's impact speed and the
        cycle is that of the constant ``e = e(v_flat)`` (``cyc.e``); the law changes only the
        multipliers (through :math:`\phi'`, in the FDA's).
    tc_initial : None, array_like (n_nodes,) or callable
        Default as in :func:`~tps_solver.solvers.tps.solve_lattice` (kink step or oscillon core).
    r_core : float
    tol : float
    max_iter : int
    continuation : bool
        Follow the branch from the decoupled limit in the coupling.
    callback : callable, optional
        ``callback(state)`` after each Newton step (each accepted continuation point), a
        :class:`~tps_solver.core.progress.ProgressState` with ``iteration``, ``residual`` and ``tc``.  A ``KeyboardInterrupt`` returns ``status=5`` with the
        last accepted iterate.

    Returns
    -------
    LatticeCycle

    Notes
    -----
    The work is O(n_nodes^3) per Newton step; the cost is estimated first and a lattice
    out of reach raises ``ValueError`` (:mod:`tps_solver.core.costs`).  The small dense
    kernels run on one BLAS thread (:func:`tps_solver.core.costs.blas_threads`).

    Examples
    --------
    >>> from tps_solver.solvers.fda import Lattice
    >>> cyc = solve_lattice_cycle(Lattice.planar(n_nodes=8, length=140.0))
    >>> cyc.converged, round(cyc.e, 2)
    (True, 0.45)
    """
    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    if lattice.boundary != "neumann":
        raise ValueError(f"lattice.boundary must be 'neumann' for the exact cycle, got {lattice.boundary!r}")
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    if e is not None:
        law = as_restitution(e)
        e = check_restitution(law.e, "e") if law.constant else law
    flat = bouncing_far_field(Gamma, M, **defaults.model(e, t0))
    tol = check_positive(tol, "tol")
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    r_core = check_real(r_core, "r_core")
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable or None, got {type(callback).__name__}")
    check_cost("solve_lattice_cycle", "lattice.n_nodes", lattice.n_nodes, *cycle_cost(lattice.n_nodes),
               hint="the work is O(n_nodes^3) per Newton step; single-contact cycles need spacing "
                    f">= {defaults.FOLD_SPACING_LATTICE:g} anyway")
    x = np.asarray(lattice.nodes, dtype=float)
    tc = lattice_initial_tc(lattice, flat, tc_initial, r_core)
    start = time.perf_counter()
    make = lambda nu: CycleProblem(lattice, flat, nu)
    nu_start = (lattice.spacing / decoupled_spacing(M)) ** 2
    path = []
    with blas_threads(1, enabled=small_dense(lattice.n_nodes)):
        if continuation and nu_start < 1.0:
            tc, _, status, message, nit, history, path, problem = run_continuation(
                make, tc.astype(float), tol, max_iter, nu_start, callback)
        else:
            problem = make(1.0)
            tc, _, status, message, nit, history = newton(problem, tc.astype(float), tol, max_iter,
                                                          callback)
    tc = np.mod(tc, flat.period)
    if status != 0:
        message = message.rstrip()
        message += "" if message.endswith(".") else "."
        if problem.coupling < 1.0:
            message += (f" The fields belong to the lattice operator scaled by coupling = "
                        f"{problem.coupling:.4g} (nodes unchanged).")
        message += next_steps(status, flat, lattice.geometry, float(x[-1]), x.size, lattice)
    cyc = LatticeCycle(
        converged=status == 0, success=status == 0, status=status, message=message, nit=nit,
        residual=history[-1], residual_history=np.asarray(history), tc=tc, nodes=x.copy(),
        nodes_requested=x.copy(), geometry=lattice.geometry,
        coupling=problem.coupling, lattice=lattice, flat=flat, Gamma=Gamma, e=flat.e, M=M,
        t0=flat.t0, period=flat.period, J=problem.J, time=time.perf_counter() - start,
        continuation_path=np.asarray(path, dtype=float).reshape(-1, 3))
    cyc.eigenvalues, cyc.modes, cyc.modes_inv = problem.lam, problem.V, problem.Vinv
    cyc.zeta_offset = np.zeros(x.size)
    cyc.zeta_offset = np.diag(cyc._height_raw(tc))
    cyc.far_field_stable, cyc.far_field_multipliers, note = far_field(flat)
    if note:
        cyc.message += "; " + note.rstrip()
    return cyc


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_cycle(f):
    from tps_solver.model.flat import FlatLayer
    from tps_solver.core.orbit import STATUS

    fl = f.instance("flat", FlatLayer)
    e = f.float("e")
    if e != fl.e:
        f.fail(f"inconsistent: the stored e = {e!r} but the flat layer has e = {fl.e:.15g} by (19)")
    lattice = f.instance("lattice", Lattice)
    n = lattice.n_nodes
    tc = f.array("tc", "f", shape=(n,), finite=True)
    if np.any(tc < 0) or np.any(tc >= fl.period):
        f.fail(f"the field 'tc' must lie in [0, T) with T = 2 pi M = {fl.period:.6g}")
    f.array("modes", "f", shape=(n, n), finite=True)
    f.status(STATUS)


io.register("LatticeCycle", LatticeCycle, validate=_validate_cycle)
