r"""Closed-form pieces of free flight and linear propagation: the phi-functions and flight maps.

One home for the formulas that the flat layer, the FDA integrators, the soft
contact and the exact lattice cycle share:

* :func:`phi1`, :func:`phi2`, :func:`taylor_tail` -- the entire functions
  :math:`\varphi_k(z) = (e^z - \sum_{j<k} z^j/j!)/z^k`, cancellation-free;
* :func:`flight_velocity`, :func:`flight_height` -- the plate-frame flight
  (17): a launch at :math:`t_s` with velocity :math:`v` from zero height;
* :func:`flight_map` -- the linearised flight of one lattice mode;
* :func:`expm_companion` -- :math:`\exp(At)` of the 2x2 damped oscillator;
* :class:`Flight` -- the one-node free flight in closed form and its certified next landing
  (:meth:`Flight.first_landing`), with :func:`gravity`, :func:`gravity_zeros`,
  :func:`next_liftoff`, :func:`bracket_root`: the one implementation that the flat layer
  (:mod:`tps_solver.model.flat`), the sticking orbits (:mod:`tps_solver.model.sticking`), the
  one-node ball (:mod:`tps_solver.model.ball`) and the impact-and-stick TPS use.

One-node flight
---------------
In flight the plate-frame acceleration is :math:`g(t) = \sin t - 1/\Gamma` (16).  After a
launch at :math:`t_a` with velocity :math:`w_a` and height :math:`\zeta_a`, in the local time
:math:`d = t - t_a`,

.. math::
    w &= w_a + \sin t_a \sin d + \cos t_a\,(1 - \cos d) - d/\Gamma, \\
    \zeta &= \zeta_a + w_a d + \sin t_a\,(1 - \cos d) - \cos t_a\,(\sin d - d) - d^2/(2\Gamma),

the plate-frame flight (17) rearranged so that every term keeps its relative precision for
short (chatter) flights: :math:`1 - \cos d = 2\sin^2(d/2)` (:func:`one_minus_cos`) and
:math:`\sin d - d` by its Taylor series for :math:`|d| < 1` (:func:`sin_minus_x`).

The next landing is certified: :math:`[0, H]` is cut at the zeros of :math:`g` (between them
:math:`w` is monotone) and at the zero of :math:`w` on each such piece, so :math:`\zeta` is
monotone on every piece and has at most one root there.  A landing is the first piece that
starts with :math:`\zeta > 0` and ends with :math:`\zeta \le 0` (a grazing minimum
:math:`\zeta = 0` exactly at a piece end counts), or a piece that starts at exactly
:math:`\zeta = 0` after the first.  A start with :math:`\zeta \le 0` never counts as a
landing at once: a launch from rest at the lift-off phase, where :math:`g(t_a)` is
:math:`\pm 1` ulp, makes :math:`w` and :math:`\zeta` negative by round-off for
:math:`d \lesssim 10^{-16}` only.  Roots are bracketed (:func:`bracket_root`: a geometric
shrink of the bracket towards its left end, so a root many decades shorter than the piece is
found as precisely as a long one), refined by ``brentq`` to relative accuracy 4 eps and
polished by safeguarded Newton steps on :math:`\zeta`.  Tested against mpmath at 30 digits
(tests/test_flight.py) on grazing landings, chatter flights down to :math:`10^{-12}` and
launches from rest at the lift-off phase.
"""
import math

import numpy as np
from scipy.optimize import brentq

__all__ = ["phi1", "phi2", "phi2_expm1", "taylor_tail", "flight_velocity", "flight_height", "flight_map",
           "expm_companion", "Flight", "gravity", "gravity_zeros", "next_liftoff", "liftoff_index",
           "bracket_root", "one_minus_cos", "sin_minus_x"]

_TWO_PI = 2.0 * math.pi
_RTOL = 4.0 * np.finfo(float).eps
# 1/(2k+3)! for the series of sin x - x = -x^3 sum_k (-x^2)^k / (2k+3)!, |x| < 1: 10 terms (< 1/23!)
_SMX = [1.0 / math.factorial(2 * k + 3) for k in range(10)]


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


