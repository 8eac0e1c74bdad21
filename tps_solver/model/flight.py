r"""Closed-form pieces of free flight and linear propagation: the phi-functions and flight maps.

One home for the formulas that the flat layer, the FDA integrators, the soft
contact and the exact lattice cycle share:

* :func:`phi1`, :func:`phi2`, :func:`taylor_tail` -- the entire functions
  :math:`\varphi_k(z) = (e^z - \sum_{j<k} z^j/j!)/z^k`, cancellation-free;
* :func:`flight_velocity`, :func:`flight_height` -- the plate-frame flight
  (17): a launch at :math:`t_s` with velocity :math:`v` from zero height;
* :func:`flight_map` -- the linearised flight of one lattice mode;
* :func:`expm_companion` -- :math:`\exp(At)` of the 2x2 damped oscillator.
"""
import math

import numpy as np

__all__ = ["phi1", "phi2", "phi2_expm1", "taylor_tail", "flight_velocity", "flight_height", "flight_map",
           "expm_companion"]


def phi1(z):
    r""":math:`\varphi_1(z) = (e^z - 1)/z`, with :math:`\varphi_1(0) = 1` (vectorised).

    ``expm1`` keeps the relative error at a few eps for every real ``z``.

    Examples
    --------
    >>> float(phi1(0.0)), bool(abs(phi1(1e-20) - 1.0) < 1e-15)
    (1.0, True)
    """
    z = np.asarray(z, dtype=float)
    return np.divide(np.expm1(z), z, out=np.ones_like(z), where=z != 0.0)


_PHI2_SERIES = 1.0 / np.array([math.factorial(k + 2) for k in range(10)])


def phi2(z):
    r""":math:`\varphi_2(z) = (e^z - 1 - z)/z^2`, with :math:`\varphi_2(0) = 1/2` (vectorised, stable).

    Examples
    --------
    >>> float(phi2(0.0))
    0.5
    """
    z = np.asarray(z, dtype=float)
    return phi2_expm1(z, np.expm1(z))


def phi2_expm1(z, em1):
    r""":math:`\varphi_2(z)` given ``em1`` :math:`= e^z - 1` (saves the exponential when it is at hand).

    The Taylor series is used for :math:`|z| < 0.1`, with as many of its first 10 terms as the
    largest such :math:`|z|` needs for a truncation below 1e-17.

    Examples
    --------
    >>> z = np.array([0.0, 1e-3, 1.0])
    >>> bool(np.allclose(phi2_expm1(z, np.expm1(z)), [0.5, (np.expm1(1e-3) - 1e-3) / 1e-6, np.e - 2]))
    True
    """
    z = np.asarray(z, dtype=float)
    em1 = np.asarray(em1, dtype=float)
    scalar = z.ndim == 0
    z, em1 = np.atleast_1d(z), np.atleast_1d(em1)
    small = np.abs(z) < 0.1
    out = np.divide(em1 - z, z * z, out=np.empty_like(z), where=~small)
    if small.any():
        zs = z[small]
        zmax = float(np.max(np.abs(zs)))
        k = 1
        while k < 10 and zmax ** k * _PHI2_SERIES[k] > 1e-17:
            k += 1
        acc = np.full_like(zs, _PHI2_SERIES[k - 1])
        for c in (_PHI2_SERIES[k - 2::-1] if k >= 2 else ()):
            acc = acc * zs + c
        out[small] = acc
    return out[0] if scalar else out


def taylor_tail(z, order):
    r""":math:`(e^z - \sum_{k<\mathrm{order}} z^k/k!)/z^{\mathrm{order}}`, cancellation-free.

    A 25-term series for :math:`|z| < 1` (error below 1/24!), the direct form outside.

    Examples
    --------
    >>> bool(abs(taylor_tail(0.5, 1) - phi1(0.5)) < 1e-15)
    True
    """
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1.0
    zs = np.where(small, z, 0.0)
    acc = np.zeros_like(zs)
    for k in range(24, -1, -1):
        acc = acc * zs + 1.0 / math.factorial(k + order)
    zb = np.where(small, 1.0, z)
    direct = np.expm1(zb)
    for k in range(1, order):
        direct = direct - zb ** k / math.factorial(k)
    return np.where(small, acc, direct / zb ** order)


