r"""Floquet multipliers and measured growth of periodic orbits: one place for both.

* :func:`multipliers` -- the eigenvalues of a monodromy (the linearised period map),
  sorted by decreasing modulus; all of a dense matrix, or the leading ``k`` of a matrix or
  ``LinearOperator`` by Arnoldi (``scipy.sparse.linalg.eigs``);
* :func:`fit_growth` -- the per-period growth factor of a perturbation from the distances
  :math:`d_k = |x_k - x^*|` after k periods, by a log-linear fit on the linear window (used
  where the period map is not differentiable: sticking, grazing).
"""
import math

import numpy as np
from scipy.sparse.linalg import LinearOperator, eigs

__all__ = ["multipliers", "ritz_multipliers", "fit_growth"]


def multipliers(monodromy, k=None):
    """Eigenvalues of a monodromy, by decreasing modulus.

    Parameters
    ----------
    monodromy : ndarray of float, shape (n, n), or scipy.sparse.linalg.LinearOperator
    k : int, optional
        Only the ``k`` leading multipliers (Arnoldi; required for a ``LinearOperator``, and
        used for a matrix when ``k < n - 1``).

    Returns
    -------
    ndarray of complex, shape (n,) or (k,)

    Examples
    --------
    >>> A = np.diag([0.5, -0.9, 0.1])
    >>> multipliers(A).real.tolist()
    [-0.9, 0.5, 0.1]
    >>> bool(abs(multipliers(np.diag(np.linspace(0.01, 0.99, 40)), k=2)[0] - 0.99) < 1e-12)
    True
    """
    if isinstance(monodromy, LinearOperator):
        if k is None:
            raise ValueError("k must be given for a LinearOperator monodromy (the leading k multipliers)")
        n = monodromy.shape[0]
    else:
        monodromy = np.asarray(monodromy, dtype=float)
        if monodromy.ndim != 2 or monodromy.shape[0] != monodromy.shape[1]:
            raise ValueError(f"monodromy must be a square matrix, got shape {monodromy.shape}")
        n = monodromy.shape[0]
        if k is None or k >= n - 1:
            mu = np.linalg.eigvals(monodromy).astype(complex)
            return mu[np.argsort(-np.abs(mu), kind="stable")][:k]
    k = int(k)
    if not 1 <= k < n - 1:
        raise ValueError(f"k must lie in [1, n - 2] = [1, {n - 2}] for Arnoldi, got {k}")
    mu = eigs(monodromy, k=k, which="LM", return_eigenvectors=False).astype(complex)
    return mu[np.argsort(-np.abs(mu), kind="stable")]


