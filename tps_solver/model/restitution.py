r"""Restitution laws: the coefficient of restitution as a function of the impact speed.

The paper treats the restitution e of (11) as a constant and tunes it to the forcing through
(19); its conclusion asks for a restitution that depends on the impact velocity, so that the
flat layer tunes itself.  A *restitution law* maps the impact speed :math:`v = -w^- > 0`
(plate frame, units of :math:`A\omega`) to :math:`e(v) \in [0, 1]`; the rebound velocity is

.. math::
    w^+ = \phi(v) = e(v)\,v, \qquad \phi'(v) = e(v) + v\,e'(v),

and :math:`\phi'` is what enters every Jacobian and multiplier in place of the constant e (the
linearised impact map: :math:`\delta w^+ = -\phi'(v)\,\delta w^-`).

Laws
----
* :class:`ConstantRestitution` -- today's constant e; a float passed wherever a law is accepted
  is this law, and every code path treats it exactly as the float (bit for bit).
* :class:`ViscoelasticRestitution` -- viscoelastic Hertz spheres (Brilliantov, Spahn, Hertzsch &
  Pöschel; Ramírez, Pöschel, Brilliantov & Schwager, Phys. Rev. E 60, 4465, 1999): the
  collision obeys :math:`\ddot\xi + \rho\,\xi^{3/2} + \tfrac32 A\rho\,\xi^{1/2}\dot\xi = 0`,
  whose dimension analysis makes e a function of :math:`\kappa = \tfrac32 A \rho^{2/5}
  v^{1/5}` alone; here :math:`\kappa = b\,v^{1/5}` with the one material constant ``b`` in plate
  units.  :math:`e(\kappa)` is computed from the scaled collision
  :math:`x'' = -x^{3/2} - \kappa x^{1/2} x'`, :math:`x(0) = 0`, :math:`x'(0) = 1`, ended where
  the contact force vanishes (:math:`x + \kappa x' = 0`), and tabulated once per process by a
  Chebyshev interpolant in :math:`\sqrt\kappa` (error about 1e-12 for :math:`\kappa \le 25`;
  larger :math:`\kappa` integrate the collision directly).  Its expansion is
  :math:`e = 1 - C_1\kappa + \tfrac35 C_1^2\kappa^2 + O(\kappa^{5/2})` with
  :math:`C_1 = \tfrac45(\tfrac54)^{3/5} B(\tfrac35, \tfrac32) = 1.15344\ldots`, Ramírez et al.'s
  first coefficient (the tests check both).
* :class:`PowerLawRestitution` -- the law with a floor that Bizon et al. used (Phys. Rev. Lett.
  80, 57, 1998): :math:`e = 1 - (1 - e_0)(v/v_0)^{3/4}` for :math:`v < v_0`, :math:`e_0` above.
* :class:`CallableRestitution` -- a user's function (and optionally its derivative).

Every evaluation is checked: a law that gives a non-finite e or one outside [0, 1] raises
``ValueError`` naming the law and the speed.

Examples
--------
>>> law = ViscoelasticRestitution.from_reference(e=0.45, v=5.0)
>>> round(float(law(5.0)), 12)
0.45
>>> bool(law(1.0) > law(5.0) > law(10.0))        # slower impacts are more elastic
True
>>> as_restitution(0.45)
ConstantRestitution(e=0.45)
"""
import math
import numbers

import numpy as np

from tps_solver.core import archive
from tps_solver.core.checks import check_in_range, check_int, check_positive, check_real
from tps_solver.core.costs import check_cost

__all__ = ["RestitutionLaw", "ConstantRestitution", "ViscoelasticRestitution", "PowerLawRestitution",
           "CallableRestitution", "ThicknessRestitution", "as_restitution", "viscoelastic_restitution", "viscoelastic_c1"]


