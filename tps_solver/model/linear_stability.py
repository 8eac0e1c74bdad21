r"""Linear stability of periodically bouncing flat layers, eqs. (25)-(35).

Between impacts a normal-mode perturbation :math:`\hat w(z) e^{\sigma t + i k x}`
of a flat layer of thickness :math:`h` satisfies the eigenvalue problem (28)-(29)

.. math::  (\mathscr L - \lambda \mathscr M)\hat w = 0, \quad
           \mathscr M = \partial_z^2 - k^2, \quad \mathscr L = \mathscr M^2,
           \quad \lambda = \sigma/\nu, \qquad -h/2 < z < h/2,

   (\mathscr M + 2k^2)\hat w = 0, \quad (\mathscr M - 2k^2 - \lambda)\partial_z\hat w = 0
   \quad\text{at } z = \pm h/2,

with :math:`\lambda` appearing in a boundary condition.  With
:math:`q^2 = k^2 + \lambda`, :math:`\gamma = q/k` and :math:`\kappa = kh/2` the
paper reduces it to the secular equation (35),
:math:`(\tanh\gamma\kappa/\tanh\kappa)^{\pm 1} = 4\gamma/(\gamma^2+1)^2`.

Parity and labels (checked here, not taken on trust)
---------------------------------------------------
Inserting :math:`\hat w = A\sinh kz + B\sinh qz` (odd in :math:`z`) into (29)
gives :math:`2A\sinh\kappa + (\gamma^2+1)B\sinh\gamma\kappa = 0` and
:math:`(\gamma^2+1)A\cosh\kappa + 2\gamma B\cosh\gamma\kappa = 0`, whose determinant
vanishes iff :math:`\tanh\gamma\kappa/\tanh\kappa = 4\gamma/(\gamma^2+1)^2`: the
exponent **+1 belongs to odd** :math:`\hat w`.  The even ansatz (cosh) gives the
exponent **-1**.  Odd vertical velocity moves the two free surfaces in opposite
directions and changes the thickness, i.e. a **varicose** mode; even
:math:`\hat w` moves them together at constant thickness, a **sinuous** mode.
So the paper's labelling ("+1 varicose, -1 sinuous"; "sines, odd,
varicose"; "cosines, even, sinuous") is self-consistent and physically right.
Here ``mode="varicose"`` means odd :math:`\hat w` (exponent +1) and
``mode="sinuous"`` means even :math:`\hat w` (exponent -1).

Roots the paper missed, and two roots that are not eigenvalues
--------------------------------------------------------------
The paper states that :math:`\gamma = 1` (both families) and :math:`\gamma = 0`
(varicose) are the only solutions of (35).  Measured here (and proved below):

* :math:`\gamma = 1` is a root of (35) for every :math:`\kappa` but **not** an
  eigenvalue of (28)-(29): at :math:`q = k` the two basis functions coincide and
  the determinant vanishes trivially.  With the proper basis
  :math:`\{\cosh kz, z\sinh kz\}` at :math:`\lambda = 0` the boundary determinant
  is :math:`(\sinh 2\kappa - 2\kappa)/2 \ne 0` (sinuous) and
  :math:`-(\sinh 2\kappa + 2\kappa)/2 \ne 0` (varicose).  So there is no neutral
  mode :math:`\sigma = 0` for :math:`k > 0`.
* :math:`\gamma = 0` solves the varicose (35) because :math:`\sinh qz` vanishes
  identically at :math:`q = 0`; with the basis :math:`\{\sinh kz, z\}` the
  determinant is :math:`4\sinh\kappa - \kappa\cosh\kappa`, zero only at
  :math:`\kappa_c = 4\tanh\kappa_c \approx 3.9973`.  So :math:`\sigma = -\nu k^2`
  is an eigenvalue only at that single :math:`\kappa`.
* (35) has **other real roots** the paper missed.  For every :math:`\kappa > 0`
  the sinuous family has a root :math:`\gamma_1 \in (0, 1)` (the even secular
  function changes sign on :math:`(0, 1)`): e.g. :math:`\gamma_1^2 = 0.48806137`
  at :math:`\kappa = 1` (:math:`\sigma = -0.51193863\,\nu k^2`) and
  :math:`\gamma_1^2 = 0.98690178` at :math:`\kappa = 0.1`.  The varicose family
  has a root :math:`\gamma \in (0, 1)` for :math:`\kappa > \kappa_c`
  (:math:`\gamma^2 = 0.04838032` at :math:`\kappa = 5`).  On the imaginary axis
  :math:`\gamma = i\beta` both families have an infinite sequence of roots,
  :math:`\lambda = -k^2(1 + \beta^2)`.
* Limits (measured, see ``validation/linear_stability.py``): for
  :math:`\kappa \to 0` the sinuous root behaves as :math:`\gamma_1^2 - 1 \approx
  -\tfrac43\kappa^2`, i.e. :math:`\sigma \approx -\nu k^4 h^2/3`, and the
  least-damped varicose root tends to :math:`\gamma = i\sqrt3`
  (:math:`\sigma \to -4\nu k^2`); for :math:`\kappa \to \infty` both families
  tend to the single-free-surface root of :math:`4\gamma = (\gamma^2+1)^2`, i.e.
  :math:`\gamma^3 + \gamma^2 + 3\gamma - 1 = 0`, :math:`\gamma = 0.2955977425`.
* There are **no** roots with :math:`\gamma > 1` (i.e. :math:`\sigma > 0`):
  concavity of tanh gives :math:`\tanh\gamma\kappa / \tanh\kappa \le \gamma \le
  (\gamma^2+1)^2/(4\gamma)` with equality only at :math:`\gamma = 1`.  Off the
  real and imaginary :math:`\gamma` axes (complex :math:`\lambda`) the argument
  principle finds no roots inside the disc it checks (see :func:`secular_roots`).

So every eigenvalue is real and negative: the paper's conclusion (flat layers are
linearly stable) holds, and more strongly than stated, since the least-damped
mode decays at a finite rate instead of being neutral.  The Chebyshev
discretisation :func:`chebyshev_eigenvalues` of (28)-(29), which never uses (35),
reproduces exactly these roots (and no eigenvalue at :math:`\lambda = 0`).

Numerics
--------
Everything is written in :math:`s = p^2 = (\gamma\kappa)^2`.  The secular
determinants, divided by their trivial factors, are entire real functions of
:math:`s` (:func:`reduced_secular_function`); the trivial factors are removed
analytically (a divided difference of :math:`\tanh`) so that roots near
:math:`\gamma = 1` keep full relative accuracy.  Real roots are bracketed on a
grid and polished with Brent's method; a winding-number count of the zeros inside
a disc in the :math:`s` plane certifies that no complex root was missed.  Each root
carries a first-order error bound (rounding error of the secular function over
its slope, times the amplification from the root variable to :math:`\gamma`); where
it exceeds :data:`POLISH_REL` the root is re-solved by bisection of the plain
determinant in mpmath.  That is needed near :math:`\kappa_c = 4\tanh\kappa_c`, where
the least-damped varicose root :math:`\gamma \to 0` is ill-conditioned in double
precision (:math:`\kappa^4 - 4\kappa^3\tanh\kappa` cancels).
Hyperbolic functions are evaluated in scaled form, so :math:`\kappa` up to 1e3
gives no overflow.
"""
import math

