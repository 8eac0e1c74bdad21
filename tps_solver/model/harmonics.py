r"""Fourier convention of the package, forcing harmonics and the contact polynomial.

Fourier convention (stated once, used everywhere)
-------------------------------------------------
A :math:`T`-periodic function, :math:`T = 2\pi M` and :math:`\alpha = 1/M`, is
written as in the paper's (38)-(39)

.. math::  f(t) = \sum_{n=-N}^{N} \hat f_n\, e^{+i n \alpha t},
           \qquad \hat f_n = \frac{\alpha}{2\pi}\int_{P} f(t)\, e^{-i n \alpha t}\, dt ,

i.e. a **plus** sign in the synthesis exponent and the normalisation
:math:`1/T` on the analysis integral over any period :math:`P`.  Arrays of
coefficients are stored **centred**: entry ``N + n`` holds :math:`\hat f_n` for
``n = -N, ..., N`` (shape ``(2N+1,)`` or ``(2N+1, n_nodes)``).  Real
functions have :math:`\hat f_{-n} = \hat f_n^*`.

Contents
--------
* :func:`mode_numbers` -- the integer ``n`` of each entry, ``-N..N``;
* :func:`g_hat` -- the forcing :math:`\hat g_n` of :math:`g(t) = \sin t - 1/\Gamma`, eq. (43);
* :func:`evaluate` -- synthesis of a (possibly multi-node) series at times ``t``;
* :func:`flat_w_hat` -- the flat layer's velocity harmonics in closed form
  (the solution of (45) with constant :math:`t_c`);
* :func:`sawtooth_tail` -- the closed-form tail of the truncated jump series.

The jump and its tail
---------------------
At its contact time every node's velocity jumps by :math:`J = T/\Gamma`
((44) makes the impulse the same everywhere).  The unit T-periodic sawtooth
with a jump +1 at :math:`\tau = 0`, :math:`s(\tau) = 1/2 - \tau/T` on
:math:`(0, T)`, has :math:`\hat s_n = 1/(2\pi i n)` (:math:`n \ne 0`), and its
integral :math:`Z(\tau)` (zero mean) has
:math:`\hat Z_n = \hat s_n/(i n\alpha)`, i.e. with :math:`x = \alpha\tau \in [0, 2\pi)`

.. math:: s(\tau) = \frac{\pi - x}{2\pi}, \qquad
          Z(\tau) = -\frac{M}{\pi}\Big(\frac{\pi^2}{6} - \frac{\pi x}{2} + \frac{x^2}{4}\Big).

Their symmetric partial sums leave O(1/N) and O(1/N^2) tails that are known in
closed form; adding :math:`J\,[s - s_N](t - t_c)` to a truncated velocity
series (and :math:`J\,[Z - Z_N]` to the height) removes the Gibbs error of the
node's own jump, so the flat layer is reproduced exactly for every N >= M.
Note :math:`s_N(0) = 0 = s(0^\pm)` averaged: the symmetric partial sum
already gives the jump's mean exactly at the jump (docs/design.md, hazard 1).
"""
import numpy as np

from tps_solver.core.checks import check_int, check_positive, check_real

__all__ = ["mode_numbers", "centred", "height_from_velocity", "g_hat", "evaluate", "flat_w_hat", "sawtooth_tail", "sawtooth", "sawtooth_hat"]


def mode_numbers(N, positive=False):
    """Return the mode numbers ``n = -N..N`` in storage order (or ``1..N``).

    Parameters
    ----------
    N : int
        Truncation order, ``N >= 1``.
    positive : bool
        Return only the positive modes ``1..N`` (the harmonics the TPS solves for).

    Returns
    -------
    n : ndarray of int, shape (2N+1,) or (N,)

    Examples
    --------
    >>> mode_numbers(2)
    array([-2, -1,  0,  1,  2])
    >>> mode_numbers(3, positive=True)
    array([1, 2, 3])
    """
    N = check_int(N, "N", minimum=1)
    return np.arange(1, N + 1) if positive else np.arange(-N, N + 1)