class RestitutionLaw:
    """Base class: :math:`e(v)` for impact speeds :math:`v \\ge 0` (module docstring).

    Subclasses implement ``_e(v)`` and ``_de(v)`` on float arrays and set ``parameters``;
    :meth:`__call__` and :meth:`derivative` validate.

    Attributes
    ----------
    constant : bool
        True only for :class:`ConstantRestitution`.
    parameters : dict
        The law's parameters by name (what :meth:`at` changes, e.g. in continuation).

    Examples
    --------
    >>> law = PowerLawRestitution(e0=0.45, v0=4.0)
    >>> float(law(4.0)), float(law(0.0)), float(law.rebound(8.0))
    (0.45, 1.0, 3.6)
    """
    constant = False

    def __call__(self, v):
        """e(v) (float for a scalar ``v``, else an array of ``v``'s shape); checked in [0, 1]."""
        v, scalar = _speeds(v)
        e = np.asarray(self._e(v), dtype=float)
        if e.shape != v.shape:
            e = np.broadcast_to(e, v.shape).copy()
        bad = ~(np.isfinite(e) & (e >= 0.0) & (e <= 1.0))
        if np.any(bad):
            i = int(np.flatnonzero(bad.ravel())[0])
            raise ValueError(f"{self!r} gave e = {e.ravel()[i]!r} at impact speed v = {v.ravel()[i]!r}: a "
                             "restitution law must give a finite e in [0, 1]")
        return float(e) if scalar else e

    def derivative(self, v):
        """de/dv at impact speed ``v`` (> 0), same shape rules as :meth:`__call__`."""
        v, scalar = _speeds(v)
        d = np.asarray(self._de(v), dtype=float)
        if d.shape != v.shape:
            d = np.broadcast_to(d, v.shape).copy()
        if not np.all(np.isfinite(d)):
            i = int(np.flatnonzero(~np.isfinite(d).ravel())[0])
            raise ValueError(f"{self!r} has a non-finite derivative de/dv = {d.ravel()[i]!r} at impact speed "
                             f"v = {v.ravel()[i]!r}")
        return float(d) if scalar else d

    def rebound(self, v):
        """The rebound speed :math:`\\phi(v) = e(v)\\,v`."""
        return self(v) * (v if np.isscalar(v) else np.asarray(v, dtype=float))

    def rebound_derivative(self, v):
        """:math:`\\phi'(v) = e(v) + v\\,e'(v)`: the factor of the linearised impact map."""
        vv = v if np.isscalar(v) else np.asarray(v, dtype=float)
        return self(v) + vv * self.derivative(v)

    def low_speed_asymptote(self):
        r"""``(c, p)`` with :math:`1 - e(v) \sim c\,v^p` as :math:`v \to 0`, or None if :math:`e(0) < 1`.

        What :meth:`chatter_tail` needs to sum a chatter sequence whose restitution tends to 1."""
        e0 = self(0.0)
        if e0 < 1.0:
            return None
        raise ValueError(f"{self!r} has e(0) = 1 but no low-speed asymptote; give one (CallableRestitution's "
                         "low_speed=(c, p)) to sum chatter tails")

    def chatter_tail(self, v, gamma, max_impacts=200000):
        r"""Duration and impact count of a chatter sequence at constant gravity ``gamma``.

        A bounce launched at speed :math:`u` under constant :math:`|g| = \gamma` lasts
        :math:`2u/\gamma` and lands at speed :math:`u`, so the launch speeds follow
        :math:`u_{j+1} = \phi(u_j)` and the sequence accumulates after
        :math:`D = (2/\gamma)\sum_j u_j`.  A constant law (or one with :math:`e(0) < 1` and
        ``e(v) <= e(0)``) is summed geometrically once the ratio is within 1e-3 of its limit;
        a law with :math:`e \to 1` is iterated until :math:`u_j < 10^{-15}` (``ValueError`` if
        that takes more than ``max_impacts``: laws with p near 1 chatter for a long time) and the rest is
        the asymptotic sum :math:`\sum_{i \ge j} u_i \approx u_j^{1-p}/(c(1-p)) + u_j/2`
        (from :math:`du/dj = -c\,u^{1+p}`, :meth:`low_speed_asymptote`; its relative error is
        :math:`O(u_j^p)`, far below 1e-15 of :math:`D` here).

        Parameters
        ----------
        v : float
            Launch speed of the first bounce, >= 0.
        gamma : float
            :math:`|g| > 0` during the sequence.
        max_impacts : int, optional

        Returns
        -------
        duration : float
        impacts : float
            The impacts iterated, plus the asymptotic count of the rest (inf for a law
            with e -> 1: the sequence has infinitely many impacts in a finite time).

        Examples
        --------
        >>> d, n = ConstantRestitution(0.5).chatter_tail(1.0, 2.0)     # 2 v / (gamma (1 - e))
        >>> round(d, 12), n
        (2.0, inf)
        >>> d, n = ViscoelasticRestitution(0.6).chatter_tail(1e-6, 1.0)
        >>> c, p = ViscoelasticRestitution(0.6).low_speed_asymptote()
        >>> bool(abs(d / (2 * (1e-6 ** (1 - p) / (c * (1 - p)))) - 1) < 0.05), n     # the asymptote
        (True, inf)
        """
        v = float(v)
        gamma = check_positive(gamma, "gamma")
        max_impacts = check_int(max_impacts, "max_impacts", minimum=1)
        check_cost(f"{type(self).__name__}.chatter_tail", "max_impacts", max_impacts, 1e6,
                   _IMPACT_SECONDS * max_impacts, hint="the sequence is iterated impact by impact up to this bound")
        if not (math.isfinite(v) and v >= 0.0):
            raise ValueError(f"v must be a finite number >= 0, got {v!r}")
        if v == 0.0:
            return 0.0, 0.0
        asym = self.low_speed_asymptote()
        total, u = 0.0, v
        for j in range(int(max_impacts)):
            total += u
            u_next = self.rebound(u)
            if u_next <= 0.0:
                return 2.0 * total / gamma, float(j + 1)
            if asym is None:
                ratio = u_next / u
                e_lim = self(0.0)
                if abs(ratio - e_lim) <= 1e-3 * max(e_lim, 1e-300) and ratio < 1.0:
                    # the rest is geometric to within the ratio's drift (the law is flat near 0)
                    return 2.0 * (total + u_next / (1.0 - ratio)) / gamma, math.inf
            elif u_next < 1e-15:
                c, p = asym
                return 2.0 * (total + u_next ** (1.0 - p) / (c * (1.0 - p)) + 0.5 * u_next) / gamma, math.inf
            u = u_next
        raise ValueError(f"the chatter sequence of {self!r} from v = {v} has not accumulated after {max_impacts} "
                         f"impacts (speed still {u:.3g})")

    def at(self, **parameters):
        """A copy with some parameters changed (names of :attr:`parameters`)."""
        unknown = set(parameters) - set(self.parameters)
        if unknown:
            raise ValueError(f"parameter {sorted(unknown)[0]!r} is not a parameter of {type(self).__name__} "
                             f"(it has {sorted(self.parameters)})")
        return type(self)(**{**self.parameters, **parameters})

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.parameters.items())
        return f"{type(self).__name__}({args})"

    def __eq__(self, other):
        return type(self) is type(other) and self.parameters == other.parameters

    def __hash__(self):
        return hash((type(self).__name__, tuple(sorted(self.parameters.items()))))