import mpmath
import numpy as np
from scipy import linalg, optimize

from tps_solver.core import archive as io
from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_choice, check_int, check_positive

__all__ = [
    "secular_roots", "growth_rates", "reduced_secular_function",
    "chebyshev_eigenvalues", "SecularRoots", "KAPPA_C", "MODES", "POLISH_REL",
]

MODES = ("sinuous", "varicose")
_KAPPA_MAX = 1.0e3
_KAPPA_MIN = 1.0e-6
_N_MAX = 1000
_EPS = np.finfo(float).eps

#: Relative error bound on gamma above which a root is re-solved in extended precision.
POLISH_REL = 4.0 * _EPS


def _kappa_c():
    """Root of kappa = 4 tanh(kappa): the only kappa where gamma = 0 is a varicose eigenvalue."""
    return optimize.brentq(lambda x: x - 4.0 * math.tanh(x), 3.0, 5.0, xtol=1e-15, rtol=4 * np.finfo(float).eps)


KAPPA_C = _kappa_c()


def _check_kappa(kappa):
    kappa = check_positive(kappa, "kappa")
    if not _KAPPA_MIN <= kappa <= _KAPPA_MAX:
        raise ValueError(f"kappa must be a finite number in [{_KAPPA_MIN:g}, {_KAPPA_MAX:g}], got {kappa!r}")
    return kappa


# ----------------------------------------------------------------------------- secular functions


def _sinhc_minus_one(u):
    """sinh(u)/u - 1 for real |u| <= 1, accurate near 0 (Taylor series there)."""
    u = np.asarray(u, dtype=float)
    u2 = u * u
    small = np.abs(u) < 0.1
    series = u2 / 6.0 * (1.0 + u2 / 20.0 * (1.0 + u2 / 42.0 * (1.0 + u2 / 72.0 * (1.0 + u2 / 110.0))))
    safe = np.where(small, 1.0, u)
    return np.where(small, series, np.sinh(safe) / safe - 1.0)


def _tanh_minus_x(x):
    """tanh(x) - x for real x >= 0, accurate near 0 (Taylor series for x < 0.1)."""
    x = np.asarray(x, dtype=float)
    x2 = x * x
    coeffs = (-1.0 / 3, 2.0 / 15, -17.0 / 315, 62.0 / 2835, -1382.0 / 155925, 21844.0 / 6081075,
              -929569.0 / 638512875)
    series = np.zeros_like(x)
    for c in coeffs[::-1]:
        series = series * x2 + c
    return np.where(x < 0.1, series * x * x2, np.tanh(x) - x)


def _sech(x):
    """1/cosh(x) for real x without overflow."""
    e = np.exp(-2.0 * np.abs(x))
    return 2.0 * np.exp(-np.abs(x)) / (1.0 + e)


def _dT(p, d, kappa):
    r"""Divided difference (T(kappa) - T(p)) / d of T(x) = tanh x - x, with d = kappa - p in (0, kappa].

    Uses tanh(kappa) - tanh(p) = sinh(d) sech(kappa) sech(p); for kappa <= 1 the
    identity sech(kappa) sech(p) - 1 = -[sinh^2((kappa+p)/2) + sinh^2(d/2)] sech(kappa) sech(p)
    removes the cancellation that would otherwise cost 1/kappa^2 in relative accuracy.
    """
    sech2 = _sech(p) * _sech(kappa)
    near = d <= 1.0
    dn = np.where(near, d, 0.0)
    if kappa <= 1.0:
        return (_sinhc_minus_one(dn) - np.sinh(0.5 * (kappa + p)) ** 2 - np.sinh(0.5 * dn) ** 2) * sech2
    far = (math.tanh(kappa) - np.tanh(p)) / np.where(near, 1.0, d) - 1.0
    return np.where(near, (_sinhc_minus_one(dn) + 1.0) * sech2 - 1.0, far)


