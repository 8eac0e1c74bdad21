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
(as in :mod:`tps_solver.tps`).  The result is the N -> infinity limit of
:func:`~tps_solver.tps.solve_lattice`: a reference for its convergence in N and,
integrated by the FDA, for the FDA itself (the periodicity defect must be
round-off).
"""
import math
import time

import numpy as np
from scipy.linalg import eigh

from ._result import Bunch
from ._validation import check_int, check_positive, check_real
from .flat import FlatLayer

__all__ = ["LatticeCycle", "solve_lattice_cycle"]


def _phi1(z):
    """expm1(z)/z, = 1 at z = 0."""
    z = np.asarray(z, dtype=float)
    safe = np.where(z == 0.0, 1.0, z)
    return np.where(np.abs(z) < 1e-12, 1.0 + 0.5 * z, np.expm1(safe) / safe)


def _taylor_tail(z, order):
    """(e^z - sum_{k<order} z^k/k!) / z^order, cancellation-free: series for |z| < 1."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1.0
    zs = np.where(small, z, 0.0)
    # Horner on sum_{k>=0} z^k / (k + order)!, 24 terms (error < 1/24! for |z| < 1)
    acc = np.zeros_like(zs)
    for k in range(24, -1, -1):
        acc = acc * zs + 1.0 / math.factorial(k + order)
    zb = np.where(small, 1.0, z)
    direct = np.expm1(zb)
    for k in range(1, order):
        direct = direct - zb ** k / math.factorial(k)
    return np.where(small, acc, direct / zb ** order)


def _H(lam, tau, T):
    """H(lambda, tau) for tau in [0, T) (mean of the jump at tau = 0); lam <= 0, shape broadcast.

    With mu = lambda T and x = tau/T:  H = [f2(mu) - x phi1(mu x)] / phi1(mu), where
    phi1(z) = (e^z - 1)/z and f2(z) = (e^z - 1 - z)/z^2 -- free of the 1/mu cancellation of
    the textbook form and equal to 1/2 - x at mu = 0.  At x = 0 the mean of the jump,
    f2/phi1 - 1/2, is returned.
    """
    lam, tau = np.broadcast_arrays(np.asarray(lam, dtype=float), np.asarray(tau, dtype=float))
    mu = lam * T
    x = tau / T
    p1 = _phi1(mu)
    f2 = _taylor_tail(mu, 2)
    val = (f2 - x * _phi1(mu * x)) / p1
    return np.where(tau == 0.0, f2 / p1 - 0.5, val)


def _H_int(lam, tau, T):
    """Zero-mean antiderivative of H in tau (continuous, T-periodic):
    T [f2(mu) x - x^2 f2(mu x) - (f2(mu)/2 - f3(mu))] / phi1(mu)."""
    lam, tau = np.broadcast_arrays(np.asarray(lam, dtype=float), np.asarray(tau, dtype=float))
    mu = lam * T
    x = tau / T
    f2 = _taylor_tail(mu, 2)
    f3 = _taylor_tail(mu, 3)
    return T * (f2 * x - x * x * _taylor_tail(mu * x, 2) - (0.5 * f2 - f3)) / _phi1(mu)


class LatticeCycle(Bunch):
    """Exact periodic orbit of a lattice (result of :func:`solve_lattice_cycle`).

    Attributes
    ----------
    converged, success : bool
    status : int
        0 converged; 1 iteration limit; 2 Newton stagnated; 4 continuation ended before
        full coupling (a fold).
    message : str
    nit : int
    residual : float
    residual_history : ndarray of float
    tc : ndarray of float, shape (n_nodes,)
    nodes : ndarray of float, shape (n_nodes,)
    geometry : str
        The lattice's geometry ("planar" or "axisymmetric").
    coupling : float
        Coupling reached (1: the lattice as given).
    lattice, flat, Gamma, e, M, t0, period
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
        t = np.atleast_1d(np.asarray(t, dtype=float))
        tau = np.mod(t[:, None] - self.tc[None, :], self.period)      # (nt, k)
        Hk = _H(self._lam[None, None, :], tau[:, :, None], self.period)  # (nt, k, p)
        # w_j = -cos t + J sum_k sum_p V_jp H_p(tau_k) Vinv_pk
        coef = np.einsum("tkp,pk->tp", Hk, self._Vinv)
        w = -np.cos(t)[:, None] + self.J * coef @ self._V.T
        at = tau == 0.0
        return w + np.where(at, 0.5 * self.J, 0.0)

    def height(self, t):
        """Node heights zeta(t), exact, with zeta(tc) = 0 at every node.

        Returns
        -------
        ndarray of float, shape (n_times, n_nodes)
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self._height_raw(t) - self._zeta_offset[None, :]

    def _height_raw(self, t):
        tau = np.mod(t[:, None] - self.tc[None, :], self.period)
        Hk = _H_int(self._lam[None, None, :], tau[:, :, None], self.period)
        coef = np.einsum("tkp,pk->tp", Hk, self._Vinv)
        return -np.sin(t)[:, None] + self.J * coef @ self._V.T