#: Lower bound of the time of one iterated impact of a chatter sequence (measured 1.1e-4 s for the
#: power law, 4.4e-4 s for the viscoelastic law, divided by ten).
_IMPACT_SECONDS = 1.0e-5


def _speeds(v):
    scalar = np.ndim(v) == 0
    a = np.asarray(v, dtype=float)
    if not np.all(np.isfinite(a)) or np.any(a < 0.0):
        raise ValueError(f"v (impact speed) must be finite and >= 0, got {v!r}")
    return a, scalar


class ConstantRestitution(RestitutionLaw):
    """The constant restitution of the paper, (11): :math:`e(v) = e`.

    Parameters
    ----------
    e : float
        In [0, 1).

    Examples
    --------
    >>> law = ConstantRestitution(0.45)
    >>> law(3.0), law.derivative(3.0), law.e
    (0.45, 0.0, 0.45)
    """
    constant = True

    def __init__(self, e):
        self.e = check_in_range(e, "e", 0.0, 1.0, low_closed=True, high_closed=False)
        self.parameters = {"e": self.e}

    def _e(self, v):
        return np.full(v.shape, self.e)

    def _de(self, v):
        return np.zeros(v.shape)


class PowerLawRestitution(RestitutionLaw):
    r"""Bizon et al.'s law with a floor: :math:`e = 1 - (1-e_0)(v/v_0)^{3/4}` below :math:`v_0`,
    :math:`e_0` above.

    Parameters
    ----------
    e0 : float
        The floor, in [0, 1).
    v0 : float
        The speed (plate units) at which the floor is reached, > 0.

    Examples
    --------
    >>> law = PowerLawRestitution(e0=0.45, v0=4.0)
    >>> round(law(1.0), 12), law(9.0)
    (0.805545635174, 0.45)
    """

    def __init__(self, e0, v0):
        self.e0 = check_in_range(e0, "e0", 0.0, 1.0, low_closed=True, high_closed=False)
        self.v0 = check_positive(v0, "v0")
        self.parameters = {"e0": self.e0, "v0": self.v0}

    def low_speed_asymptote(self):
        """:math:`1 - e = (1 - e_0)(v/v_0)^{3/4}` below :math:`v_0`."""
        return (1.0 - self.e0) / self.v0 ** 0.75, 0.75

    def _e(self, v):
        r = np.minimum(v / self.v0, 1.0)
        return np.where(v < self.v0, 1.0 - (1.0 - self.e0) * r ** 0.75, self.e0)

    def _de(self, v):
        with np.errstate(divide="ignore"):
            d = -0.75 * (1.0 - self.e0) / self.v0 * np.minimum(v / self.v0, 1.0) ** -0.25
        return np.where(v < self.v0, d, 0.0)