def centred(w_pos):
    r"""Centred coefficients of a real, zero-mean series from its positive harmonics.

    Parameters
    ----------
    w_pos : ndarray of complex, shape (N, n)
        Harmonics ``n = 1..N``.

    Returns
    -------
    w_hat : ndarray of complex, shape (2N+1, n)
        Entry ``N + n`` holds :math:`w_n`; :math:`w_0 = 0` and :math:`w_{-n} = \overline{w_n}`.

    Examples
    --------
    >>> centred(np.array([[1j], [2.0]]))[:, 0].imag
    array([-0., -1.,  0.,  1.,  0.])
    """
    w_pos = np.asarray(w_pos)
    N, n = w_pos.shape
    full = np.zeros((2 * N + 1, n), dtype=complex)
    full[N + 1:] = w_pos
    full[:N] = np.conj(w_pos[::-1])
    return full


def height_from_velocity(w_hat, M):
    r"""Height harmonics :math:`\hat\zeta_n = \hat w_n/(i n\alpha)` for ``n != 0`` (from (39)).

    The mean :math:`\hat\zeta_0` is not fixed by the velocity and is returned as 0;
    the caller fixes it from the contact condition (40).

    Parameters
    ----------
    w_hat : ndarray of complex, shape (2N+1, ...)
        Centred velocity harmonics.
    M : int
        Subharmonic order (:math:`\alpha = 1/M`).

    Returns
    -------
    zeta_hat : ndarray of complex, shape (2N+1, ...)

    Examples
    --------
    >>> height_from_velocity(np.array([1j, 0.0, -1j]), 1).real
    array([-1.,  0., -1.])
    """
    w_hat = np.asarray(w_hat, dtype=complex)
    N = (w_hat.shape[0] - 1) // 2
    n = np.arange(-N, N + 1).reshape((-1,) + (1,) * (w_hat.ndim - 1))
    zeta_hat = np.zeros_like(w_hat)
    nz = (n != 0).ravel()
    zeta_hat[nz] = w_hat[nz] / (1j * n[nz] / M)
    return zeta_hat


def g_hat(N, M, Gamma):
    r"""Fourier coefficients of the plate-frame gravity :math:`g(t) = \sin t - 1/\Gamma`.

    Implements (43): :math:`\hat g_0 = -1/\Gamma`, :math:`\hat g_{\pm M} = \mp i/2`
    (for ``N >= M``), all others zero.

    Parameters
    ----------
    N : int
        Truncation order.
    M : int
        Subharmonic order (period ``2 pi M``).
    Gamma : float
        Dimensionless plate acceleration.

    Returns
    -------
    g : ndarray of complex, shape (2N+1,)

    Examples
    --------
    >>> g = g_hat(2, 2, 2.5)
    >>> float(g[2].real), float(g[4].imag), float(g[0].imag)
    (-0.4, -0.5, 0.5)
    """
    N = check_int(N, "N", minimum=1)
    M = check_int(M, "M", minimum=1)
    Gamma = check_positive(Gamma, "Gamma")
    g = np.zeros(2 * N + 1, dtype=complex)
    g[N] = -1.0 / Gamma
    if M <= N:
        g[N + M] = -0.5j
        g[N - M] = 0.5j
    return g


def evaluate(coeffs, t, M):
    r"""Evaluate :math:`\sum_n \hat f_n e^{i n \alpha t}` at times ``t``.

    Parameters
    ----------
    coeffs : ndarray of complex, shape (2N+1,) or (2N+1, n_nodes)
        Centred coefficients.
    t : array_like of float, shape (n_times,)
        Times.
    M : int
        Subharmonic order, ``alpha = 1/M``.

    Returns
    -------
    f : ndarray of float, shape (n_times,) or (n_times, n_nodes)
        The real part of the synthesis (the imaginary part vanishes for
        conjugate-symmetric coefficients).

    Examples
    --------
    >>> c = np.array([0.5, 0, 0.5])          # cos(t/2) with M = 2
    >>> float(evaluate(c, [0.0], 2)[0])
    1.0
    """
    coeffs = np.asarray(coeffs)
    M = check_int(M, "M", minimum=1)
    N = (coeffs.shape[0] - 1) // 2
    t = np.atleast_1d(np.asarray(t, dtype=float))
    n = np.arange(-N, N + 1)
    phase = np.exp(1j * np.outer(t, n) / M)
    return (phase @ coeffs).real