def _phi_upper(d, kappa, mode):
    r"""Reduced secular function at real p = kappa - d, d in [0, kappa] (0 <= s <= kappa^2).

    Equals D(s) / ((s - kappa^2) cosh p) with D the even determinant (sinuous) or
    the odd determinant divided by p (varicose); see :func:`reduced_secular_function`.
    Written with T(x) = tanh x - x so that the O(kappa^3) parts cancel analytically:
    sinuous  kappa d (2 kappa - d) + 4 kappa^3 (T(p) + kappa dT) / (p + kappa) - (p^2 + 3 kappa^2) T(kappa),
    varicose (p^2 + kappa^2)^2 Q + g(kappa) (p^2 + 3 kappa^2), Q = (g(p) - g(kappa)) / (p^2 - kappa^2),
    g(x) = tanh(x) / x.  The root variable d keeps full relative accuracy for roots near gamma = 1.
    """
    d = np.asarray(d, dtype=float)
    p = kappa - d
    k2 = kappa * kappa
    Tk = float(_tanh_minus_x(np.array(kappa)))
    tk = math.tanh(kappa)
    dT = _dT(p, d, kappa)
    # for kappa > 1 the T-form trades a cancellation ~kappa for nothing away from p = kappa;
    # there the plain form [F(p)] / (p^2 - kappa^2) is better conditioned
    direct = (kappa > 1.0) & (d > 0.25 * kappa)
    den = np.where(direct, (p - kappa) * (p + kappa), 1.0)
    if mode == "sinuous":
        t_form = (kappa * d * (2.0 * kappa - d) + 4.0 * kappa ** 3 * (_tanh_minus_x(p) + kappa * dT) / (p + kappa)
                  - (p * p + 3.0 * k2) * Tk)
        plain = (4.0 * kappa ** 3 * p * np.tanh(p) - (p * p + k2) ** 2 * tk) / den
        return np.where(direct, plain, t_form)
    gk = tk / kappa
    low = p < 0.5 * kappa
    p_low = np.where(low, p, 0.5 * kappa)
    small = p_low < 1e-4
    g_low = np.where(small, 1.0 - p_low ** 2 / 3.0, np.tanh(p_low) / np.where(small, 1.0, p_low))
    q_low = (g_low - gk) / (p_low ** 2 - k2)
    p_high = np.where(low, kappa, p)
    # g(p) - g(k) = (k - p)(tanh k - R) / (p k) with R = k (1 + dT)  =>  Q = (k dT - T(k)) / (p k (p + k))
    q_high = (kappa * np.where(low, 0.0, dT) - Tk) / (p_high * kappa * (p_high + kappa))
    Q = np.where(low, q_low, q_high)
    t_form = (p * p + k2) ** 2 * Q + gk * (p * p + 3.0 * k2)
    g_p = np.where(p < 1e-4, 1.0 - p ** 2 / 3.0, np.tanh(p) / np.where(p < 1e-4, 1.0, p))
    plain = ((p * p + k2) ** 2 * g_p - 4.0 * kappa ** 3 * tk) / den
    return np.where(direct, plain, t_form)


def _phi_lower(m, kappa, mode):
    """Reduced secular function for s = -m^2 <= 0 (gamma = i m / kappa); same sign convention."""
    m = np.asarray(m, dtype=float)
    k2 = kappa * kappa
    tk = math.tanh(kappa)
    if mode == "sinuous":
        D = -4.0 * kappa ** 3 * m * np.sin(m) - (k2 - m * m) ** 2 * tk * np.cos(m)
    else:
        D = (k2 - m * m) ** 2 * np.sinc(m / np.pi) - 4.0 * kappa ** 3 * tk * np.cos(m)
    return D / (-m * m - k2)


def _phi_complex(s, kappa, mode):
    """Reduced secular function at complex s, times the positive factor exp(-Re sqrt(s))."""
    s = np.asarray(s, dtype=complex)
    k2 = kappa * kappa
    tk = math.tanh(kappa)
    p = np.sqrt(s)
    a = p.real
    e1 = np.exp(1j * p.imag)
    e2 = np.exp(-2.0 * a - 1j * p.imag)
    ch = 0.5 * (e1 + e2)
    sh = 0.5 * (e1 - e2)
    if mode == "sinuous":
        D = 4.0 * kappa ** 3 * p * sh - (s + k2) ** 2 * tk * ch
    else:
        small = np.abs(p) < 1e-3
        safe = np.where(small, 1.0, p)
        shp = np.where(small, (1.0 + s / 6.0 + s * s / 120.0) * np.exp(-a), sh / safe)
        D = (s + k2) ** 2 * shp - 4.0 * kappa ** 3 * tk * ch
    return D / (s - k2)


def reduced_secular_function(s, kappa, mode):
    r"""The secular determinant of (28)-(29) with its trivial roots divided out.

    For :math:`s = (\gamma\kappa)^2` this is, up to a factor that is positive
    for real :math:`s`,

    * sinuous: :math:`[4\kappa^3 p\sinh p - (s+\kappa^2)^2\tanh\kappa\cosh p]/(s-\kappa^2)`,
    * varicose: :math:`[(s+\kappa^2)^2 \sinh(p)/p - 4\kappa^3\tanh\kappa\cosh p]/(s-\kappa^2)`,

    with :math:`p = \sqrt s`.  Both are entire in :math:`s`; their zeros are
    exactly the eigenvalues :math:`\lambda = k^2(s/\kappa^2 - 1)` of (28)-(29).
    The removed factors :math:`s - \kappa^2` and (varicose) :math:`p` are the
    trivial roots :math:`\gamma = 1` and :math:`\gamma = 0` of (35).

    Parameters
    ----------
    s : array_like of float or complex
        Points :math:`s = \gamma^2\kappa^2`.
    kappa : float
        :math:`\kappa = kh/2 > 0`.
    mode : {"sinuous", "varicose"}

    Returns
    -------
    phi : ndarray of float (real ``s``) or complex (complex ``s``), shape of ``s``
        For real ``s`` it is divided by :math:`\cosh p` when :math:`s > 0`; for
        complex ``s`` it is multiplied by :math:`e^{-\mathrm{Re}\,p}`.  Both factors
        are positive, so signs (real ``s``) and arguments (complex ``s``) are exact.

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver.model.linear_stability import reduced_secular_function
    >>> round(float(reduced_secular_function(0.0, 1.0, "sinuous")), 12)  # kappa^2 tanh(kappa)
    0.761594155956
    """
    kappa = _check_kappa(kappa)
    mode = check_choice(mode, "mode", MODES)
    s_arr = np.asarray(s)
    if np.iscomplexobj(s_arr):
        return _phi_complex(s_arr, kappa, mode)
    s_arr = s_arr.astype(float)
    k2 = kappa * kappa
    out = np.empty(s_arr.shape)
    up = (s_arr >= 0) & (s_arr <= k2)
    lo = s_arr < 0
    hi = s_arr > k2
    out[up] = _phi_upper(kappa - np.sqrt(s_arr[up]), kappa, mode)
    out[lo] = _phi_lower(np.sqrt(-s_arr[lo]), kappa, mode)
    if np.any(hi):
        p = np.sqrt(s_arr[hi])
        out[hi] = (_phi_complex(s_arr[hi].astype(complex), kappa, mode)).real / (0.5 * (1.0 + np.exp(-2.0 * p)))
    return out[()] if out.ndim == 0 else out