# ------------------------------------------------------------------ the viscoelastic collision
_C1 = None
_TABLE = {}
_KAPPA_TABLE = 25.0          # the Chebyshev table covers kappa in [0, 25], i.e. sqrt(kappa) in [0, 5]
# The collision is integrated up to this dissipation (e = 1.1e-10 there, 26 ms); beyond it the
# explicit integration does not reach the end of the contact within its span.
_KAPPA_MAX = 1.0e6
_TABLE_DEGREE = 60


def viscoelastic_restitution(kappa, rtol=1e-13):
    r"""e of one viscoelastic Hertz collision with dissipation :math:`\kappa \ge 0`, by integration.

    Integrates :math:`x'' = -x^{3/2} - \kappa x^{1/2} x'` from :math:`x = 0`, :math:`x' = 1`
    (started at :math:`s_0 = 10^{-4}` on its series
    :math:`x = s - \tfrac{4\kappa}{15}s^{5/2} - \tfrac{4}{35}s^{7/2}`) with ``DOP853`` until the
    contact force vanishes (:math:`x + \kappa x' = 0`); returns :math:`-x'` there.  Accuracy
    about 1e-12 (the start's truncation and ``rtol``).

    Parameters
    ----------
    kappa : float
    rtol : float, optional

    Returns
    -------
    e : float

    Examples
    --------
    >>> e = viscoelastic_restitution(1e-3)
    >>> bool(abs((1 - e) / 1e-3 - 1.15344) < 1e-3)
    True
    """
    from scipy.integrate import solve_ivp

    k = float(kappa)
    if not (math.isfinite(k) and 0.0 <= k <= _KAPPA_MAX):
        raise ValueError(f"kappa must be a finite number in [0, {_KAPPA_MAX:g}] (e < 1.1e-10 at the upper end: "
                         f"an inelastic collision, e = 0), got {kappa!r}")
    if k == 0.0:
        return 1.0
    s0 = 1e-4
    y0 = [s0 - 4.0 * k / 15.0 * s0 ** 2.5 - 4.0 / 35.0 * s0 ** 3.5, 1.0 - 2.0 * k / 3.0 * s0 ** 1.5 - 0.4 * s0 ** 2.5]

    def rhs(s, y):
        r = math.sqrt(max(y[0], 0.0))
        return [y[1], -y[0] * r - k * r * y[1]]

    def force_zero(s, y):
        return y[0] + k * y[1]

    force_zero.terminal, force_zero.direction = True, -1
    span = 10.0 + 20.0 * k
    sol = solve_ivp(rhs, (s0, span), y0, method="DOP853", rtol=rtol, atol=1e-16, events=force_zero)
    if sol.status != 1:
        raise RuntimeError(f"the viscoelastic collision with kappa = {k} did not end within s = {span}")
    return float(min(max(-sol.y_events[0][0][1], 0.0), 1.0))