def ritz_multipliers(matvec, n, k, dim, v0, tol=None, min_dim=None, power=1):
    r"""The ``k`` leading multipliers as Ritz values of an Arnoldi factorisation of bounded dimension.

    One product per step and no implicit restarts, so the cost (at most ``dim`` products) is
    known in advance; ARPACK's restarts to a tolerance have no useful bound when the spectrum
    is clustered near 0 (sticking) and the products carry finite-difference noise.  With
    ``tol`` the factorisation stops early, at the first dimension ``>= min_dim`` where every
    one of the ``k`` leading Ritz pairs has the residual estimate
    :math:`r_i = |h_{j+1,j}\, y_{j,i}|` with
    :math:`p\,|\theta_i|^{p-1} r_i \le` ``tol`` :math:`\cdot|\theta_1|^p` (``power`` p: the
    first-order error of :math:`\theta_i^p`, e.g. p = 2 for the multipliers of :math:`P = G^2`
    from those of G).

    Parameters
    ----------
    matvec : callable
        ``v -> M v`` for the monodromy M, v of shape (n,).
    n, k, dim : int
        Size, multipliers wanted (``k <= dim <= n``), largest Krylov dimension.
    v0 : ndarray of float, shape (n,)
        Start vector.
    tol : float, optional
        Relative residual estimate at which to stop early (default: never, ``dim`` products).
    min_dim : int, optional
        Smallest dimension at which an early stop is allowed; default ``k + 2``.
    power : int
        The power p of the stopping rule.

    Returns
    -------
    mu : ndarray of complex, shape (k,)
        By decreasing modulus.
    residuals : ndarray of float, shape (k,)
        Ritz residual estimates :math:`|h_{j+1,j}\, y_j|` of the reported pairs.
    used : int
        The dimension reached (smaller than ``dim`` at an invariant subspace or an early stop).

    Examples
    --------
    >>> A = np.diag(np.linspace(0.0, 0.9, 30))
    >>> mu, res, used = ritz_multipliers(lambda v: A @ v, 30, 2, 30, np.ones(30))
    >>> np.round(mu.real, 12).tolist(), bool(np.all(res < 1e-8))
    ([0.9, 0.868965517241], True)
    >>> B = np.diag(0.5 ** np.arange(30.0))              # a fast-decaying spectrum
    >>> mu, res, used = ritz_multipliers(lambda v: B @ v, 30, 2, 30, np.ones(30), tol=1e-12)
    >>> np.round(mu.real, 12).tolist(), used < 30
    ([1.0, 0.5], True)
    """
    V = np.zeros((n, dim + 1))
    H = np.zeros((dim + 1, dim))
    V[:, 0] = v0 / np.linalg.norm(v0)
    used = dim
    min_dim = k + 2 if min_dim is None else int(min_dim)
    for j in range(dim):
        wv = matvec(V[:, j])
        for _ in range(2):
            c = V[:, :j + 1].T @ wv
            H[:j + 1, j] += c
            wv = wv - V[:, :j + 1] @ c
        H[j + 1, j] = float(np.linalg.norm(wv))
        if H[j + 1, j] <= 1e-13 * max(1.0, float(np.max(np.abs(H[:j + 1, :j + 1])))):
            used = j + 1
            break
        V[:, j + 1] = wv / H[j + 1, j]
        if tol is not None and j + 1 >= max(min_dim, k) and j + 1 < dim:
            theta, Y = np.linalg.eig(H[:j + 1, :j + 1])
            order = np.argsort(-np.abs(theta), kind="stable")[:k]
            res = np.abs(H[j + 1, j] * Y[j, order])
            a = np.abs(theta[order])
            if np.all(power * a ** (power - 1) * res <= tol * max(float(a[0]) ** power, 1e-300)):
                used = j + 1
                break
    theta, Y = np.linalg.eig(H[:used, :used])
    order = np.argsort(-np.abs(theta), kind="stable")[:k]
    return theta[order].astype(complex), np.abs(H[used, used - 1] * Y[used - 1, order]), used


def fit_growth(dist, saturation=1e-3):
    """Per-period growth factor from a log-linear fit on the linear window of ``dist``.

    The window ends at the last period before ``dist`` first exceeds ``saturation`` (the
    linear regime) and starts half-way into it (after the transient); with fewer than two
    points there it starts at period 0.

    Parameters
    ----------
    dist : ndarray of float, shape (n_periods + 1,)
        Distance from the orbit after 0, 1, 2, ... periods.
    saturation : float

    Returns
    -------
    growth : float
        nan when the window has fewer than two points or a distance is not positive.
    window : tuple of int
        ``(k0, k1)``, the first and last period of the fit.

    Examples
    --------
    >>> d = 1e-8 * 1.5 ** np.arange(30)
    >>> g, window = fit_growth(d)
    >>> round(g, 12), window
    (1.5, (14, 28))
    """
    dist = np.asarray(dist, dtype=float)
    over = np.flatnonzero(~(dist < saturation))
    k1 = (int(over[0]) - 1) if over.size else dist.size - 1
    if k1 < 1:
        return float("nan"), (0, max(k1, 0))
    k0 = max(1, k1 // 2) if k1 - max(1, k1 // 2) >= 1 else 0
    ks = np.arange(k0, k1 + 1)
    d = dist[ks]
    if np.any(d <= 0):
        return float("nan"), (k0, k1)
    return float(math.exp(np.polyfit(ks, np.log(d), 1)[0])), (k0, k1)