# ----------------------------------------------------------------------------- root finding


def _brent(f, a, b):
    return optimize.brentq(f, a, b, xtol=1e-300, rtol=4.5 * np.finfo(float).eps, maxiter=500)


def _bracket_roots(f, grid):
    """Brent-polished roots of ``f`` at sign changes on the increasing ``grid``."""
    vals = f(grid)
    roots = []
    for i in range(len(grid) - 1):
        fa, fb = vals[i], vals[i + 1]
        if fa == 0.0:
            roots.append(grid[i])
        elif fa * fb < 0.0:
            roots.append(_brent(lambda x: float(f(np.array([x]))[0]), grid[i], grid[i + 1]))
    return roots


def _upper_roots(kappa, mode):
    """Roots d = kappa - p in (0, kappa] (real gamma = 1 - d/kappa in [0, 1)), increasing.

    The grid is uniform in d plus geometric towards d = 0: the sinuous root sits at
    d ~ (2/3) kappa^3 for small kappa.
    """
    grid = kappa * np.union1d(np.linspace(0.0, 1.0, 513)[1:], np.logspace(-18, 0, 181))
    return sorted(_bracket_roots(lambda d: _phi_upper(d, kappa, mode), grid))


def _lower_roots(kappa, mode, n_wanted):
    """The first ``n_wanted`` roots m > 0 (gamma = i m / kappa), increasing."""
    roots = []
    m_lo = 0.0
    step = math.pi / 32.0
    fine = min(step, kappa / 64.0)
    while len(roots) < n_wanted:
        m_hi = m_lo + max(8.0 * math.pi, 2.0 * math.pi * (n_wanted - len(roots) + 1))
        coarse = np.arange(m_lo, m_hi + step / 2, step)
        grid = coarse
        if m_lo < 2.0 * kappa:
            grid = np.union1d(coarse, np.arange(m_lo, min(2.0 * kappa, m_hi), fine))
        found = _bracket_roots(lambda m: _phi_lower(m, kappa, mode), grid)
        roots.extend(r for r in found if not roots or r > roots[-1])
        m_lo = grid[-1]
    return roots[:n_wanted]


def _magnitude_upper(d, kappa, mode):
    """Sum of the absolute values of the terms that :func:`_phi_upper` adds (its rounding scale)."""
    d = np.asarray(d, dtype=float)
    p = kappa - d
    k2 = kappa * kappa
    Tk = abs(float(_tanh_minus_x(np.array(kappa))))
    tk = math.tanh(kappa)
    dT = np.abs(_dT(p, d, kappa))
    direct = (kappa > 1.0) & (d > 0.25 * kappa)
    den = np.abs(np.where(direct, (p - kappa) * (p + kappa), 1.0))
    if mode == "sinuous":
        t_form = (kappa * d * (2.0 * kappa - d) + 4.0 * kappa ** 3 * (np.abs(_tanh_minus_x(p)) + kappa * dT)
                  / (p + kappa) + (p * p + 3.0 * k2) * Tk)
        plain = (4.0 * kappa ** 3 * p * np.tanh(p) + (p * p + k2) ** 2 * tk) / den
        return np.where(direct, plain, t_form)
    gk = tk / kappa
    g_p = np.where(p < 1e-4, 1.0, np.tanh(p) / np.where(p < 1e-4, 1.0, p))
    low = p < 0.5 * kappa
    p_safe = np.where(p > 0, p, 1.0)
    q_mag = np.where(low, (g_p + gk) / np.abs(p * p - k2 + (p * p == k2)),
                     (kappa * dT + Tk) / (p_safe * kappa * (p_safe + kappa)))
    t_form = (p * p + k2) ** 2 * q_mag + gk * (p * p + 3.0 * k2)
    plain = ((p * p + k2) ** 2 * g_p + 4.0 * kappa ** 3 * tk) / den
    return np.where(direct, plain, t_form)


def _magnitude_lower(m, kappa, mode):
    """Sum of the absolute values of the terms that :func:`_phi_lower` adds (its rounding scale)."""
    m = np.asarray(m, dtype=float)
    k2 = kappa * kappa
    tk = math.tanh(kappa)
    if mode == "sinuous":
        mag = 4.0 * kappa ** 3 * np.abs(m * np.sin(m)) + (k2 - m * m) ** 2 * tk * np.abs(np.cos(m))
    else:
        mag = (k2 - m * m) ** 2 * np.abs(np.sinc(m / np.pi)) + 4.0 * kappa ** 3 * tk * np.abs(np.cos(m))
    return mag / (m * m + k2)


def _error_bound(f, magnitude, x, amplification, c=4.0):
    r"""First-order relative error bound of the root ``x`` of ``f`` carried over to gamma.

    :math:`c\,\epsilon\,|f|_{
m terms}/(|f'(x)|\,|x|)` (rounding error of ``f`` over its
    slope) times ``amplification`` = :math:`|x\,d\gamma/dx|/|\gamma|`, plus the
    rounding of gamma itself.  The slope is a central difference with step 1e-5 x.
    """
    h = 1e-5 * abs(x)
    if h == 0.0:
        return math.inf
    slope = abs(float(f(np.array([x + h]))[0] - f(np.array([x - h]))[0])) / (2.0 * h)
    scale = float(magnitude(np.array([x]))[0])
    if not (slope > 0.0 and math.isfinite(slope) and math.isfinite(scale)):
        return math.inf
    return c * _EPS * scale / (slope * abs(x)) * amplification + _EPS