def _table():
    """The Chebyshev interpolant of e in q = sqrt(kappa) on [0, 5] (built once per process, ~0.6 s)."""
    if "e" not in _TABLE:
        from numpy.polynomial import Chebyshev
        q_max = math.sqrt(_KAPPA_TABLE)
        cheb = Chebyshev.interpolate(lambda q: np.array([viscoelastic_restitution(x * x) for x in q]),
                                     _TABLE_DEGREE, domain=[0.0, q_max])
        _TABLE["e"], _TABLE["de"] = cheb, cheb.deriv()
    return _TABLE["e"], _TABLE["de"]


def viscoelastic_c1():
    r""":math:`C_1 = \tfrac45 (\tfrac54)^{3/5} B(\tfrac35, \tfrac32)`, the first coefficient of
    :math:`1 - e(\kappa)` (first-order energy loss along the elastic Hertz collision).

    Examples
    --------
    >>> round(viscoelastic_c1(), 5)
    1.15345
    """
    from scipy.special import beta
    return 0.8 * 1.25 ** 0.6 * float(beta(0.6, 1.5))


class ViscoelasticRestitution(RestitutionLaw):
    r"""Viscoelastic Hertz spheres (module docstring): :math:`e = e_{ve}(\kappa)`, :math:`\kappa = b\,v^{1/5}`.

    Parameters
    ----------
    b : float
        The dissipation constant :math:`\tfrac32 A\rho^{2/5}(A\omega)^{1/5}` in plate units, > 0.

    Examples
    --------
    >>> law = ViscoelasticRestitution(b=0.5)
    >>> round(law(1.0), 6), round(law(32.0), 6)         # kappa = 0.5 and 1.0
    (0.595252, 0.393931)
    """

    def __init__(self, b):
        self.b = check_in_range(b, "b", 0.0, _KAPPA_MAX, low_closed=False)
        self.parameters = {"b": self.b}

    @classmethod
    def from_reference(cls, e, v):
        """The law with :math:`e(v) = e` at the reference impact speed ``v``.

        Parameters
        ----------
        e : float
            In (0, 1).
        v : float
            > 0 (plate units).

        Examples
        --------
        >>> law = ViscoelasticRestitution.from_reference(0.6, 2.0)
        >>> round(law(2.0), 12)
        0.6
        """
        from scipy.optimize import brentq
        e = check_in_range(e, "e", 0.0, 1.0, low_closed=False, high_closed=False)
        v = check_positive(v, "v")
        if e < float(_kappa_e(_KAPPA_TABLE)):
            raise ValueError(f"e must be >= {float(_kappa_e(_KAPPA_TABLE)):.4g} for from_reference (the table "
                             f"covers kappa <= {_KAPPA_TABLE:g}), got {e}")
        kappa = brentq(lambda k: float(_kappa_e(k)) - e, 0.0, _KAPPA_TABLE, xtol=1e-15, rtol=1e-15)
        return cls(kappa / v ** 0.2)

    def low_speed_asymptote(self):
        """:math:`1 - e \\sim C_1 b\\,v^{1/5}` (:func:`viscoelastic_c1`)."""
        return viscoelastic_c1() * self.b, 0.2

    def kappa(self, v):
        """:math:`\\kappa = b\\,v^{1/5}`; ``ValueError`` beyond the integrated range (kappa <= 1e6)."""
        k = self.b * np.asarray(v, dtype=float) ** 0.2
        if np.any(k > _KAPPA_MAX):
            v_max = (_KAPPA_MAX / self.b) ** 5
            raise ValueError(f"v (impact speed) must be <= {v_max:.6g} for {self!r} (kappa = b v^(1/5) <= "
                             f"{_KAPPA_MAX:g}, where e < 1.1e-10), got {float(np.max(v))!r}")
        return k

    def _e(self, v):
        return _kappa_e(self.kappa(v))

    def _de(self, v):
        k = self.kappa(v)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = _kappa_de(k) * k / (5.0 * v)
        return np.where(v > 0.0, d, -np.inf)


