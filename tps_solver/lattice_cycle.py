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
from ._validation import check_array, check_int, check_positive, check_real
from .flat import FlatLayer

__all__ = ["LatticeCycle", "solve_lattice_cycle"]


def _H(lam, tau, T):
    """H(lambda, tau) for tau in [0, T) (mean of the jump at tau = 0); lam <= 0, shape broadcast."""
    lam = np.asarray(lam, dtype=float)
    tau = np.asarray(tau, dtype=float)
    zero = np.abs(lam) * T < 1e-9
    lt = np.where(zero, -1.0, lam)
    em = np.expm1(lt * T)                           # e^{lam T} - 1 < 0
    val = -np.exp(lt * tau) / em + 1.0 / (lt * T)
    at0 = tau == 0.0
    val = np.where(at0, -(np.exp(lt * T) + 1.0) / (2.0 * em) + 1.0 / (lt * T), val)
    saw = np.where(at0, 0.0, 0.5 - tau / T)
    return np.where(zero, saw, val)


def _H_int(lam, tau, T):
    """Zero-mean antiderivative of H in tau (continuous, T-periodic)."""
    lam = np.asarray(lam, dtype=float)
    tau = np.asarray(tau, dtype=float)
    zero = np.abs(lam) * T < 1e-9
    lt = np.where(zero, -1.0, lam)
    em = np.expm1(lt * T)
    # int H = -e^{l tau}/(l em) + tau/(l T) + C; zero mean: mean of first two terms is
    # -1/(l^2 T) + T/(2 l T) -> C = 1/(l^2 T) - 1/(2 l)
    val = -np.exp(lt * tau) / (lt * em) + tau / (lt * T) + 1.0 / (lt * lt * T) - 0.5 / lt
    x = tau / T
    z = T * (x / 2 - x * x / 2 - 1.0 / 12.0)         # int of (1/2 - tau/T), zero mean
    return np.where(zero, z, val)


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
        self.A = (self.V * self.lam) @ self.Vinv

    def _R_pairs(self, tc):
        tau = np.mod(tc[:, None] - tc[None, :], self.T)                     # (j, k)
        Hjk = _H(self.lam[None, None, :], tau[:, :, None], self.T)          # (j, k, p)
        return np.einsum("jp,jkp,pk->jk", self.V, Hjk, self.Vinv)

    def residual(self, tc):
        R = self._R_pairs(tc)
        F = -np.cos(tc) + self.J * np.sum(R, axis=1) - self.level
        return F, R, None

    def jacobian_operator(self, tc, R, _):
        from scipy.sparse.linalg import aslinearoperator

        n = tc.size
        # R'(tau) = V diag(lam H - 1/T) V^{-1}  (= A R - I/T)
        tau = np.mod(tc[:, None] - tc[None, :], self.T)
        Hjk = _H(self.lam[None, None, :], tau[:, :, None], self.T)
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
    if tc_initial is None:
        if M % 2:
            raise ValueError(f"tc_initial must be given for odd M (got M = {M})")
        if lattice.geometry == "planar":
            tc = np.where(x >= 0.0, flat.t0, flat.t0 + flat.period / 2)
        else:
            tc = np.where(x < r_core, flat.t0 + flat.period / 2, flat.t0)
    elif callable(tc_initial):
        tc = check_array(tc_initial(x.copy()), "tc_initial", shape=(x.size,))
    else:
        tc = check_array(tc_initial, "tc_initial", shape=(x.size,))
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
        coupling=problem.coupling, lattice=lattice, flat=flat, Gamma=Gamma, e=flat.e, M=M,
        t0=flat.t0, period=flat.period, J=problem.J, time=time.perf_counter() - start,
        continuation_path=np.asarray(path, dtype=float).reshape(-1, 3))
    cyc._lam, cyc._V, cyc._Vinv = problem.lam, problem.V, problem.Vinv
    cyc._zeta_offset = np.zeros(x.size)
    cyc._zeta_offset = np.diag(cyc._height_raw(tc))
    return cyc
