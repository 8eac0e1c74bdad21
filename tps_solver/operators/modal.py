r"""The modal decomposition of a Neumann lattice and the all-orders periodic kernel.

One home for what the exact lattice cycle (:mod:`tps_solver.solvers.tps.cycle`) and the
impact-and-stick TPS (:mod:`tps_solver.solvers.tps.stick_problem`) share.

**Modes.**  The lattice operator :math:`A = \nu_c\underline L` of a lattice with cell volumes
:math:`D` and symmetric flux matrix :math:`S` (:math:`\underline L = D^{-1}S`) is
diagonalised through the symmetric :math:`D^{-1/2} S D^{-1/2} = U\Lambda U^T` (``eigh``):
:math:`A = V\Lambda V^{-1}` with :math:`V = D^{-1/2}U`, :math:`V^{-1} = U^T D^{1/2}`
(:class:`ModalBasis`).  Eigenvalues above 0 (round-off of the Neumann zero mode) are set to 0;
the zero mode is then 0 to round-off.

**Kernel.**  The zero-mean :math:`T`-periodic response of
:math:`y' = \lambda y + \delta_T(\tau) - 1/T` (the sum of the TPS Fourier series to all
orders, :math:`\hat H_n = 1/(T(in\alpha - \lambda))`) is

.. math::
    H(\lambda, \tau) = \frac{e^{\lambda\tau}}{1 - e^{\lambda T}} + \frac{1}{\lambda T}
    = \frac{\varphi_2(\mu) - x\,\varphi_1(\mu x)}{\varphi_1(\mu)},
    \qquad \mu = \lambda T,\; x = \tau/T \in (0, 1),

with :math:`\varphi_1(z) = (e^z - 1)/z`, :math:`\varphi_2(z) = (e^z - 1 - z)/z^2`
(:func:`kernel`); the zero mode is :math:`H(0, \tau) = 1/2 - x`.  It jumps by +1 at
:math:`\tau = 0`.  Its zero-mean antiderivative (:func:`kernel_integral`) is

.. math::
    \int H\,d\tau = T\,\frac{\varphi_2(\mu)\,x - x^2\varphi_2(\mu x) - (\varphi_2(\mu)/2 - \varphi_3(\mu))}
    {\varphi_1(\mu)}, \qquad \varphi_3(z) = (e^z - 1 - z - z^2/2)/z^3 .

Both use the :math:`\varphi`-form for :math:`|\mu| \le 1` (3 for the integral; no
:math:`1/\mu` cancellation) and the textbook form (no cancellation either:
:math:`1/(1 - e^\mu)` is O(1)) beyond, where the :math:`\varphi`-form would cancel
(:math:`\varphi_2(\mu) \approx x\varphi_1(\mu x)` for :math:`x \to 1`).  Measured against
mpmath at 50 digits (tests/test_modal.py) for :math:`\lambda T \in [-10^3, -10^{-12}]` and
:math:`\tau` across :math:`(0, T)`: error at most ``KERNEL_ULPS`` eps times
:math:`|H| + |\tau\,\partial_\tau H|` (the error that rounding :math:`\tau` alone causes; it
is the relative error away from the zero of :math:`H`), likewise for the integral.
"""
import numpy as np
from scipy.linalg import eigh

from tps_solver.core import archive
from tps_solver.model.flight import phi1, taylor_tail

__all__ = ["ModalBasis", "kernel", "kernel_integral", "KERNEL_ULPS"]

#: Measured bound (in eps) of the kernel error (module docstring; tests/test_modal.py).
KERNEL_ULPS = 8

_DIRECT = 1.0                  # |lambda T| above this: the textbook form of H (no cancellation there)
_ZERO_MODE = 1e-10             # |lambda T| below this: the zero mode's closed form in the separable tables
_DIRECT_INT = 3.0              # the same for the integral (its 1/mu^2 terms cancel for |mu| ~ 1)


def _forms(lam, tau, T, threshold):
    lam, tau = np.broadcast_arrays(np.asarray(lam, dtype=float), np.asarray(tau, dtype=float))
    mu = lam * T
    return lam, tau, mu, np.abs(mu) > threshold