def _kappa_e(k):
    k = np.asarray(k, dtype=float)
    cheb, _ = _table()
    inside = k <= _KAPPA_TABLE
    out = np.empty(k.shape)
    out[inside] = cheb(np.sqrt(k[inside]))
    for i in np.flatnonzero(~inside.ravel()):
        out.flat[i] = viscoelastic_restitution(float(k.flat[i]))
    return np.clip(out, 0.0, 1.0)


def _kappa_de(k):
    """de/dkappa = (de/dq) / (2 q); at kappa = 0 the limit -C1."""
    k = np.asarray(k, dtype=float)
    _, dcheb = _table()
    out = np.empty(k.shape)
    inside = k <= _KAPPA_TABLE
    q = np.sqrt(k[inside])
    with np.errstate(divide="ignore", invalid="ignore"):
        out[inside] = np.where(q > 0.0, dcheb(q) / (2.0 * q), -viscoelastic_c1())
    for i in np.flatnonzero(~inside.ravel()):
        kk = float(k.flat[i])
        h = 1e-5 * kk
        out.flat[i] = (viscoelastic_restitution(kk + h) - viscoelastic_restitution(kk - h)) / (2.0 * h)
    return out


class CallableRestitution(RestitutionLaw):
    r"""A user's law: ``func(v) -> e`` and optionally ``derivative(v) -> de/dv``.

    Without ``derivative``, de/dv is a central difference with step ``1e-6 * max(v, 1)`` (error
    about 1e-10 relative for smooth laws): pass the derivative where multipliers matter.

    Parameters
    ----------
    func : callable
        Vectorised or scalar function of the impact speed (float or float array).
    derivative : callable or None, optional
    name : str, optional
        Shown in ``repr`` and messages.
    low_speed : (float, float), optional
        ``(c, p)`` with :math:`1 - e(v) \sim c\,v^p` at small speeds, for laws with
        :math:`e(0) = 1` whose chatter tails are summed (:meth:`chatter_tail`).

    Examples
    --------
    >>> law = CallableRestitution(lambda v: 0.9 / (1 + 0.1 * v), lambda v: -0.09 / (1 + 0.1 * v) ** 2)
    >>> law(10.0), law.derivative(10.0)
    (0.45, -0.0225)
    """

    def __init__(self, func, derivative=None, name=None, low_speed=None):
        if low_speed is not None:
            c, p = (float(x) for x in low_speed)
            if not (c > 0.0 and 0.0 < p < 1.0):
                raise ValueError(f"low_speed must be (c, p) with c > 0 and 0 < p < 1 (1 - e ~ c v^p), got {low_speed!r}")
            low_speed = (c, p)
        self.low_speed = low_speed
        if not callable(func):
            raise ValueError(f"func must be callable (v -> e), got {type(func).__name__}")
        if derivative is not None and not callable(derivative):
            raise ValueError(f"derivative must be callable (v -> de/dv) or None, got {type(derivative).__name__}")
        self.func, self.dfunc = func, derivative
        self.name = str(name) if name is not None else getattr(func, "__name__", "func")
        self.parameters = {}

    def _apply(self, f, v):
        try:
            out = np.asarray(f(v), dtype=float)
            if out.shape == v.shape:
                return out
        except (TypeError, ValueError):
            pass
        return np.array([float(f(float(x))) for x in v.ravel()]).reshape(v.shape)

    def low_speed_asymptote(self):
        if self.low_speed is not None:
            return self.low_speed
        return super().low_speed_asymptote()

    def _e(self, v):
        return self._apply(self.func, v)

    def _de(self, v):
        if self.dfunc is not None:
            return self._apply(self.dfunc, v)
        h = 1e-6 * np.maximum(v, 1.0)
        lo = np.maximum(v - h, 0.0)
        return (self._e(v + h) - self._e(lo)) / (v + h - lo)

    def at(self, **parameters):
        raise ValueError("a CallableRestitution has no parameters to change; build a new law")

    def __repr__(self):
        return f"CallableRestitution({self.name})"

    def __eq__(self, other):
        return self is other

    def __hash__(self):
        return id(self)


