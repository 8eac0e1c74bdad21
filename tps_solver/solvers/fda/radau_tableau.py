r"""The Radau IIA collocation tableau and the Lagrange basis of its dense output.

Used by the soft-contact integrator :mod:`~tps_solver.solvers.fda.soft` (its stage systems and the
scan grid of a step).
"""
import functools
import inspect

import mpmath
import numpy as np

from tps_solver.core.checks import check_int

__all__ = ["radau_iia", "lagrange_matrix"]


def radau_iia(s):
    r"""Nodes and Butcher matrix of the ``s``-stage Radau IIA method (computed in 40-digit arithmetic).

    Parameters
    ----------
    s : int
        Number of stages, >= 1 (order :math:`2s - 1`).

    Returns
    -------
    c : ndarray of float, shape (s,)
        Nodes, the roots of :math:`d^{s-1}/dx^{s-1}[x^{s-1}(x-1)^s]`; ``c[-1] = 1``.
    A : ndarray of float, shape (s, s)
        :math:`A_{ij} = \int_0^{c_i}\ell_j(\tau)\,d\tau` (collocation).

    Examples
    --------
    >>> c, A = radau_iia(2)
    >>> np.round(c, 12).tolist(), np.round(A, 12).tolist()
    ([0.333333333333, 1.0], [[0.416666666667, -0.083333333333], [0.75, 0.25]])
    """
    s = check_int(s, "s", minimum=1)
    c, A = _radau_iia(s)
    return c.copy(), A.copy()


@functools.lru_cache(maxsize=None)
def _radau_iia(s):
    """:func:`radau_iia` without the copies (cached: 40-digit arithmetic takes ~70 ms per call)."""
    with mpmath.workdps(40):
        x = mpmath.mpf
        # coefficients of x^(s-1) (x-1)^s, highest degree first
        p = [mpmath.binomial(s, k) * (-1) ** k for k in range(s + 1)] + [x(0)] * (s - 1)
        for _ in range(s - 1):                      # differentiate s-1 times
            deg = len(p) - 1
            p = [p[i] * (deg - i) for i in range(deg)]
        if len(p) <= 2:
            roots = [-p[1] / p[0]]
        elif "asc" in inspect.signature(mpmath.polyroots).parameters:      # mpmath >= 1.4
            roots = mpmath.polyroots(p[::-1], maxsteps=200, extraprec=80, asc=True)
        else:
            roots = mpmath.polyroots(p, maxsteps=200, extraprec=80)
        c = sorted(mpmath.re(r) for r in roots)
        c[-1] = x(1)
        V = mpmath.matrix([[ci ** m for m in range(s)] for ci in c])
        W = mpmath.matrix([[ci ** (m + 1) / (m + 1) for m in range(s)] for ci in c])
        A = W * V ** -1
        return (np.array([float(ci) for ci in c]),
                np.array([[float(A[i, j]) for j in range(s)] for i in range(s)]))


def lagrange_matrix(nodes, theta):
    """Values at ``theta`` of the Lagrange basis on ``nodes``.

    Parameters
    ----------
    nodes : array_like of float, shape (k,)
        Distinct interpolation nodes.
    theta : ndarray of float, shape (G,)
        Evaluation points.

    Returns
    -------
    ndarray of float, shape (G, k)
        ``out[g, j]`` is the j-th Lagrange basis polynomial at ``theta[g]``.

    Examples
    --------
    >>> lagrange_matrix([0.0, 1.0], np.array([0.25])).tolist()
    [[0.75, 0.25]]
    """
    nodes = np.asarray(nodes, float)
    out = np.ones((len(theta), nodes.size))
    for j in range(nodes.size):
        for m in range(nodes.size):
            if m != j:
                out[:, j] *= (theta - nodes[m]) / (nodes[j] - nodes[m])
    return out