def _by_modes(lam, tau, threshold, T):
    """For ``lam`` of shape (1, ..., 1, P) and ``tau`` of shape (..., 1): the modes of each form.

    Returns None for other shapes (the elementwise masks of :func:`_forms` then apply).
    """
    lam, tau = np.asarray(lam, dtype=float), np.asarray(tau, dtype=float)
    if (lam.ndim == 0 or lam.ndim != tau.ndim or tau.shape[-1] != 1 or lam.shape[-1] == 1
            or any(d != 1 for d in lam.shape[:-1])):
        return None
    lam = lam.reshape(-1)
    big = np.abs(lam * T) > threshold
    return lam, tau, np.nonzero(big)[0], np.nonzero(~big)[0]


def kernel(lam, tau, T, at_jump="mean"):
    r"""The all-orders periodic kernel :math:`H(\lambda, \tau)` (module docstring), vectorised.

    Parameters
    ----------
    lam : array_like of float
        Eigenvalues, <= 0 (broadcast against ``tau``).
    tau : array_like of float
        Times in [0, T).
    T : float
        Period.
    at_jump : {"mean", "right"}
        Value at :math:`\tau = 0`, where :math:`H` jumps by +1: the mean of the jump
        (``"mean"``) or the limit from the right :math:`\tau \to 0^+` (``"right"``).

    Returns
    -------
    ndarray of float

    Examples
    --------
    >>> float(kernel(0.0, 1.0, 4.0)), round(float(kernel(-1e-12, 1.0, 4.0)), 12)     # 1/2 - tau/T
    (0.25, 0.25)
    >>> float(kernel(0.0, 0.0, 4.0)), float(kernel(0.0, 0.0, 4.0, at_jump="right"))
    (0.0, 0.5)
    """
    modes = _by_modes(lam, tau, _DIRECT, T)
    if modes is not None:           # the callers' layout: the same form for a mode at every tau
        lam, tau, ib, isml = modes
        val = np.empty(tau.shape[:-1] + lam.shape)
        lb = lam[ib]
        val[..., ib] = -np.exp(lb * tau) / np.expm1(lb * T) + 1.0 / (lb * T)
        if isml.size:
            ms, xs = lam[isml] * T, tau / T
            val[..., isml] = (taylor_tail(ms, 2) - xs * phi1(ms * xs)) / phi1(ms)
        tau = np.broadcast_to(tau, val.shape)
    else:
        val = _kernel_masked(lam, tau, T)
    if at_jump == "right":
        return val
    if at_jump != "mean":
        raise ValueError(f"at_jump must be 'mean' or 'right', got {at_jump!r}")
    return np.where(tau == 0.0, val - 0.5, val)


def _kernel_masked(lam, tau, T):
    lam, tau, mu, big = _forms(lam, tau, T, _DIRECT)
    val = np.empty(mu.shape)
    # each form only where it is used (most modes of a fine lattice take the textbook form)
    lb, tb = lam[big], tau[big]
    val[big] = -np.exp(lb * tb) / np.expm1(lb * T) + 1.0 / (lb * T)
    small = ~big
    if small.any():
        ms, xs = mu[small], tau[small] / T
        val[small] = (taylor_tail(ms, 2) - xs * phi1(ms * xs)) / phi1(ms)
    return val