def flat_w_hat(N, M, Gamma, tc):
    r"""Velocity harmonics of a layer with uniform contact time ``tc``.

    Closed form of (45) with :math:`\nabla^2 = 0`:

    .. math:: \hat w_n = \frac{\Gamma^{-1} e^{-i n \alpha t_c} + \hat g_n}{i n \alpha},
              \quad n \ne 0, \qquad \hat w_0 = 0 ,

    which equals the Fourier series of the bouncing-ball velocity (17) with
    launch phase :math:`t_0 = t_c`:
    :math:`\hat W_n = e^{-in\alpha t_0}/(i n\alpha\Gamma) - \tfrac12\delta_{|n|M}`.

    Parameters
    ----------
    N : int
    M : int
    Gamma : float
    tc : float
        Contact (launch) phase.

    Returns
    -------
    w_hat : ndarray of complex, shape (2N+1,)

    Examples
    --------
    The mean is 0 and the forcing harmonic :math:`n = M` is
    :math:`e^{-it_c}/(i\Gamma) - 1/2 = -0.5 - 0.4i` for :math:`\Gamma = 2.5`, :math:`t_c = 0`:

    >>> w = flat_w_hat(2, 2, 2.5, 0.0)
    >>> complex(w[2]), complex(np.round(w[2 + 2], 12))
    (0j, (-0.5-0.4j))
    """
    N = check_int(N, "N", minimum=1)
    M = check_int(M, "M", minimum=1)
    Gamma = check_positive(Gamma, "Gamma")
    tc = check_real(tc, "tc")
    n = np.arange(-N, N + 1)
    g = g_hat(N, M, Gamma)
    w = np.zeros(2 * N + 1, dtype=complex)
    nz = n != 0
    w[nz] = (np.exp(-1j * n[nz] * tc / M) / Gamma + g[nz]) / (1j * n[nz] / M)
    return w


def sawtooth_tail(tau, N, M, kind="velocity"):
    r"""Tail :math:`s - s_N` (or :math:`Z - Z_N`) of the unit sawtooth series.

    Parameters
    ----------
    tau : array_like of float
        Time since the jump; reduced modulo T = 2 pi M.  At ``tau = 0`` the
        velocity tail is defined as 0 (the jump's mean, where the symmetric
        partial sum is exact).
    N : int
        Truncation order.
    M : int
        Subharmonic order.
    kind : {"velocity", "height"}
        ``"velocity"``: :math:`s(\tau) - s_N(\tau)`, with
        :math:`s_N = \sum_{n=1}^N \sin(n\alpha\tau)/(\pi n)`;
        ``"height"``: :math:`Z(\tau) - Z_N(\tau)`, with
        :math:`Z_N = -(M/\pi)\sum_{n=1}^N \cos(n\alpha\tau)/n^2`.

    Returns
    -------
    tail : ndarray of float, same shape as ``tau``

    Examples
    --------
    >>> float(sawtooth_tail(0.0, 10, 2))
    0.0
    >>> abs(float(sawtooth_tail(0.0, 10, 2, "height")) + 2 / np.pi * (np.pi**2 / 6 - sum(1 / n**2 for n in range(1, 11)))) < 1e-15
    True
    """
    N = check_int(N, "N", minimum=1)
    M = check_int(M, "M", minimum=1)
    if kind not in ("velocity", "height"):
        raise ValueError(f"kind must be one of 'velocity', 'height', got {kind!r}")
    tau = np.asarray(tau, dtype=float)
    x = np.mod(tau / M, 2.0 * np.pi)
    n = np.arange(1, N + 1)
    nx = np.multiply.outer(x, n)
    if kind == "velocity":
        exact = np.where(x == 0.0, 0.0, (np.pi - x) / (2.0 * np.pi))
        partial = np.sin(nx) @ (1.0 / (np.pi * n))
    else:
        exact = -(M / np.pi) * (np.pi ** 2 / 6.0 - np.pi * x / 2.0 + x * x / 4.0)
        partial = -(M / np.pi) * (np.cos(nx) @ (1.0 / n ** 2))
    return exact - partial