class _CycleProblem:
    """F(tc) = 0 for the exact lattice cycle, with the interface used by tps._newton."""

    def __init__(self, lattice, flat, coupling):
        D = np.asarray(lattice.volumes, dtype=float)
        S = np.asarray(lattice.flux, dtype=float)
        sq = np.sqrt(D)
        lam, U = eigh(S / np.outer(sq, sq))
        self.lam = coupling * np.minimum(lam, 0.0)
        self.V = U / sq[:, None]
        self.Vinv = U.T * sq[None, :]
        self.T = flat.period
        self.J = flat.period / flat.Gamma
        self.t0 = flat.t0
        self.level = -math.cos(flat.t0)
        self.coupling = coupling

    def residual(self, tc):
        """F(tc) and H(lambda_p, tc_j - tc_k) of shape (j, k, p), reused by the Jacobian."""
        tau = np.mod(tc[:, None] - tc[None, :], self.T)                     # (j, k)
        Hjk = _H(self.lam[None, None, :], tau[:, :, None], self.T)          # (j, k, p)
        R = np.einsum("jp,jkp,pk->jk", self.V, Hjk, self.Vinv)
        F = -np.cos(tc) + self.J * np.sum(R, axis=1) - self.level
        return F, Hjk, None

    def jacobian_operator(self, tc, Hjk, _):
        from scipy.sparse.linalg import aslinearoperator

        n = tc.size
        # R'(tau) = V diag(lam H - 1/T) V^{-1}  (= A R - I/T)
        dH = self.lam[None, None, :] * Hjk - 1.0 / self.T
        Rp = np.einsum("jp,jkp,pk->jk", self.V, dH, self.Vinv)
        Jm = -self.J * Rp
        Jm[np.arange(n), np.arange(n)] += np.sin(tc) + self.J * np.sum(Rp, axis=1)
        slope = np.diag(Jm).copy()
        return aslinearoperator(Jm), slope


def solve_lattice_cycle(lattice, Gamma=2.5, M=2, e=None, t0=0.0, tc_initial=None, *, r_core=1.0,
                        tol=1e-12, max_iter=50, continuation=True):
    r"""Exact single-contact periodic orbit of an FDA lattice (see the module docstring).

    Parameters
    ----------
    lattice : tps_solver.fda.Lattice
        Neumann ends (planar) or axisymmetric.
    Gamma, M, e, t0 : as in :func:`~tps_solver.solve_kink`.
    tc_initial : None, array_like (n_nodes,) or callable
        Default as in :func:`~tps_solver.tps.solve_lattice` (kink step or oscillon core).
    r_core : float
    tol : float
    max_iter : int
    continuation : bool
        Follow the branch from the decoupled limit in the coupling.

    Returns
    -------
    LatticeCycle

    Examples
    --------
    >>> from tps_solver.fda import Lattice
    >>> cyc = solve_lattice_cycle(Lattice.planar(n_nodes=8, length=140.0), e=0.45, t0=None)
    >>> cyc.converged
    True
    """
    from . import tps as tps_module
    from .fda import Lattice

    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    if lattice.boundary != "neumann":
        raise ValueError(f"lattice.boundary must be 'neumann' for the exact cycle, got {lattice.boundary!r}")
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    flat = FlatLayer(Gamma, M, e=e, t0=t0)
    tol = check_positive(tol, "tol")
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    r_core = check_real(r_core, "r_core")
    x = np.asarray(lattice.nodes, dtype=float)
    tc = tps_module._lattice_initial_tc(lattice, flat, tc_initial, r_core)
    start = time.perf_counter()
    make = lambda nu: _CycleProblem(lattice, flat, nu)
    nu_start = (lattice.spacing / tps_module._decoupled_spacing(M)) ** 2
    path = []
    if continuation and nu_start < 1.0:
        tc, _, status, message, nit, history, path, problem = tps_module._continuation(
            make, tc.astype(float), tol, max_iter, nu_start)
    else:
        problem = make(1.0)
        tc, _, status, message, nit, history = tps_module._newton(problem, tc.astype(float), tol, max_iter)
    tc = np.mod(tc, flat.period)
    cyc = LatticeCycle(
        converged=status == 0, success=status == 0, status=status, message=message, nit=nit,
        residual=history[-1], residual_history=np.asarray(history), tc=tc, nodes=x.copy(),
        geometry=lattice.geometry,
        coupling=problem.coupling, lattice=lattice, flat=flat, Gamma=Gamma, e=flat.e, M=M,
        t0=flat.t0, period=flat.period, J=problem.J, time=time.perf_counter() - start,
        continuation_path=np.asarray(path, dtype=float).reshape(-1, 3))
    cyc._lam, cyc._V, cyc._Vinv = problem.lam, problem.V, problem.Vinv
    cyc._zeta_offset = np.zeros(x.size)
    cyc._zeta_offset = np.diag(cyc._height_raw(tc))
    return cyc