# ----------------------------------------------------------------------------- one-node flight
def one_minus_cos(x):
    r""":math:`1 - \cos x = 2\sin^2(x/2)`, without cancellation for small ``x``.

    Examples
    --------
    >>> one_minus_cos(1e-9)
    5e-19
    """
    s = math.sin(0.5 * x)
    return 2.0 * s * s


def sin_minus_x(x):
    r""":math:`\sin x - x`, by its Taylor series (10 terms) for :math:`|x| < 1`, without cancellation.

    Examples
    --------
    >>> math.sin(1e-6) - 1e-6, sin_minus_x(1e-6)            # the direct form keeps 5 digits
    (-1.666537323722836e-19, -1.6666666666665832e-19)
    """
    if abs(x) < 1.0:
        x2 = x * x
        acc = _SMX[-1]
        for c in _SMX[-2::-1]:
            acc = c - x2 * acc
        return -x * x2 * acc
    return math.sin(x) - x


def gravity(t, Gamma):
    r"""Plate-frame acceleration :math:`g(t) = \sin t - 1/\Gamma`, eq. (16).

    Examples
    --------
    >>> gravity(math.pi / 2, 2.0)
    0.5
    """
    return math.sin(t) - 1.0 / Gamma


def gravity_zeros(t_a, t_b, Gamma):
    r"""Sorted zeros of :math:`g(t) = \sin t - 1/\Gamma` in the open interval ``(t_a, t_b)``.

    Examples
    --------
    >>> [round(z, 12) for z in gravity_zeros(0.0, 2 * math.pi, 2.0)]      # pi/6, 5 pi/6
    [0.523598775598, 2.617993877991]
    """
    if Gamma < 1.0:
        return []
    base = math.asin(1.0 / Gamma)
    out = []
    k = math.floor((t_a - math.pi) / _TWO_PI) - 1
    while base + _TWO_PI * k <= t_b + _TWO_PI:
        for z in (base + _TWO_PI * k, math.pi - base + _TWO_PI * k):
            if t_a < z < t_b:
                out.append(z)
        k += 1
    return sorted(out)


def liftoff_index(t, Gamma):
    r"""Smallest integer k with :math:`\arcsin(1/\Gamma) + 2\pi k \ge t` (the next lift-off phase).

    Examples
    --------
    >>> liftoff_index(0.0, 2.0), liftoff_index(1.0, 2.0)
    (0, 1)
    """
    base = math.asin(1.0 / Gamma)
    k = math.ceil((t - base) / _TWO_PI)
    while base + _TWO_PI * (k - 1) >= t:
        k -= 1
    while base + _TWO_PI * k < t:
        k += 1
    return k


def next_liftoff(t, Gamma):
    """First time >= ``t`` at which :math:`g` turns positive (a lift-off from rest), None if Gamma <= 1.

    Examples
    --------
    >>> round(next_liftoff(1.0, 2.0), 12)        # pi/6 + 2 pi
    6.806784082778
    """
    if Gamma <= 1.0:
        return None
    return math.asin(1.0 / Gamma) + _TWO_PI * liftoff_index(t, Gamma)


def bracket_root(f, a, b):
    """The root of a monotone ``f`` with a sign change on [a, b], to relative precision.

    The bracket is first shrunk geometrically towards ``a`` (a binary search over
    :math:`a + (b - a)2^{-j}`), so a root many decades smaller than :math:`b - a` (a chatter
    flight) is found as precisely as a large one; then ``brentq`` (relative tolerance 4 eps).

    Examples
    --------
    >>> bracket_root(lambda x: x - 1e-13, 0.0, 1.0) == 1e-13
    True
    """
    fa = f(a)
    L = b - a
    lo, hi = 0, 1100                   # sign(f(x(lo))) == sign(f(b)), sign(f(x(hi))) == sign(f(a))
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if (f(a + math.ldexp(L, -mid)) > 0.0) == (fa > 0.0):
            hi = mid
        else:
            lo = mid
    left, right = a + math.ldexp(L, -hi), a + math.ldexp(L, -lo)
    if left == right:
        return right
    return brentq(f, left, right, xtol=1e-300, rtol=_RTOL, maxiter=500)