class ThicknessRestitution:
    r"""A restitution that also depends on the layer thickness: :math:`e(v, h) = e_v(v)\,
    \min(1, 2/(1 + (h/h_e)^q))`.

    It equals the speed law :math:`e_v` at the reference thickness :math:`h_e` and tends to 0
    for deep layers, as the paper proposes after (11) (e -> 0 for h/d -> infinity: deep layers
    adhere to the plate).  Used by the thickness model
    (:func:`tps_solver.solvers.thickness.simulate_thickness`); elsewhere the thickness is
    uniform and a speed law is what is needed.

    Parameters
    ----------
    law : float or RestitutionLaw
        The speed law :math:`e_v`.
    h_e : float
        The reference thickness (plate amplitudes), > 0.
    q : float, optional
        The decay exponent, > 0 (default 2).

    Examples
    --------
    >>> law = ThicknessRestitution(0.45, h_e=2.0)
    >>> law(3.0, 2.0), round(law(3.0, 6.0), 6), law(3.0, 0.5)
    (0.45, 0.09, 0.45)
    """

    def __init__(self, law, h_e, q=2.0):
        self.law = as_restitution(law, "law")
        self.h_e = check_positive(h_e, "h_e")
        self.q = check_positive(q, "q")

    def __call__(self, v, h):
        """e at impact speeds ``v`` and thicknesses ``h`` (broadcast; float for scalars)."""
        hh = np.asarray(h, dtype=float)
        if not np.all(np.isfinite(hh)) or np.any(hh <= 0):
            raise ValueError(f"h must be finite and > 0 for {self!r}, got {h!r}")
        with np.errstate(over="ignore"):     # (h/h_e)**q overflows to inf for deep layers: e -> 0, its limit
            factor = np.minimum(1.0, 2.0 / (1.0 + (hh / self.h_e) ** self.q))
        out = self.law(v) * factor
        return float(out) if np.ndim(out) == 0 else out

    def __repr__(self):
        return f"ThicknessRestitution({self.law!r}, h_e={self.h_e!r}, q={self.q!r})"


def as_restitution(e, name="e"):
    """A :class:`RestitutionLaw` from a law or a float (a :class:`ConstantRestitution`).

    Parameters
    ----------
    e : float or RestitutionLaw
    name : str, optional
        The parameter's name in error messages.

    Examples
    --------
    >>> as_restitution(0.0).e
    0.0
    >>> as_restitution("x")
    Traceback (most recent call last):
    ...
    ValueError: e must be a float in [0, 1) or a RestitutionLaw, got 'x'
    """
    if isinstance(e, RestitutionLaw):
        return e
    if isinstance(e, numbers.Real) and not isinstance(e, bool) or (isinstance(e, np.ndarray) and e.ndim == 0):
        check_real(e, name)
        return ConstantRestitution(check_in_range(e, name, 0.0, 1.0, low_closed=True, high_closed=False))
    raise ValueError(f"{name} must be a float in [0, 1) or a RestitutionLaw, got {e!r}")


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
for _cls in (ConstantRestitution, ViscoelasticRestitution, PowerLawRestitution):
    archive.register(_cls.__name__, _cls, encode=lambda law: dict(law.parameters),
                     decode=lambda d, cls=_cls: cls(**d))
