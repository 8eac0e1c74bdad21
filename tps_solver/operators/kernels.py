r"""Green's-function kernels of the complex Helmholtz operator and their cell integrals.

The per-harmonic problem (45)/(47) is :math:`\nabla^2 u - \beta^2 u = q` with
:math:`\beta = (i n \alpha)^{1/2}`, :math:`\operatorname{Re}\beta > 0`.  Its
Green's functions (48)-(50) are built from

* planar (kinks), (49): :math:`F_\pm(x) = e^{\pm\beta x}`, Wronskian :math:`2\beta`,
  free-space Green's function :math:`G(x, x') = -e^{-\beta|x - x'|}/(2\beta)`;
* axisymmetric (oscillons), (50): :math:`F_+ = I_0(\beta r)`, :math:`F_- = K_0(\beta r)`,
  :math:`W\{I_0, K_0\} = -1/r`, and
  :math:`G(r, s) = -I_0(\beta r_<) K_0(\beta r_>)` (weight :math:`s\,ds`).

This module holds the **cell integrals** (product-integration weights) that
:mod:`tps_solver.operators.helmholtz` sweeps over.  All of them are returned *scaled*
by the exponential factor that the recursive sweep needs, so no intermediate
quantity overflows or underflows for :math:`|\beta|` up to 16 and lengths up
to 200 and beyond:

* :func:`exp_moments` -- :math:`\varphi_0(z) = \int_0^1 e^{-zt}dt` and
  :math:`\varphi_1(z) = \int_0^1 t\,e^{-zt}dt` (planar, piecewise-linear
  right-hand sides, exact);
* :func:`radial_moment_i` -- :math:`e^{-\operatorname{Re}(\beta) b}\int_a^b s\,I_0(\beta s)\,ds`;
* :func:`radial_moment_k` -- :math:`e^{\beta a}\int_a^b s\,K_0(\beta s)\,ds`;
* :func:`radial_half_cell_moments` -- both halves of a cell at once (solver weights).

The radial integrals use the closed forms :math:`\int s I_0(\beta s)ds = s I_1(\beta s)/\beta`
and :math:`\int s K_0(\beta s)ds = -s K_1(\beta s)/\beta` with
``scipy.special.ive``/``kve`` and explicitly combined exponents.  Where the
closed-form difference would cancel (cells short compared with
:math:`1/|\beta|`), the Taylor series of :math:`I_0`/:math:`K_0` about the
cell centre is integrated term by term instead (its coefficients follow from
Bessel's equation, so a cell costs two ``ive``/``kve`` calls), and near the
origin a power series of :math:`\int_0^x t K_0(t)\,dt`; each branch is
accurate to a few ulps, which the tests check against mpmath at 30-40 digits.
Accuracy is guaranteed for :math:`|\arg\beta| \le \pi/3` (all physical
:math:`\beta` have :math:`\arg\beta = \pi/4`).
"""
import numpy as np
from scipy.special import ive, kve

__all__ = ["helmholtz_beta", "exp_moments", "radial_moment_i", "radial_moment_k",
           "radial_half_cell_moments"]

_EULER_GAMMA = 0.57721566490153286061
_SMALL_Z = 0.5        # |z| below which exp_moments uses its Taylor series
_SHORT_CELL = 2.0     # |beta| * h at or below which a cell counts as short
_K_SERIES_TERMS = 30  # terms of the series of int_0^x t K0(t) dt, used for |x| <= 4
_TAYLOR_TERMS = 40    # terms of the Taylor series about a cell centre (ratio <= 1/3)


def helmholtz_beta(N, M):
    r"""Return :math:`\beta_n = (i n\alpha)^{1/2}` for ``n = 1..N``, :math:`\alpha = 1/M`.

    The principal root is taken, so :math:`\operatorname{Re}\beta_n > 0` and
    :math:`\arg\beta_n = \pi/4`.

    Parameters
    ----------
    N : int
        Number of harmonics.
    M : int
        Subharmonic order.

    Returns
    -------
    beta : ndarray of complex, shape (N,)

    Examples
    --------
    >>> beta = helmholtz_beta(2, 2)
    >>> bool(np.allclose(beta, [0.5 + 0.5j, np.sqrt(0.5) * (1 + 1j)]))
    True
    """
    n = np.arange(1, N + 1)
    return np.sqrt(1j * n / M)