def _mp_determinant(x, k, tk, mode, branch):
    """The secular determinant (trivial factors kept) at the root variable x, in mpmath.

    ``k`` is kappa and ``tk`` its tanh, both mpf at the working precision.
    """
    if branch == "upper":                      # p = kappa - x real
        p = k - x
        sh_p = mpmath.sinh(p) / p if p != 0 else mpmath.mpf(1)
        if mode == "sinuous":
            return 4 * k ** 3 * p * mpmath.sinh(p) - (p * p + k * k) ** 2 * tk * mpmath.cosh(p)
        return (p * p + k * k) ** 2 * sh_p - 4 * k ** 3 * tk * mpmath.cosh(p)
    m = x                                      # p = i m
    if mode == "sinuous":
        return -4 * k ** 3 * m * mpmath.sin(m) - (k * k - m * m) ** 2 * tk * mpmath.cos(m)
    sn_m = mpmath.sin(m) / m if m != 0 else mpmath.mpf(1)
    return (k * k - m * m) ** 2 * sn_m - 4 * k ** 3 * tk * mpmath.cos(m)


def _polish_mp(x, rel, kappa, mode, branch):
    """Re-solve the root near ``x`` (relative error about ``rel``) by mpmath bisection.

    Returns ``(gamma, lam, s)`` rounded from the extended-precision root, or None
    if no sign change is found within a few widenings of the bracket.
    """
    lost = math.log10(max(1.0, kappa / x)) if branch == "upper" else 0.0
    dps = 30 + int(2 * math.ceil(lost)) + 4 * int(math.ceil(max(0.0, -math.log10(kappa))))
    with mpmath.workdps(dps):
        xm = mpmath.mpf(x)
        k = mpmath.mpf(kappa)
        tk = mpmath.tanh(k)
        f = lambda y: _mp_determinant(y, k, tk, mode, branch)  # noqa: E731
        width = max(64.0 * _EPS, 8.0 * rel)
        for _ in range(8):
            a, b = xm * (1 - width), xm * (1 + width)
            if branch == "upper" and b > k:
                b = k
            fa, fb = f(a), f(b)
            if fa * fb < 0:
                break
            width *= 8.0
            if width >= 0.5:
                return None
        else:
            return None
        tol = xm * mpmath.mpf(10) ** -22
        while b - a > tol:
            c = (a + b) / 2
            fc = f(c)
            if fc == 0:
                a = b = c
                break
            if fa * fc < 0:
                b = c
            else:
                a, fa = c, fc
        root = (a + b) / 2
        if branch == "upper":
            g = 1 - root / k
            return complex(float(g)), float(g * g - 1), float((k - root) ** 2)
        g = root / k
        return complex(0.0, float(g)), float(-g * g - 1), float(-root * root)


def _winding_number(f, center, radius, n0=4096, max_points=2 ** 23, sqrt_scale=False):
    """Zeros of analytic ``f`` inside the circle |s - center| = radius (argument principle).

    The circle is refined adaptively: an arc is bisected while arg f changes by more
    than pi/8 over it or, with ``sqrt_scale`` (for the secular functions, whose fast
    factors are exp(+-sqrt(s)) and rational in s), while |d sqrt(s)| > 1/8 or
    |ds| > |s|/8 -- a resolution fixed by the analytic structure, so a phase that
    winds by 2 pi between two samples cannot be missed.  Returns
    ``(count, n_points, resolved)``; ``resolved`` is False if ``max_points`` was reached.
    """
    theta = 2.0 * np.pi * np.arange(n0 + 1) / n0
    s = center + radius * np.exp(1j * theta)
    vals = f(s)
    while True:
        dphi = np.angle(vals[1:] / vals[:-1])
        refine = np.abs(dphi) > np.pi / 8
        if sqrt_scale:
            ds = np.abs(np.diff(s))
            r = np.sqrt(s)  # f is even in sqrt(s): across the branch cut compare with -sqrt(s)
            refine |= np.minimum(np.abs(r[1:] - r[:-1]), np.abs(r[1:] + r[:-1])) > 0.125
            refine |= ds > 0.125 * np.minimum(np.abs(s[1:]), np.abs(s[:-1]))
        bad = np.flatnonzero(refine)
        if bad.size == 0 or theta.size + bad.size > max_points:
            return int(round(dphi.sum() / (2.0 * np.pi))), theta.size, bad.size == 0
        mid = 0.5 * (theta[bad] + theta[bad + 1])
        s_mid = center + radius * np.exp(1j * mid)
        theta = np.insert(theta, bad + 1, mid)
        s = np.insert(s, bad + 1, s_mid)
        vals = np.insert(vals, bad + 1, f(s_mid))