def kernel_integral(lam, tau, T):
    r"""The zero-mean antiderivative of :math:`H` in :math:`\tau` (continuous, T-periodic), vectorised.

    Examples
    --------
    The zero mode's integral is :math:`T(x/2 - x^2/2 - 1/12)`:

    >>> round(float(kernel_integral(0.0, 0.0, 4.0)), 15), round(float(kernel_integral(-1e-12, 2.0, 4.0)), 12)
    (-0.333333333333333, 0.166666666667)
    """
    modes = _by_modes(lam, tau, _DIRECT_INT, T)
    if modes is not None:
        lam, tau, ib, isml = modes
        out = np.empty(tau.shape[:-1] + lam.shape)
        lb = lam[ib]
        out[..., ib] = (-np.exp(lb * tau) / (lb * np.expm1(lb * T)) + tau / (lb * T) + 1.0 / (lb * lb * T)
                        - 0.5 / lb)
        if isml.size:
            ms, xs = lam[isml] * T, tau / T
            f2 = taylor_tail(ms, 2)
            out[..., isml] = T * (f2 * xs - xs * xs * taylor_tail(ms * xs, 2) - (0.5 * f2 - taylor_tail(ms, 3))) / phi1(ms)
        return out
    lam, tau, mu, big = _forms(lam, tau, T, _DIRECT_INT)
    out = np.empty(mu.shape)
    lb, tb = lam[big], tau[big]
    out[big] = (-np.exp(lb * tb) / (lb * np.expm1(lb * T)) + tb / (lb * T) + 1.0 / (lb * lb * T)
                - 0.5 / lb)
    small = ~big
    if small.any():
        ms, xs = mu[small], tau[small] / T
        f2 = taylor_tail(ms, 2)
        out[small] = T * (f2 * xs - xs * xs * taylor_tail(ms * xs, 2) - (0.5 * f2 - taylor_tail(ms, 3))) / phi1(ms)
    return out