def exp_moments(z):
    r"""Moments :math:`\varphi_0(z) = \int_0^1 e^{-zt}dt` and :math:`\varphi_1(z) = \int_0^1 t e^{-zt}dt`.

    Closed forms :math:`\varphi_0 = (1 - e^{-z})/z` and
    :math:`\varphi_1 = (1 - (1 + z)e^{-z})/z^2`; for :math:`|z| < 1/2` the
    Taylor series :math:`\varphi_m = \sum_k (-z)^k / (k!\,(k + m + 1))` is used
    to avoid cancellation.  With :math:`z = \beta h` they give the exact
    integrals of :math:`e^{-\beta|x - x'|}` times a linear function over a cell
    of width ``h`` (planar kernel (49)).

    Parameters
    ----------
    z : array_like of complex, any shape
        Requires ``Re z >= 0``.

    Returns
    -------
    phi0, phi1 : ndarray of complex, shape of ``z``

    Examples
    --------
    >>> phi0, phi1 = exp_moments([0.0, 1.0])
    >>> phi0.real, phi1.real
    (array([1.        , 0.63212056]), array([0.5       , 0.26424112]))
    """
    z = np.asarray(z, dtype=complex)
    small = np.abs(z) < _SMALL_Z
    zs = np.where(small, z, 0.0)
    phi0_s = np.zeros_like(z)
    phi1_s = np.zeros_like(z)
    term = np.ones_like(z)
    for k in range(18):                         # |z|^18/18! < 1e-21
        phi0_s += term / (k + 1)
        phi1_s += term / (k + 2)
        term = term * (-zs) / (k + 1)
    zl = np.where(small, 1.0, z)
    e = np.exp(-np.minimum(zl.real, 700.0) - 1j * zl.imag)
    phi0_l = (1.0 - e) / zl
    phi1_l = (1.0 - (1.0 + zl) * e) / zl**2
    return np.where(small, phi0_s, phi0_l), np.where(small, phi1_s, phi1_l)