class SecularRoots(Bunch):
    """Result of :func:`secular_roots` (a :class:`~tps_solver.core.bunch.Bunch`).

    Attributes
    ----------
    kappa : float
    mode : str
    gamma : ndarray of complex, shape (n_roots,)
        The roots of (35) that are eigenvalues of (28)-(29), one per eigenvalue,
        on the branch ``Re gamma >= 0``, ``Im gamma >= 0`` (``gamma`` and
        ``-gamma`` give the same mode), sorted by decreasing ``Re(gamma**2)``, i.e.
        least damped first.  Real entries lie in (0, 1); the others are ``i beta``.
    lam : ndarray of float, shape (n_roots,)
        ``gamma**2 - 1 = lambda / k**2 = sigma / (nu k**2)``, all < 0.
    trivial : ndarray of complex, shape (1,) or (2,)
        Roots of (35) that come from the degenerate basis: ``[1]`` (sinuous) or
        ``[1, 0]`` (varicose).  They are *not* in ``gamma``.
    trivial_is_eigenvalue : ndarray of bool, same shape as ``trivial``
        Whether the trivial root is nevertheless an eigenvalue of (28)-(29):
        always False for ``gamma = 1``; for varicose ``gamma = 0`` True only at
        ``kappa = KAPPA_C`` (to round-off), where it also appears in ``gamma``.
    n_enclosed : int
        Argument-principle count of zeros of the reduced secular function inside
        ``contour`` (complex ones included).
    complete : bool
        ``n_enclosed == n_roots``: no complex or missed root inside the contour.
    contour : tuple of float
        ``(center, radius)`` of the checked circle in the ``s = (gamma kappa)**2`` plane;
        it contains every returned root and crosses the real axis between the
        ``n_roots``-th and the next root.
    error_bound : ndarray of float, shape (n_roots,)
        Estimated bound on ``|delta gamma| / |gamma|`` of each root (first order in
        the rounding error of the secular function); ``eps`` for a polished root.
    polished : ndarray of bool, shape (n_roots,)
        Roots whose double-precision bound exceeded :data:`POLISH_REL` and that were
        re-solved in mpmath (near ``KAPPA_C``, the varicose root ``gamma -> 0``).

    Examples
    --------
    The least damped sinuous root at ``kappa = 1`` is real, the next ones are ``i beta``;
    ``lam = gamma**2 - 1`` holds for each:

    >>> import numpy as np
    >>> from tps_solver import secular_roots
    >>> r = secular_roots(1.0, "sinuous", 3)
    >>> type(r).__name__, r.gamma.round(6)
    ('SecularRoots', array([0.698614+0.j      , 0.      +2.218843j, 0.      +4.765445j]))
    >>> bool(np.allclose(r.lam, (r.gamma ** 2 - 1).real)), r.complete
    (True, True)
    """

    def save(self, path):
        """Write the roots to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return io.save(self, path)


def secular_roots(kappa, mode, n_roots=10):
    r"""Roots of the secular equation (35) in the complex :math:`\gamma` plane.

    Implements (35), :math:`(\tanh\gamma\kappa/\tanh\kappa)^{\pm1} = 4\gamma/(\gamma^2+1)^2`,
    exponent +1 for ``"varicose"`` (odd :math:`\hat w`) and -1 for ``"sinuous"``
    (even :math:`\hat w`), as the paper says and as re-derived in the module
    docstring.  The search covers the real :math:`\gamma` axis, the imaginary axis
    :math:`\gamma = i\beta` (infinitely many damped roots,
    :math:`\lambda = -k^2(1+\beta^2)`) and, by the argument principle, the rest of
    the plane inside a disc around the returned roots.  The trivial roots
    :math:`\gamma = 1` and (varicose) :math:`\gamma = 0` are reported separately:
    they solve (35) but are not eigenvalues (module docstring).

    Parameters
    ----------
    kappa : float
        :math:`\kappa = k h / 2`, in [1e-6, 1e3].
    mode : {"sinuous", "varicose"}
    n_roots : int, optional
        Number of non-trivial roots to return (least damped first), 1..1000.

    Returns
    -------
    res : SecularRoots
        Always the same type; fields ``gamma`` (complex, shape ``(n_roots,)``),
        ``lam``, ``trivial``, ``trivial_is_eigenvalue``, ``n_enclosed``,
        ``complete``, ``contour``, ``kappa``, ``mode``, ``error_bound``, ``polished``.

    Raises
    ------
    ValueError
        If ``kappa`` is not in [1e-6, 1e3], ``mode`` is unknown or ``n_roots`` < 1.

    Examples
    --------
    >>> from tps_solver import secular_roots
    >>> r = secular_roots(1.0, "sinuous", 3)
    >>> r.gamma.round(6)
    array([0.698614+0.j      , 0.      +2.218843j, 0.      +4.765445j])
    >>> r.trivial, r.trivial_is_eigenvalue, r.complete
    (array([1.+0.j]), array([False]), True)
    """
    kappa = _check_kappa(kappa)
    mode = check_choice(mode, "mode", MODES)
    n_roots = check_int(n_roots, "n_roots", minimum=1, maximum=_N_MAX)
    k2 = kappa * kappa

    upper = _upper_roots(kappa, mode)                # d = kappa - p, increasing: s decreasing
    n_up = min(len(upper), n_roots + 1)
    upper = upper[:n_up]
    lower = _lower_roots(kappa, mode, n_roots + 1 - n_up)  # m, increasing
    # lam = gamma^2 - 1 without cancellation: -d (2 kappa - d) / kappa^2 and -(m^2 + kappa^2) / kappa^2
    lam = [-d * (2.0 * kappa - d) / k2 for d in upper] + [-(m * m + k2) / k2 for m in lower]
    gamma = [complex(1.0 - d / kappa) for d in upper] + [complex(0.0, m / kappa) for m in lower]
    s_all = [(kappa - d) ** 2 for d in upper] + [-m * m for m in lower]
    # per-root error bounds; ill-conditioned roots are re-solved in extended precision
    f_up = lambda d: _phi_upper(d, kappa, mode)  # noqa: E731
    f_lo = lambda m: _phi_lower(m, kappa, mode)  # noqa: E731
    bound, polished = [], []
    for i, (branch, x) in enumerate([("upper", d) for d in upper] + [("lower", m) for m in lower]):
        if i >= n_roots:
            break
        if branch == "upper":
            g = 1.0 - x / kappa
            amp = (x / kappa) / g if g > 0 else math.inf
            rel = _error_bound(f_up, lambda d: _magnitude_upper(d, kappa, mode), x, amp)
        else:
            rel = _error_bound(f_lo, lambda m: _magnitude_lower(m, kappa, mode), x, 1.0)
        done = False
        if rel > POLISH_REL and x > 0.0:
            better = _polish_mp(x, rel, kappa, mode, branch)
            if better is not None:
                gamma[i], lam[i], s_all[i] = better
                rel, done = _EPS, True
        bound.append(rel)
        polished.append(done)

    s_low = 0.5 * (s_all[n_roots - 1] + s_all[n_roots])
    s_high = k2 + max(k2, 1.0)
    center, radius = 0.5 * (s_low + s_high), 0.5 * (s_high - s_low)
    n_enclosed, _, resolved = _winding_number(lambda s: _phi_complex(s, kappa, mode), center, radius,
                                              sqrt_scale=True)

    if mode == "sinuous":
        trivial = np.array([1.0 + 0.0j])
        is_eig = np.array([False])
    else:
        trivial = np.array([1.0 + 0.0j, 0.0j])
        # gamma = 0 is an eigenvalue iff 4 tanh(kappa) = kappa, i.e. phi(0) = 0
        phi0 = float(_phi_lower(np.array([0.0]), kappa, mode)[0])
        scale = k2 + 4.0 * kappa * math.tanh(kappa)
        is_eig = np.array([False, abs(phi0) <= 64 * np.finfo(float).eps * scale])
    return SecularRoots(
        kappa=kappa, mode=mode,
        gamma=np.array(gamma[:n_roots], dtype=complex),
        lam=np.array(lam[:n_roots], dtype=float),
        trivial=trivial, trivial_is_eigenvalue=is_eig,
        n_enclosed=n_enclosed, complete=bool(resolved and n_enclosed == n_roots),
        contour=(center, radius),
        error_bound=np.array(bound, dtype=float), polished=np.array(polished, dtype=bool),
    )


def growth_rates(k, h, mode, n_modes=10, nu=1.0):
    r"""Growth rates :math:`\sigma = \nu k^2(\gamma^2 - 1)` of a flat layer's perturbations.

    Implements (27)-(28) with the roots of (35) from :func:`secular_roots` at
    :math:`\kappa = kh/2`.  The trivial roots of (35) are excluded because they
    are not eigenvalues (module docstring); in particular there is no neutral
    :math:`\sigma = 0` mode for :math:`k > 0`.

    Parameters
    ----------
    k : float
        Horizontal wavenumber :math:`k_o > 0`.
    h : float
        Layer thickness :math:`h > 0`; ``k * h / 2`` must lie in [1e-6, 1e3].
    mode : {"sinuous", "varicose"}
    n_modes : int, optional
        Number of modes, 1..1000.
    nu : float, optional
        Kinematic viscosity (1 in the package's units).

    Returns
    -------
    sigma : ndarray of float, shape (n_modes,)
        Sorted by decreasing value (least damped first); every entry is < 0.

    Examples
    --------
    >>> from tps_solver import growth_rates
    >>> growth_rates(1.0, 2.0, "varicose", 2).round(6)
    array([ -2.902524, -11.559266])
    """
    k = check_positive(k, "k")
    h = check_positive(h, "h")
    nu = check_positive(nu, "nu")
    mode = check_choice(mode, "mode", MODES)
    n_modes = check_int(n_modes, "n_modes", minimum=1, maximum=_N_MAX)
    kappa = k * h / 2.0
    if not _KAPPA_MIN <= kappa <= _KAPPA_MAX:
        raise ValueError(f"k * h / 2 must be in [{_KAPPA_MIN:g}, {_KAPPA_MAX:g}], got {kappa!r} "
                         f"(k={k!r}, h={h!r})")
    res = secular_roots(kappa, mode, n_modes)
    return nu * k * k * res.lam


# ----------------------------------------------------------------------------- Chebyshev check


def _ultraspherical_pencil(kappa, parity, n_cheb):
    r"""Pencil (A, B) of (28)-(29) for w and v = (D^2 - kappa^2) w / kappa^2 on x = 2z/h.

    Chebyshev coefficients of the given parity for w and v; the two second-order
    equations are imposed in the C^(2) (ultraspherical) basis, which keeps the
    matrices banded-like and well conditioned; two boundary rows at x = 1 (x = -1
    follows by parity).  Eigenvalue: lam = Lambda / kappa^2 = lambda / k^2.
    """
    N = 2 * n_cheb - (1 if parity == "even" else 0) - 1
    j = np.arange(N + 1)
    D2 = np.zeros((N + 1, N + 1))
    D2[j[2:] - 2, j[2:]] = 2.0 * j[2:]                      # T_n'' = 2 n C^(2)_{n-2}
    S0 = np.zeros((N + 1, N + 1))                           # T -> C^(1)
    S0[0, 0] = 1.0
    S0[j[1:], j[1:]] = 0.5
    S0[j[2:] - 2, j[2:]] -= 0.5
    S1 = np.zeros((N + 1, N + 1))                           # C^(1) -> C^(2)
    S1[j, j] = 1.0 / (j + 1.0)
    S1[j[2:] - 2, j[2:]] -= 1.0 / (j[2:] + 1.0)
    S = S1 @ S0
    idx = j[j % 2 == N % 2]
    rows = idx[:-1]
    k2 = kappa * kappa
    L = (D2 - k2 * S)[np.ix_(rows, idx)]
    Sr = S[np.ix_(rows, idx)]
    Z = np.zeros_like(L)
    # (D^2 - k^2) w - k^2 v = 0 ;  (D^2 - k^2) v = lam k^2 v
    A = np.block([[L, -k2 * Sr], [Z, L]])
    B = np.block([[Z, Z], [Z, k2 * Sr]])
    m = len(idx)
    at1 = np.ones(m)                                        # T_n(1)
    d_at1 = idx.astype(float) ** 2                          # T_n'(1)
    c = 1.0 / d_at1.max()
    # (29a): w'' + k^2 w = k^2 (v + 2 w) = 0 ; (29b): w''' - (3k^2 + Lambda) w' = k^2 (v' - 2w' - lam w') = 0
    A = np.vstack([A, np.concatenate([2.0 * at1, at1]), c * np.concatenate([-2.0 * d_at1, d_at1])])
    B = np.vstack([B, np.zeros(2 * m), c * np.concatenate([d_at1, np.zeros(m)])])
    return A, B


def _collocation_pencil(kappa, parity, n_cheb):
    """Same (w, v) system by Chebyshev collocation on the half Gauss-Lobatto grid (parity folded)."""
    H = n_cheb
    N = 2 * H
    x = np.cos(np.pi * np.arange(N + 1) / N)
    c = np.ones(N + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** np.arange(N + 1)
    X = x[:, None] - x[None, :]
    D = np.outer(c, 1.0 / c) / (X + np.eye(N + 1))
    D -= np.diag(D.sum(axis=1))
    if parity == "even":
        P = np.zeros((N + 1, H + 1))
        P[np.arange(H + 1), np.arange(H + 1)] = 1.0
        P[N - np.arange(H + 1), np.arange(H + 1)] = 1.0
        P[H, H] = 1.0
        rows = np.arange(H + 1)
    else:
        P = np.zeros((N + 1, H))
        P[np.arange(H), np.arange(H)] = 1.0
        P[N - np.arange(H), np.arange(H)] = -1.0
        rows = np.arange(H)
    d1 = (D @ P)[rows]
    d2 = (D @ (D @ P))[rows]
    eye = P[rows]
    k2 = kappa * kappa
    n = len(rows)
    Z = np.zeros_like(eye)
    A = np.block([[d2 - k2 * eye, -k2 * eye], [Z, d2 - k2 * eye]])
    B = np.block([[Z, Z], [Z, k2 * eye]])
    A[0] = np.concatenate([2.0 * eye[0], eye[0]])
    B[0] = 0.0
    A[n] = np.concatenate([-2.0 * d1[0], d1[0]])
    B[n] = np.concatenate([d1[0], np.zeros(n)])
    return A, B


def _refine(A, B, lam, x, y, n_iter=3):
    """Two-sided inverse iteration + generalised Rayleigh quotient for one eigenvalue.

    The shift is offset by 1e-9 |lam| so that an eigenvalue QZ found exactly
    (e.g. lam = -1 at KAPPA_C) does not give an exactly singular factorisation.
    """
    for _ in range(n_iter):
        shift = lam + 1e-9 * max(abs(lam), 1.0)
        lu = linalg.lu_factor(A - shift * B, check_finite=False)
        x = linalg.lu_solve(lu, B @ x, check_finite=False)
        x /= np.linalg.norm(x)
        y = linalg.lu_solve(lu, B.conj().T @ y, trans=2, check_finite=False)
        y /= np.linalg.norm(y)
        lam = (y.conj() @ (A @ x)) / (y.conj() @ (B @ x))
    return lam


def chebyshev_eigenvalues(kappa, mode, n_cheb=40, n_refine=10, method="ultraspherical"):
    r"""Eigenvalues :math:`\lambda/k^2` of (28)-(29) by a Chebyshev discretisation.

    Independent of (35): (28) is split into the second-order system
    :math:`(D^2-\kappa^2)\hat w = \kappa^2 v`, :math:`(D^2-\kappa^2)v = \Lambda v`
    on :math:`x = 2z/h \in [-1, 1]` (:math:`\Lambda = \lambda h^2/4`), the boundary
    conditions (29) become :math:`v + 2\hat w = 0` and
    :math:`v' - 2\hat w' = (\Lambda/\kappa^2)\hat w'` at :math:`x = 1` (the
    :math:`\lambda`-linear row of the generalised pencil), and parity is imposed
    by the basis: even :math:`\hat w` (sinuous) or odd (varicose).  The pencil is
    solved by QZ; the leading ``n_refine`` eigenvalues are then polished by
    two-sided inverse iteration with a generalised Rayleigh quotient, which
    removes the QZ round-off that dominates the small eigenvalue of the sinuous
    family at small :math:`\kappa` (normwise condition ~1e9 at
    :math:`\kappa = 0.1`, componentwise ~1.5e3).

    Parameters
    ----------
    kappa : float
        :math:`\kappa = kh/2`, in [1e-6, 1e3].
    mode : {"sinuous", "varicose"}
    n_cheb : int, optional
        Chebyshev polynomials of the family's parity per unknown (>= 4).
    n_refine : int, optional
        How many leading eigenvalues to polish (0 to skip).
    method : {"ultraspherical", "collocation"}, optional
        ``"ultraspherical"`` (default) imposes the equations on Chebyshev
        coefficients in the :math:`C^{(2)}` basis (Olver-Townsend); its matrices
        have O(n) entries.  ``"collocation"`` uses point values on the
        Gauss-Lobatto grid; its :math:`D^2` has O(n^4) entries and its round-off
        floor is measured (``validation/linear_stability.py``) at about 1e-7
        relative (6e-8 measured) for the first sinuous eigenvalue at :math:`\kappa = 0.1`, too
        coarse for a 1e-9 comparison.

    Returns
    -------
    lam : ndarray of complex, shape (n_finite,)
        All finite eigenvalues, sorted by decreasing real part.  Only the
        leading ones are resolved; the tail is discretisation noise.

    Examples
    --------
    >>> from tps_solver.model.linear_stability import chebyshev_eigenvalues
    >>> chebyshev_eigenvalues(1.0, "sinuous")[:2].real.round(8)
    array([-0.51193863, -5.92326222])
    """
    kappa = _check_kappa(kappa)
    mode = check_choice(mode, "mode", MODES)
    n_cheb = check_int(n_cheb, "n_cheb", minimum=4, maximum=400)
    n_refine = check_int(n_refine, "n_refine", minimum=0)
    method = check_choice(method, "method", ("ultraspherical", "collocation"))
    parity = "even" if mode == "sinuous" else "odd"
    build = _ultraspherical_pencil if method == "ultraspherical" else _collocation_pencil
    A, B = build(kappa, parity, n_cheb)
    w, vl, vr = linalg.eig(A, B, left=True, right=True, check_finite=False)
    finite = np.isfinite(w)
    w, vl, vr = w[finite], vl[:, finite], vr[:, finite]
    order = np.argsort(-w.real, kind="stable")
    w, vl, vr = w[order], vl[:, order], vr[:, order]
    for i in range(min(n_refine, len(w))):
        w[i] = _refine(A, B, w[i], vr[:, i], vl[:, i])
    order = np.argsort(-w.real, kind="stable")
    return w[order]


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_roots(f):
    if not f.float("kappa") > 0:
        f.fail(f"the field 'kappa' must be > 0, got {f.float('kappa')}")
    f.str("mode", ("sinuous", "varicose"))
    gamma = f.array("gamma", "c", ndim=1, finite=True)
    lam = f.array("lam", "f", shape=(gamma.size,), finite=True)
    if not np.all(np.abs(lam - ((gamma ** 2).real - 1.0)) <= 1e-12 * (np.abs(gamma) ** 2 + 1)):
        f.fail("inconsistent: lam is not gamma**2 - 1")


io.register("SecularRoots", SecularRoots, validate=_validate_roots)