class ModalBasis:
    r"""Eigen-decomposition :math:`A = V\,\mathrm{diag}(\lambda)\,V^{-1}` of a Neumann lattice operator.

    Parameters
    ----------
    lattice : Lattice
        Anything with ``volumes`` (D), ``flux`` (S) and ``operator`` (:math:`D^{-1}S`).
    coupling : float, optional
        :math:`\nu_c`; the operator is :math:`\nu_c D^{-1}S`.
    period : float, optional
        :math:`T`, needed only by :meth:`separable_table` and :meth:`separable_poly`.

    Attributes
    ----------
    lam : ndarray of float, shape (n,)
        Eigenvalues (<= 0, increasing; the Neumann zero mode last).
    V, Vinv : ndarray of float, shape (n, n)
    A : ndarray of float, shape (n, n)
        The coupled operator.
    n : int

    Examples
    --------
    >>> from tps_solver.operators.lattice import Lattice
    >>> mb = ModalBasis(Lattice.planar(n_nodes=5, length=8.0, boundary="neumann"))
    >>> bool(np.allclose(mb.V @ np.diag(mb.lam) @ mb.Vinv, mb.A)), bool(abs(mb.lam[-1]) < 1e-14)
    (True, True)
    """

    def __init__(self, lattice, coupling=1.0, period=None):
        self.inputs = {"lattice": lattice, "coupling": coupling, "period": period}   # for the file codec
        D = np.asarray(lattice.volumes, dtype=float)
        S = np.asarray(lattice.flux, dtype=float)
        sq = np.sqrt(D)
        lam, U = eigh(S / np.outer(sq, sq))
        self.lam = coupling * np.minimum(lam, 0.0)
        self.V = U / sq[:, None]
        self.Vinv = U.T * sq[None, :]
        self.A = coupling * np.asarray(lattice.operator, dtype=float)
        self.n = D.size
        self.period = None if period is None else float(period)
        self._tables, self._poly = None, None

    def response(self, tau, T, integral=False, at_jump="mean"):
        r""":math:`V\,\mathrm{diag}(K(\lambda_p, \tau))\,V^{-1}` for one ``tau`` (K = :func:`kernel` or its integral).

        Examples
        --------
        >>> from tps_solver.operators.lattice import Lattice
        >>> mb = ModalBasis(Lattice.planar(n_nodes=4, length=6.0, boundary="neumann"))
        >>> R = mb.response(1.0, 4.0)
        >>> bool(np.allclose(R.sum(axis=1), 0.5 - 1.0 / 4.0))     # uniform columns: the zero mode
        True
        """
        k = (kernel_integral(self.lam, tau, T) if integral else kernel(self.lam, tau, T, at_jump))
        return self.V @ (k[:, None] * self.Vinv)

    def _build_separable(self):
        T, lam = self.period, self.lam
        zero = self.zero_modes()
        ls = np.where(zero, -1.0, lam)
        alpha = np.where(zero, 0.0, 1.0 / (-np.expm1(ls * T)))
        beta = np.where(zero, 0.5, 1.0 / (ls * T))
        self._tables = {
            False: (alpha, beta, np.where(zero, -1.0 / T, 0.0), np.zeros_like(lam)),
            True: (np.where(zero, 0.0, alpha / ls), np.where(zero, 0.0, (beta - 0.5) / ls),
                   np.where(zero, 0.5, 1.0 / (ls * T)), np.where(zero, -0.5 / T, 0.0)),
        }
        self._poly = {W: tuple(self.V @ (k[:, None] * self.Vinv) for k in tab[1:])
                      for W, tab in self._tables.items()}

    def zero_modes(self):
        r"""Mask of the modes the separable tables treat as the zero mode (:math:`|\lambda T| < 10^{-10}`).

        Their antiderivative in the tables is :math:`\tau/2 - \tau^2/(2T)`, which is
        :func:`kernel_integral` + T/12 (the other modes' is zero-mean).

        Examples
        --------
        >>> from tps_solver.operators.lattice import Lattice
        >>> ModalBasis(Lattice.planar(n_nodes=3, length=4.0), period=4.0).zero_modes().tolist()
        [False, False, True]
        """
        if self.period is None:
            raise ValueError("period must be given to ModalBasis for the separable kernel tables")
        return np.abs(self.lam * self.period) < _ZERO_MODE

    def separable_table(self, integral=False):
        r"""Per-mode ``(A, B, C, D)`` with :math:`K_p(\tau) = A_p e^{\lambda_p\tau} + B_p + C_p\tau + D_p\tau^2`.

        ``K`` is :func:`kernel` (``at_jump="right"``) or, with ``integral``, :func:`kernel_integral`.
        The separable form lets a shift of :math:`\tau` factor out of integrals (the Legendre
        moments of the impact-and-stick TPS); it cancels for :math:`0 < |\lambda T| \ll 1`
        (modes with :math:`|\lambda T| < 10^{-10}` are treated as the zero mode), so values are
        better taken from :func:`kernel`.  Measured error against :func:`kernel` and
        :func:`kernel_integral` (T = 4 pi): about eps/:math:`|\lambda T|` for the kernel and
        eps T/:math:`|\lambda T|^2` for the integral (its :math:`A_p = \alpha_p/\lambda_p`
        grows like :math:`1/(\lambda_p^2 T)`): 4e-11 at :math:`|\lambda T| = 7.7\times10^{-3}`,
        4e-7 at :math:`7.7\times10^{-5}`, 7e-5 at :math:`7.7\times10^{-6}`.  The smallest
        nonzero :math:`|\lambda|` of a Neumann lattice of length L is about :math:`(\pi/L)^2`, so
        a lattice much longer than 100 viscous lengths (or a lattice operator scaled down, as in
        a continuation in the coupling) loses digits in the impact-and-stick TPS.

        Examples
        --------
        >>> from tps_solver.operators.lattice import Lattice
        >>> mb = ModalBasis(Lattice.planar(n_nodes=4, length=6.0, boundary="neumann"), period=4.0)
        >>> A, B, C, D = mb.separable_table()
        >>> bool(np.allclose(A * np.exp(mb.lam * 1.0) + B + C + D, kernel(mb.lam, 1.0, 4.0)))
        True
        """
        if self._tables is None:
            self._build_separable()
        return self._tables[bool(integral)]

    def separable_poly(self, integral=False):
        r""":math:`V\,\mathrm{diag}(X)\,V^{-1}` for X = B, C, D of :meth:`separable_table` (a tuple of three).

        Examples
        --------
        >>> from tps_solver.operators.lattice import Lattice
        >>> mb = ModalBasis(Lattice.planar(n_nodes=4, length=6.0, boundary="neumann"), period=4.0)
        >>> [M.shape for M in mb.separable_poly(integral=True)]
        [(4, 4), (4, 4), (4, 4)]
        """
        if self._poly is None:
            self._build_separable()
        return self._poly[bool(integral)]


# the file codec (tps_solver.core.archive): the inputs, the decomposition is recomputed
archive.register("ModalBasis", ModalBasis, encode=lambda m: dict(m.inputs), decode=lambda d: ModalBasis(**d))