class Flight:
    r"""Free flight of one node launched at ``t_a`` with velocity ``w_a`` and height ``z_a`` (module docstring).

    Parameters
    ----------
    t_a, w_a : float
        Launch time and velocity.
    Gamma : float
        Plate acceleration, > 0.
    z_a : float, optional
        Launch height (default 0: from the plate).

    All methods take the local time :math:`d = t - t_a`.

    Examples
    --------
    A launch from rest at the lift-off phase :math:`\sin t_a = 1/\Gamma` (the e = 0 flat layer)
    lands once, at the touch-and-go of the sticking orbit:

    >>> G = 4.1
    >>> fl = Flight(math.asin(1 / G), 0.0, G)
    >>> d = fl.first_landing(4 * math.pi)
    >>> round(d, 12), abs(fl.z(d)) < 1e-15, fl.w(d) < 0
    (7.188565375314, True, True)
    """

    __slots__ = ("t_a", "w_a", "z_a", "Gamma", "inv_G", "s", "c")

    def __init__(self, t_a, w_a, Gamma, z_a=0.0):
        self.t_a, self.w_a, self.z_a, self.Gamma = t_a, w_a, z_a, Gamma
        self.inv_G = 1.0 / Gamma
        self.s, self.c = math.sin(t_a), math.cos(t_a)

    def w(self, d):
        """Velocity after the local time ``d``."""
        return self.w_a + self.s * math.sin(d) + self.c * one_minus_cos(d) - d * self.inv_G

    def z(self, d):
        """Height after the local time ``d``."""
        return (self.z_a + self.w_a * d + self.s * one_minus_cos(d) - self.c * sin_minus_x(d)
                - 0.5 * d * d * self.inv_G)

    def g(self, d):
        """Acceleration :math:`g(t_a + d)`."""
        return self.s * math.cos(d) + self.c * math.sin(d) - self.inv_G

    def monotone_pieces(self, H):
        r"""Cut [0, H] into pieces on which the height is monotone (at the zeros of g, then of w).

        Examples
        --------
        >>> len(Flight(0.0, 1.0, 2.0).monotone_pieces(2 * math.pi))      # 2 zeros of g, 1 of w
        4
        """
        breaks = [0.0] + [z - self.t_a for z in gravity_zeros(self.t_a, self.t_a + H, self.Gamma)] + [H]
        pieces = []
        for p, q in zip(breaks[:-1], breaks[1:]):
            if not q > p:
                continue
            wp, wq = self.w(p), self.w(q)
            if wp * wq < 0.0:
                c = bracket_root(self.w, p, q)
                pieces.extend([(p, c), (c, q)])
            else:
                pieces.append((p, q))
        return pieces

    def first_landing(self, H):
        r"""Local time in (0, H] of the first return to the plate (:math:`\zeta = 0`), or None.

        See the module docstring for the rules (a start at :math:`\zeta \le 0` is not a landing).

        Examples
        --------
        >>> Flight(0.0, 1.0, 2.0).first_landing(0.5) is None
        True
        """
        za = self.z_a
        for i, (p, q) in enumerate(self.monotone_pieces(H)):
            if i > 0 and za == 0.0:
                return p
            zq = self.z(q)
            if za > 0.0 and zq <= 0.0:
                return q if zq == 0.0 else self._polish(bracket_root(self.z, p, q), p, q)
            za = zq
        return None

    def _polish(self, d, lo, hi):
        """A few safeguarded Newton steps on the bracketed simple root ``d`` of the height."""
        for _ in range(3):
            slope = self.w(d)
            if slope == 0.0:
                break
            new = d - self.z(d) / slope
            if not lo <= new <= hi or new == d:
                break
            d = new
        return d