def sawtooth(tau, M, kind="velocity"):
    r"""The exact unit sawtooth :math:`s(\tau)` or its zero-mean integral :math:`Z(\tau)`.

    ``s(0) = 0`` (the jump's mean).  See the module docstring for the formulas.

    Parameters
    ----------
    tau : array_like of float
    M : int
    kind : {"velocity", "height"}

    Returns
    -------
    ndarray of float, same shape as ``tau``

    Examples
    --------
    :math:`s = (\pi - x)/(2\pi)` with :math:`x = \tau/M` mod :math:`2\pi`, and
    :math:`Z(0) = -M\pi/6`:

    >>> sawtooth(np.pi * np.array([0.0, 0.5, 1.0, 1.5]), 1)
    array([ 0.  ,  0.25,  0.  , -0.25])
    >>> bool(abs(sawtooth(0.0, 2, "height") + 2 * np.pi / 6) < 1e-15)
    True
    """
    M = check_int(M, "M", minimum=1)
    if kind not in ("velocity", "height"):
        raise ValueError(f"kind must be one of 'velocity', 'height', got {kind!r}")
    x = np.mod(np.asarray(tau, dtype=float) / M, 2.0 * np.pi)
    if kind == "velocity":
        return np.where(x == 0.0, 0.0, (np.pi - x) / (2.0 * np.pi))
    return -(M / np.pi) * (np.pi ** 2 / 6.0 - np.pi * x / 2.0 + x * x / 4.0)


def sawtooth_hat(N, M, tc, kind="velocity"):
    r"""Centred coefficients of :math:`s(t - t_c)` (or :math:`Z(t - t_c)`) per node.

    :math:`\hat s_n e^{-in\alpha t_c}` with :math:`\hat s_n = 1/(2\pi i n)`, and
    :math:`\hat Z_n = \hat s_n/(i n\alpha)`; the n = 0 entries are 0.

    Parameters
    ----------
    N, M : int
    tc : array_like of float, shape (n_nodes,)

    Returns
    -------
    ndarray of complex, shape (2N+1, n_nodes)

    Examples
    --------
    Summed with :func:`evaluate`, the coefficients give the sawtooth minus its
    tail (:func:`sawtooth_tail`) exactly:

    >>> t = np.linspace(0.0, 4 * np.pi, 7)
    >>> c = sawtooth_hat(10, 2, [0.3])
    >>> c.shape, complex(c[10 + 1, 0] * np.exp(0.3j / 2)) == 1 / (2j * np.pi)
    ((21, 1), True)
    >>> bool(np.allclose(evaluate(c, t, 2)[:, 0], sawtooth(t - 0.3, 2) - sawtooth_tail(t - 0.3, 10, 2)))
    True
    """
    N = check_int(N, "N", minimum=1)
    M = check_int(M, "M", minimum=1)
    tc = np.atleast_1d(np.asarray(tc, dtype=float))
    n = np.arange(-N, N + 1)
    c = np.zeros(2 * N + 1, dtype=complex)
    nz = n != 0
    c[nz] = 1.0 / (2j * np.pi * n[nz])
    if kind == "height":
        c[nz] = c[nz] / (1j * n[nz] / M)
    elif kind != "velocity":
        raise ValueError(f"kind must be one of 'velocity', 'height', got {kind!r}")
    return c[:, None] * np.exp(-1j * np.outer(n / M, tc))