def _flat_cells(beta, a, b):
    """Broadcast ``beta, a, b`` and return them flattened, with the broadcast shape."""
    beta, a, b = np.broadcast_arrays(np.asarray(beta, dtype=complex),
                                     np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    return beta.shape, beta.ravel(), a.ravel(), b.ravel()


def _exp_neg(x):
    """``exp(-x)`` for complex ``x`` with ``Re x >= 0``, flushing below 1e-304 to 0 without flags."""
    x = np.asarray(x, dtype=complex)
    tiny = x.real > 700.0
    return np.where(tiny, 0.0, np.exp(-np.where(tiny, 0.0, x)))


def _taylor_moments(beta, c, half, y0, y1, pieces):
    r"""Integrals :math:`\int_{c + H l}^{c + H u} s\,y(s)\,ds` from the Taylor series of ``y`` about ``c``.

    ``y`` is a solution of Bessel's modified equation of order 0 in
    :math:`\beta s` (:math:`y'' + y'/s - \beta^2 y = 0`), given by ``y0 = y(c)``
    and ``y1 = y'(c)``.  With :math:`b_m = a_m H^m` the Taylor coefficients
    follow from the equation:
    :math:`b_{m+2} = [(\beta H)^2 (b_m + \rho\, b_{m-1}) - (m+1)^2 \rho\, b_{m+1}] / ((m+1)(m+2))`,
    :math:`\rho = H/c`.  Convergent for :math:`\rho < 1`; used with
    :math:`\rho \le 1/3` and :math:`|\beta| H \le 1`, where 40 terms leave a
    truncation error below :math:`3^{-40}`.  ``pieces`` is a sequence of
    ``(l, u)`` (scalars or arrays) with ``l, u`` in [-1, 1]; returns one array
    per piece.  Callers pass the exactly computed offsets ``(a - c)/H``,
    ``(b - c)/H`` so the pieces end at the given cell ends, not at ``c -+ H``.
    """
    rho = half / c
    bh2 = (beta * half) ** 2
    b_prev, b_cur, b_next = np.zeros_like(y0), y0, y1 * half
    size = np.abs(y0) + np.abs(b_next)
    sums = [np.zeros_like(y0) for _ in pieces]
    # running powers lo^(m+1), up^(m+1) of each piece
    powers = [[np.asarray(lo, dtype=float), np.asarray(up, dtype=float)] for lo, up in pieces]
    for m in range(_TAYLOR_TERMS):
        for acc, (lo, up), pw in zip(sums, pieces, powers):
            d1 = pw[1] - pw[0]                        # up^(m+1) - lo^(m+1)
            pw[0] = pw[0] * lo
            pw[1] = pw[1] * up
            acc += b_cur * (c * d1 / (m + 1) + half * (pw[1] - pw[0]) / (m + 2))
        b_new = (bh2 * (b_cur + rho * b_prev) - (m + 1) ** 2 * rho * b_next) / ((m + 1) * (m + 2))
        b_prev, b_cur, b_next = b_cur, b_next, b_new
        if m % 4 == 3 and np.all(np.abs(b_cur) + np.abs(b_next) <= 1e-18 * size):
            break                                     # remaining terms below 1e-18 relative
    return [half * acc for acc in sums]


def _taylor_ok(beta, a, b):
    """Cells where the Taylor series about the centre is used: |beta| h <= 2 and a >= h."""
    h = b - a
    return (np.abs(beta) * h <= _SHORT_CELL) & (a >= h) & (h > 0)


def _taylor_i(beta, c, half, pieces):
    """Pieces of e^{-Re(beta) c} int s I0(beta s) ds about the centre ``c``."""
    z = beta * c
    return _taylor_moments(beta, c, half, ive(0, z), beta * ive(1, z), pieces)


def _taylor_k(beta, c, half, pieces):
    """Pieces of e^{beta c} int s K0(beta s) ds about the centre ``c``."""
    z = beta * c
    return _taylor_moments(beta, c, half, kve(0, z), -beta * kve(1, z), pieces)


def radial_moment_i(beta, a, b):
    r"""Scaled cell integral :math:`e^{-\operatorname{Re}(\beta)\,b}\int_a^b s\,I_0(\beta s)\,ds`.

    Closed form :math:`[s I_1(\beta s)/\beta]_a^b` with ``ive``.  Short cells
    away from the origin (``|beta| (b - a) <= 2`` and ``a >= b - a``), where
    the closed-form difference would cancel, use the Taylor series of
    :math:`I_0` about the cell centre instead (coefficients from Bessel's
    equation, two ``ive`` calls per cell).

    Parameters
    ----------
    beta : array_like of complex
        ``Re beta > 0``; broadcast against ``a`` and ``b``.
    a, b : array_like of float
        Cell ends, ``0 <= a <= b``.

    Returns
    -------
    m : ndarray of complex, broadcast shape

    Examples
    --------
    >>> from scipy.special import iv
    >>> beta = 0.5 + 0.5j
    >>> m = radial_moment_i(beta, 0.0, 2.0)
    >>> bool(np.isclose(m, 2.0 * iv(1, 2 * beta) / beta * np.exp(-1.0)))
    True
    """
    shape, beta, a, b = _flat_cells(beta, a, b)
    short = _taylor_ok(beta, a, b)
    out = np.empty(beta.shape, dtype=complex)
    c = ~short
    bc, ac, bb = beta[c], a[c], b[c]
    out[c] = (bb * ive(1, bc * bb) - ac * ive(1, bc * ac) * np.exp(-bc.real * (bb - ac))) / bc
    if np.any(short):
        bs, half = beta[short], 0.5 * (b[short] - a[short])
        centre = 0.5 * (a[short] + b[short])
        lo, up = a[short] - centre, b[short] - centre
        (val,) = _taylor_i(bs, centre, half, [(lo / half, up / half)])
        out[short] = val * np.exp(-bs.real * up)
    return out.reshape(shape)


def _int_t_k0(x):
    r"""Power series of :math:`S(x) = \int_0^x t K_0(t)\,dt = 1 - x K_1(x)` for ``|x| <= 4``."""
    x = np.asarray(x, dtype=complex)
    out = np.zeros_like(x)
    nz = x != 0
    xx = x[nz]
    log_term = np.log(xx / 2) + _EULER_GAMMA
    x2 = xx * xx
    power = x2.copy()               # x^(2k+2)
    coeff = 1.0                     # 1 / (4^k (k!)^2)
    harmonic = 0.0                  # H_k
    acc = np.zeros_like(xx)
    for k in range(_K_SERIES_TERMS):
        m = 2 * k + 2
        acc += coeff * power / m * (-log_term + 1.0 / m + harmonic)
        coeff /= 4.0 * (k + 1) ** 2
        harmonic += 1.0 / (k + 1)
        power = power * x2
    out[nz] = acc
    return out


def radial_moment_k(beta, a, b):
    r"""Scaled cell integral :math:`e^{\beta a}\int_a^b s\,K_0(\beta s)\,ds`.

    Closed form :math:`[-s K_1(\beta s)/\beta]_a^b` with ``kve`` (at ``a = 0``:
    :math:`(1/\beta - b K_1(\beta b))/\beta`).  Short cells
    (``|beta| (b - a) <= 2``) use the Taylor series of :math:`K_0` about the
    cell centre when ``a >= b - a`` (the series then converges with ratio
    at most 1/3) and otherwise the power series of
    :math:`\int_0^x t K_0(t)\,dt` (then ``|beta b| <= 4``).

    Parameters
    ----------
    beta : array_like of complex
        ``Re beta > 0``; broadcast against ``a`` and ``b``.
    a, b : array_like of float
        Cell ends, ``0 <= a <= b``.

    Returns
    -------
    m : ndarray of complex, broadcast shape

    Examples
    --------
    >>> from scipy.special import kv
    >>> beta = 0.5 + 0.5j
    >>> m = radial_moment_k(beta, 1.0, 3.0)
    >>> ref = (1.0 * kv(1, beta) - 3.0 * kv(1, 3 * beta)) / beta * np.exp(beta)
    >>> bool(np.isclose(m, ref))
    True
    """
    shape, beta, a, b = _flat_cells(beta, a, b)
    h = b - a
    short = (np.abs(beta) * h <= _SHORT_CELL) & (h > 0)
    taylor = _taylor_ok(beta, a, b)
    series = short & ~taylor
    closed = ~short
    out = np.zeros(beta.shape, dtype=complex)      # h == 0 cells stay 0

    # closed form, long cells: e^{beta a} [a K1(beta a) - b K1(beta b)] / beta
    bc, ac, bb = beta[closed], a[closed], b[closed]
    far = bb * kve(1, bc * bb) * _exp_neg(bc * (bb - ac))
    at0 = ac == 0
    near = np.where(at0, 1.0 / bc, ac * kve(1, bc * np.where(at0, 1.0, ac)))
    out[closed] = (near - far) / bc

    if np.any(taylor):
        bt, half = beta[taylor], 0.5 * h[taylor]
        centre = 0.5 * (a[taylor] + b[taylor])
        lo, up = a[taylor] - centre, b[taylor] - centre
        (val,) = _taylor_k(bt, centre, half, [(lo / half, up / half)])
        out[taylor] = val * np.exp(bt * lo)
    if np.any(series):
        bs, as_, b_s = beta[series], a[series], b[series]
        out[series] = ((_int_t_k0(bs * b_s) - _int_t_k0(bs * as_)) / bs**2
                       * np.exp(bs * as_))
    return out.reshape(shape)


def radial_half_cell_moments(beta, a, b):
    r"""The four scaled half-cell integrals of a cell :math:`[a, b]`, midpoint :math:`m`.

    Returns, with :math:`m = (a + b)/2`,

    * ``i_left``  :math:`= e^{-\operatorname{Re}(\beta) b}\int_a^m s I_0(\beta s)\,ds`,
    * ``i_right`` :math:`= e^{-\operatorname{Re}(\beta) b}\int_m^b s I_0(\beta s)\,ds`,
    * ``k_left``  :math:`= e^{\beta a}\int_a^m s K_0(\beta s)\,ds`,
    * ``k_right`` :math:`= e^{\beta a}\int_m^b s K_0(\beta s)\,ds`,

    the product-integration weights of the dual-cell (piecewise-constant)
    quadrature in :class:`~tps_solver.operators.helmholtz.HelmholtzSolver`.  Where the
    Taylor series about ``m`` converges fast (``|beta| (b - a) <= 2`` and
    ``a >= b - a``) both halves share one pair of Bessel evaluations per
    kernel; elsewhere :func:`radial_moment_i` / :func:`radial_moment_k` are
    applied to each half.

    Parameters
    ----------
    beta : array_like of complex
        ``Re beta > 0``; broadcast against ``a`` and ``b``.
    a, b : array_like of float
        Cell ends, ``0 <= a < b``.

    Returns
    -------
    i_left, i_right, k_left, k_right : ndarray of complex, broadcast shape

    Examples
    --------
    >>> il, ir, kl, kr = radial_half_cell_moments(0.5 + 0.5j, 2.0, 3.0)
    >>> bool(np.isclose(il + ir, radial_moment_i(0.5 + 0.5j, 2.0, 3.0)))
    True
    """
    shape, beta, a, b = _flat_cells(beta, a, b)
    m = 0.5 * (a + b)
    taylor = _taylor_ok(beta, a, b)
    other = ~taylor
    outs = [np.empty(beta.shape, dtype=complex) for _ in range(4)]
    bo, ao, mo, b_o = beta[other], a[other], m[other], b[other]
    outs[0][other] = radial_moment_i(bo, ao, mo) * np.exp(-bo.real * (b_o - mo))
    outs[1][other] = radial_moment_i(bo, mo, b_o)
    outs[2][other] = radial_moment_k(bo, ao, mo)
    outs[3][other] = radial_moment_k(bo, mo, b_o) * _exp_neg(bo * (mo - ao))
    if np.any(taylor):
        bt, mt, half = beta[taylor], m[taylor], 0.5 * (b[taylor] - a[taylor])
        lo, up = a[taylor] - mt, b[taylor] - mt
        pieces = [(lo / half, 0.0), (0.0, up / half)]
        scale_i = np.exp(-bt.real * up)                 # e^{-Re(beta)(b - m)}
        scale_k = np.exp(bt * lo)                       # e^{-beta (m - a)}
        il, ir = _taylor_i(bt, mt, half, pieces)
        kl, kr = _taylor_k(bt, mt, half, pieces)
        outs[0][taylor], outs[1][taylor] = il * scale_i, ir * scale_i
        outs[2][taylor], outs[3][taylor] = kl * scale_k, kr * scale_k
    return tuple(o.reshape(shape) for o in outs)
