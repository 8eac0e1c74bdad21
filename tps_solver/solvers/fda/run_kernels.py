r"""Compiled modal coefficients of a run segment (:class:`~tps_solver.solvers.fda.exact.Segment` with run modes).

:func:`run_coefficients` is the loop form of the run path of
:meth:`~tps_solver.solvers.fda.exact.Segment.coefficients`: per mode :math:`k`, with
:math:`z = \lambda_k\tau`,

.. math::
    c_w &= e^{z}(a_k - r_i) + r_i\cos\tau + r_r\sin\tau - (s_k/\Gamma)\,\tau\varphi_1(z), \\
    c_z &= \tau\varphi_1(z)(a_k - r_i) + r_i\sin\tau + r_r(1 - \cos\tau) - (s_k/\Gamma)\,\tau^2\varphi_2(z),

(the closed forms (55)-(56) of :func:`~tps_solver.solvers.fda.exact.forced_response` in real
arithmetic, :math:`r_r + i r_i = s_k e^{it_c}/(i - \lambda_k)`), with :math:`\varphi_2` by its
Taylor series (10 terms, truncation below 1e-18 relative) for :math:`|z| < 0.1`.  Compiled
with numba when the ``fast`` extra is installed (:mod:`tps_solver.core.jit`); the numpy form in
:meth:`~tps_solver.solvers.fda.exact.Segment.coefficients` is the reference (option
``compiled=False`` of :class:`~tps_solver.solvers.fda.exact.ExactPropagator`).
"""
import math

import numpy as np

from tps_solver.core.jit import kernel

__all__ = ["run_coefficients"]

_PHI2_SERIES = 1.0 / np.array([math.factorial(k + 2) for k in range(10)])


@kernel
def run_coefficients(lam, a_ri, rr, ri, sg, tau, cw, cz):
    """Fill ``cw``, ``cz`` (shape (m,)) with the velocity and displacement coefficients at ``tau``.

    Parameters
    ----------
    lam, a_ri, rr, ri, sg : ndarray of float, shape (m,)
        Eigenvalues, :math:`a - r_i`, :math:`r_r`, :math:`r_i` and :math:`s/\\Gamma` (module docstring).
    tau : float
    cw, cz : ndarray of float, shape (m,)
        Output.

    Examples
    --------
    A zero mode with no forcing keeps its velocity and moves ``a tau``:

    >>> cw, cz = np.empty(1), np.empty(1)
    >>> run_coefficients(np.zeros(1), np.array([2.0]), np.zeros(1), np.zeros(1), np.zeros(1), 0.5, cw, cz)
    >>> cw.tolist(), cz.tolist()
    ([2.0], [1.0])
    """
    c = math.cos(tau)
    sn = math.sin(tau)
    h = math.sin(0.5 * tau)
    omc = 2.0 * h * h
    tt = tau * tau
    series = _PHI2_SERIES
    for k in range(lam.size):
        z = lam[k] * tau
        em1 = math.expm1(z)
        if z != 0.0:
            p1 = em1 / z
        else:
            p1 = 1.0
        if abs(z) < 0.1:
            p2 = series[9]
            for i in range(8, -1, -1):
                p2 = p2 * z + series[i]
        else:
            p2 = (em1 - z) / (z * z)
        tp1 = tau * p1
        cw[k] = (em1 + 1.0) * a_ri[k] + (c * ri[k] + sn * rr[k]) - sg[k] * tp1
        cz[k] = tp1 * a_ri[k] + (sn * ri[k] + omc * rr[k]) - tt * sg[k] * p2