def flight_velocity(t, t_start, v, Gamma):
    """Plate-frame velocity at ``t`` of a flight launched at ``t_start`` with velocity ``v``, (17).

    Examples
    --------
    >>> flight_velocity(1.0, 1.0, 0.5, 2.5)
    0.5
    """
    return v + math.cos(t_start) - math.cos(t) - (t - t_start) / Gamma


def flight_height(t, t_start, v, Gamma):
    """Plate-frame height at ``t`` of a flight launched at ``t_start`` from zero height, (17).

    Examples
    --------
    >>> flight_height(1.0, 1.0, 0.5, 2.5)
    0.0
    """
    d = t - t_start
    return (v + math.cos(t_start)) * d + math.sin(t_start) - math.sin(t) - d * d / (2.0 * Gamma)


def expm_companion(a, c, t):
    r"""Batched :math:`\exp(At)` for :math:`A = [[a, c], [1, 0]]`, ``a`` of shape (k,), in closed form.

    With the eigenvalues :math:`r_{1,2} = m \pm q` (:math:`m = a/2`,
    :math:`q = \sqrt{m^2 + c}`, complex if needed),
    :math:`e^{At} = \alpha I + \gamma A` with
    :math:`\gamma = (e^{r_1t} - e^{r_2t})/(r_1 - r_2)` and
    :math:`\alpha = e^{r_2t} - r_2\gamma` (entry (0, 0) is :math:`e^{r_1t} + r_2\gamma`).  The larger root is formed as
    :math:`m + \operatorname{sign}(m)q` and the smaller as :math:`-c/r_1`, so
    nothing cancels for :math:`|a| \gg |c|`; :math:`|qt| < 10^{-4}` uses the series.

    Parameters
    ----------
    a : array_like of float, shape (k,)
    c : float
    t : float

    Returns
    -------
    ndarray of float, shape (k, 2, 2)

    Examples
    --------
    Against ``scipy.linalg.expm`` for a damped (``a = -1``) and an undamped (``a = 0``) oscillator:

    >>> from scipy.linalg import expm
    >>> E = expm_companion(np.array([-1.0, 0.0]), -2.0, 0.7)
    >>> [bool(np.allclose(E[k], expm(0.7 * np.array([[a, -2.0], [1.0, 0.0]])))) for k, a in enumerate((-1.0, 0.0))]
    [True, True]
    """
    a = np.asarray(a, dtype=float)
    m = 0.5 * a
    q = np.sqrt((m * m + c).astype(complex))
    sgn = np.where(m >= 0.0, 1.0, -1.0)
    r1 = m + sgn * q
    r1_safe = np.where(r1 == 0.0, 1.0, r1)
    r2 = np.where(r1 == 0.0, m - sgn * q, -c / r1_safe)
    e1, e2 = np.exp(r1 * t), np.exp(r2 * t)
    small = np.abs(q * t) < 1e-4
    d = np.where(small, 1.0, 2.0 * sgn * q)
    gamma = np.where(small, t * np.exp(m * t) * (1.0 + (q * t) ** 2 / 6.0), (e1 - e2) / d)
    alpha = np.where(small, np.exp(m * t) * (1.0 - m * t + (q * t) ** 2 * (0.5 - m * t / 6.0)), e2 - r2 * gamma)
    out = np.empty(a.shape + (2, 2))
    out[..., 0, 0] = np.where(small, alpha + gamma * a, e1 + r2 * gamma).real
    out[..., 0, 1] = (gamma * c).real
    out[..., 1, 0] = gamma.real
    out[..., 1, 1] = alpha.real
    return out



def flight_map(lam, tau):
    """Batched flight propagator of (dw, dzeta) for a mode: dw' = -lam dw, dzeta' = dw, over ``tau``.

    Parameters
    ----------
    lam : ndarray of float, shape (k,)
    tau : float

    Returns
    -------
    ndarray of float, shape (k, 2, 2)
        ``[[exp(-lam tau), 0], [(1 - exp(-lam tau))/lam, 1]]`` per mode.

    Examples
    --------
    >>> flight_map(np.array([0.0, 1.0]), 1.0)[:, 1, 0].round(12).tolist()     # tau, then 1 - 1/e
    [1.0, 0.632120558829]
    """
    out = np.zeros((lam.size, 2, 2))
    out[:, 0, 0] = np.exp(-lam * tau)
    out[:, 1, 0] = tau * phi1(-lam * tau)
    out[:, 1, 1] = 1.0
    return out
