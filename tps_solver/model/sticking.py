r"""Periodic orbits of one flat-layer node with sticking, touch-and-go and chatter.

The flat layer of :mod:`tps_solver.model.flat` is a single node (a bouncing ball) in
the plate frame: in flight :math:`\dot w = g(t) = \sin t - 1/\Gamma` (16) and
:math:`\dot\zeta = w`; at a contact :math:`\zeta = 0`, :math:`w^- < 0` the
restitution law (11) gives :math:`w^+ = -e w^-`.  When :math:`w^+ = 0` (always
for :math:`e = 0`, and at the end of a chatter sequence for :math:`e > 0`) the
node

* **sticks** (:math:`w = \zeta = 0`) if :math:`g \le 0` at that instant, and
  lifts off when :math:`g` turns positive, at :math:`\sin t = 1/\Gamma` with
  :math:`\cos t > 0` (Sec. 4, after (37): :math:`g \to H(\zeta) g`);
* **touches and goes** if :math:`g > 0` at the landing instant: a new flight
  starts there from rest.

Flights are in closed form, written in the local time :math:`\tau = t - a`
since the launch at :math:`a` with velocity :math:`v`,

.. math::
    w &= v + 2\cos a\,\sin^2(\tau/2) + \sin a\,\sin\tau - \tau/\Gamma, \\
    \zeta &= v\tau + 2\sin a\,\sin^2(\tau/2) - \cos a\,(\sin\tau - \tau) - \tau^2/(2\Gamma),

which is the first form of (17)-(18) rearranged so that every term keeps
its relative accuracy for short flights.  Flights and their landings are
:class:`tps_solver.model.flight.Flight` (the certified landing search: cut at the
zeros of :math:`g` and :math:`w`, a root per monotone piece, relative accuracy a
few eps, tested against mpmath).

**Chatter** (:math:`0 < e < 1`).  After an impact at :math:`t_c` with
rebound velocity :math:`v` and :math:`g_c = g(t_c) < 0` the bounces shrink
geometrically.  Bounces are integrated exactly until the remaining sequence
is provably short; it is then summed in closed form at constant
:math:`g = g_c`: bounce :math:`k` starts with :math:`v e^k`, lasts
:math:`2 v e^k/|g_c|`, and the sequence accumulates at
:math:`t_\infty = t_c + \Delta_0`, :math:`\Delta_0 = 2v/(|g_c|(1 - e))`.
Error bound (uses only :math:`|g'| = |\cos t| \le 1`): on a window of length
:math:`L` one has :math:`\gamma_- \le |g| \le \gamma_+`,
:math:`\gamma_\pm = |g_c| \pm L`, :math:`\rho = \gamma_+/\gamma_-`.  A bounce
launched with speed :math:`u` then lands within
:math:`[2u/\gamma_+, 2u/\gamma_-]` with a speed in
:math:`[u(2/\rho - 1), u(2\rho - 1)]`, so the true accumulation time lies in
:math:`[t_c + \Delta_-, t_c + \Delta_+]` with
:math:`\Delta_+ = 2v/(\gamma_-(1 - e(2\rho - 1)))` and
:math:`\Delta_- = 2v/(\gamma_+(1 - e\max(0, 2/\rho - 1)))`, provided
:math:`\Delta_+ \le L` (we take :math:`L = 2\Delta_0`).  The tail is summed
once :math:`\max(\Delta_+ - \Delta_0, \Delta_0 - \Delta_-)` is below
``tail_tol`` (default 1e-14).  The sticking state and the next lift-off do
not depend on :math:`t_\infty` at all, so the orbit after the stick is exact;
inside the tail :math:`|w| \le v` and the tail adds at most
:math:`2v^2/(|g_c|(1 - e^2))/T` to any Fourier coefficient of :math:`w`.

Because lift-off always happens at the same phase from the same state, a
sticking orbit is the unique trajectory through a lift-off; its period is a
whole number of forcing periods, and its period map is locally constant (both
multipliers 0).  Orbits without a stick and with :math:`e = 0` consist of
touch-and-go contacts only; they are roots of a one-dimensional landing map
and have one multiplier :math:`\prod_i \Delta_i g(t_{i-1})/w(t_i^-)` (and 0).
"""
import math

import numpy as np
from scipy.optimize import brentq

from tps_solver.core import archive
from tps_solver.model.flight import Flight, gravity, liftoff_index
from tps_solver.model.restitution import RestitutionLaw

__all__ = ["ContactOrbit", "sticking_orbit", "touch_orbits", "trace"]

_TWO_PI = 2.0 * math.pi
_RTOL = 4.0 * np.finfo(float).eps
_MAX_IMPACTS = 20000


def _tail(v, gam, e, tail_tol):
    """Closed-form chatter tail at constant |g| = gam: (Delta0, error bound) or None if not yet short."""
    D0 = 2.0 * v / (gam * (1.0 - e))
    L = 2.0 * D0
    gm, gp = gam - L, gam + L
    if gm <= 0.0:
        return None
    rho = gp / gm
    q = e * (2.0 * rho - 1.0)
    if q >= 1.0:
        return None
    Dp = 2.0 * v / (gm * (1.0 - q))
    if Dp > L:
        return None
    Dm = 2.0 * v / (gp * (1.0 - e * max(0.0, 2.0 / rho - 1.0)))
    err = max(Dp - D0, D0 - Dm)
    if err > tail_tol:
        return None
    return D0, err


def _law_tail(v, gam, law, tail_tol):
    """A speed-dependent law's chatter tail at constant |g| = gam: (D, error estimate) or None if not short.

    The tail is :meth:`RestitutionLaw.chatter_tail`; over its duration D the gravity changes by
    at most D (|g'| <= 1), which changes each flight by a relative D/gam and each landing speed by
    a relative (2/3) u/gam^2 (second order in the flight), so the accumulation time moves by
    about 2 D^2/gam: an estimate to first order, not a bound.  A law with e -> 1 is summed only
    once its asymptotic estimate of D is that short."""
    asym = law.low_speed_asymptote()
    if asym is not None:
        c, p = asym
        d_est = 2.0 * (v ** (1.0 - p) / (c * (1.0 - p)) + 0.5 * v) / gam
        if 2.0 * d_est * d_est / gam > tail_tol or d_est > 0.25 * gam:
            return None
    elif law(v) >= 1.0:
        return None
    try:
        D, _ = law.chatter_tail(v, gam)
    except ValueError:
        return None
    err = 2.0 * D * D / gam
    if err > tail_tol or D > 0.25 * gam:
        return None
    return D, err


def trace(Gamma, e, t_start, v_start, t_end, tail_tol=1e-14, max_impacts=_MAX_IMPACTS):
    r"""Follow one node launched from the plate at ``t_start`` until it sticks or ``t_end``.

    Parameters
    ----------
    Gamma : float
        > 0.
    e : float
        Restitution in [0, 1).
    t_start : float
        Launch time (the node is at :math:`\zeta = 0`).
    v_start : float
        Launch velocity, > 0, or 0 with :math:`g(t_{start}) > 0`.
    t_end : float
        Horizon.
    tail_tol : float, optional
        Bound on the error of the closed-form chatter accumulation time.
    max_impacts : int, optional

    Returns
    -------
    segments : list of tuple
        ``("flight", a, b, v)`` (launch at ``a`` with ``v``, landing or horizon
        at ``b``) and ``("tail", a, b, (v, |g_c|, e, err))`` (closed-form chatter
        from the impact at ``a`` to the accumulation time ``b``).
    events : list of (float, str)
        ``(t, kind)`` with kind in {"impact", "stick", "liftoff"} after ``t_start``.
    end : tuple
        ``("stick", t)``, ``("horizon", t_end)`` or ``("max_impacts", t)``.

    Examples
    --------
    >>> seg, ev, end = trace(4.1, 0.0, math.asin(1 / 4.1), 0.0, 20.0)
    >>> [k for _, k in ev], end[0]
    (['impact', 'liftoff', 'impact', 'stick'], 'stick')
    """
    segments, events = [], []
    t, v = t_start, v_start
    law = e if isinstance(e, RestitutionLaw) else None
    for _ in range(max_impacts):
        fl = Flight(t, v, Gamma)
        tau = fl.first_landing(t_end - t)
        if tau is None:
            segments.append(("flight", t, t_end, v))
            return segments, events, ("horizon", t_end)
        w_minus = fl.w(tau)
        t1 = t + tau
        segments.append(("flight", t, t1, v))
        events.append((t1, "impact"))
        g1 = gravity(t1, Gamma)
        if law is not None:
            v = law.rebound(-w_minus) if w_minus < 0.0 else 0.0
        else:
            v = -e * w_minus if w_minus < 0.0 else 0.0
        if v <= 0.0:
            if g1 <= 0.0:
                events.append((t1, "stick"))
                return segments, events, ("stick", t1)
            events.append((t1, "liftoff"))  # touch-and-go
            t, v = t1, 0.0
            continue
        if g1 < 0.0 and law is not None:
            tail = _law_tail(v, -g1, law, tail_tol)
            if tail is not None:
                D, err = tail
                segments.append(("tail", t1, t1 + D, (v, -g1, law, err)))
                events.append((t1 + D, "stick"))
                return segments, events, ("stick", t1 + D)
        elif g1 < 0.0:
            tail = _tail(v, -g1, e, tail_tol)
            if tail is not None:
                D0, err = tail
                segments.append(("tail", t1, t1 + D0, (v, -g1, e, err)))
                events.append((t1 + D0, "stick"))
                return segments, events, ("stick", t1 + D0)
        t = t1
    return segments, events, ("max_impacts", t)


# ----------------------------------------------------------------------------- orbits

class ContactOrbit:
    r"""A periodic orbit of one node made of flights, sticks and chatter tails.

    Built by :func:`sticking_orbit` or :func:`touch_orbits`; used by
    :class:`tps_solver.FlatLayer` for its non-single-bounce patterns.

    Attributes
    ----------
    pattern : str
        ``"stick"`` or ``"touch"``.
    Gamma, e, t0, period : float
        ``t0`` is the phase at which the node leaves the plate from rest
        (the lift-off for ``"stick"``, the first touch-and-go for ``"touch"``).
    M : int
    segments : list of tuple
        One period starting at ``t0``: ``("flight", a, b, v)``,
        ``("stick", a, b, None)``, ``("tail", a, b, (v, |g_c|, e, err))``.
    events : list of (float, str)
        One period ``[t0, t0 + T)`` of ``(t, kind)``, kind in {"impact", "stick", "liftoff"}.
    multipliers : ndarray of complex, shape (2,)
    tail_error : float
        Bound on the chatter accumulation-time error (0 if no tail).
    harmonic_tail_bound : float
        Bound on what the unresolved chatter tails add to any :math:`|\hat w_n|`.

    Examples
    --------
    The completely inelastic sticking orbit at Gamma = 4.1: lift-off from rest where
    :math:`g = \sin t - 1/\Gamma` turns positive, then the plate-frame flight (17):

    >>> from tps_solver.model.flight import flight_height
    >>> orb, _ = sticking_orbit(4.1, 0.0, 2)
    >>> type(orb).__name__, orb.pattern, orb.contact_sequence(), orb.t0 == math.asin(1 / 4.1)
    ('ContactOrbit', 'stick', 'TS', True)
    >>> t = orb.t0 + np.array([1.0, 3.0])
    >>> bool(np.allclose(orb.height(t), [flight_height(x, orb.t0, 0.0, 4.1) for x in t], atol=1e-12))
    True
    >>> float(orb.velocity(orb.t0)), float(orb.height(orb.t0 + orb.period))
    (0.0, 0.0)
    """

    def __init__(self, pattern, Gamma, e, M, t0, segments, events, multipliers):
        self.pattern, self.Gamma, self.e, self.M, self.t0 = pattern, Gamma, e, M, t0
        self.period = _TWO_PI * M
        self.segments, self.events = segments, events
        self.multipliers = np.asarray(multipliers, dtype=complex)
        tails = [s for s in segments if s[0] == "tail"]
        self.tail_error = max([s[3][3] for s in tails], default=0.0)
        self.harmonic_tail_bound = sum(
            s[3][0] * (s[2] - s[1]) if isinstance(s[3][2], RestitutionLaw)        # |w| <= v over the tail
            else 2.0 * s[3][0] ** 2 / (s[3][1] * (1.0 - s[3][2] ** 2)) for s in tails) / self.period
        self._starts = np.array([s[1] for s in segments])

    def _key(self):
        return (self.pattern, self.Gamma, self.e, self.M, self.t0, tuple(self.events))

    def __eq__(self, other):
        """Two orbits are equal when parameters, launch phase and events agree exactly."""
        return type(other) is type(self) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def contact_sequence(self):
        """Landings of one period as letters (see :attr:`tps_solver.FlatLayer.contact_sequence`)."""
        flights = [s for s in self.segments if s[0] == "flight"]
        if self.pattern == "touch":
            return "T" * len(flights)
        if self.e == 0.0:
            return "T" * (len(flights) - 1) + "S"
        # impact i ends flight i; its rebound speed launches flight i + 1 (or the summed tail)
        times = [s[2] for s in flights]
        rebound = [s[3] for s in flights[1:]]
        tail = [s for s in self.segments if s[0] == "tail"]
        rebound.append(tail[0][3][0] if tail else 0.0)
        j = len(times) - 1
        while (j > 0 and gravity(times[j - 1], self.Gamma) < 0.0 and rebound[j - 1] > rebound[j]):
            j -= 1
        return "B" * j + "C"

    def landings(self):
        r"""The landings of one period :math:`[t_0, t_0 + T)`, in time order.

        Returns
        -------
        list of tuple
            ``(t, kind, w_minus, liftoff)``: the landing time, its kind -- ``"touch"``
            (touch-and-go: a new flight from rest at once), ``"stick"`` (rest until
            ``liftoff``), ``"bounce"`` (a rebound) or ``"chatter"`` (the first impact of a
            summed chatter tail, at rest from its accumulation until ``liftoff``) --, the
            pre-impact velocity :math:`w(t^-)` and the lift-off time (nan unless stick or chatter).

        Examples
        --------
        >>> orb, _ = sticking_orbit(4.1, 0.0, 2)
        >>> [(round(t, 9), k, round(w, 9)) for t, k, w, _ in orb.landings()]
        [(7.434953167, 'touch', -1.19038202), (12.451615, 'stick', -1.810125689)]
        >>> orb.landings()[-1][3] == orb.t0 + orb.period
        True
        """
        segs = self.segments
        out = []
        for k, (kind, a, b, v) in enumerate(segs):
            if kind != "flight":
                continue
            nxt = segs[(k + 1) % len(segs)]
            w_minus = Flight(a, v, self.Gamma).w(b - a)
            if nxt[0] == "stick":
                out.append((b, "stick", w_minus, nxt[2]))
            elif nxt[0] == "tail":
                after = segs[(k + 2) % len(segs)]
                out.append((b, "chatter", w_minus, after[2] if after[0] == "stick" else math.nan))
            elif nxt[3] == 0.0:
                out.append((b, "touch", w_minus, math.nan))
            else:
                out.append((b, "bounce", w_minus, math.nan))
        end = self.t0 + self.period      # a landing at the period's end is the one at t0 (touch orbits)
        slack = 8.0 * np.finfo(float).eps * (abs(end) + self.period)
        out = [(self.t0 if t >= end - slack else t, *rest) for t, *rest in out]
        return sorted(out, key=lambda c: c[0])

    # ------------------------------------------------------------------ evaluation
    def _wrap(self, t):
        t = np.asarray(t, dtype=float)
        tau = np.mod(t - self.t0, self.period)
        slack = 8.0 * np.finfo(float).eps * (np.abs(t) + self.period)
        tau = np.where(self.period - tau <= slack, 0.0, tau)
        return self.t0 + tau

    def _evaluate(self, t, which):
        tt = self._wrap(t)
        flat = tt.ravel()
        out = np.zeros_like(flat)
        idx = np.searchsorted(self._starts, flat, side="right") - 1
        for j, (kind, a, b, data) in enumerate(self.segments):
            sel = np.nonzero(idx == j)[0]
            if sel.size == 0 or kind == "stick":
                continue
            if kind == "flight":
                fl = Flight(a, data, self.Gamma)
                f = fl.w if which == "w" else fl.z
                out[sel] = [f(x - a) for x in flat[sel]]
            elif isinstance(data[2], RestitutionLaw):
                continue      # a law's tail: |w| <= v, zeta <= v^2/(2 gam), both below 1e-9; evaluated as rest
            else:  # closed-form chatter tail at constant g
                v, gam, e, _ = data
                for i in sel:
                    x = min(max((flat[i] - a) * gam * (1.0 - e) / (2.0 * v), 0.0), 1.0)
                    k = 0 if x <= 0.0 else (math.floor(math.log1p(-x) / math.log(e)) if x < 1.0 else None)
                    if k is None:
                        continue
                    u = v * e ** k
                    s = a + 2.0 * v * (1.0 - e ** k) / (gam * (1.0 - e))
                    d = flat[i] - s
                    out[i] = u - gam * d if which == "w" else max(u * d - 0.5 * gam * d * d, 0.0)
        return out.reshape(tt.shape)

    def velocity(self, t):
        """Velocity w(t), T-periodic, right-continuous (post-event values at events)."""
        return self._evaluate(t, "w")

    def height(self, t):
        """Height zeta(t) >= 0, T-periodic."""
        return self._evaluate(t, "z")

    # ------------------------------------------------------------------ harmonics
    def harmonics(self, N, height=False):
        """Exact Fourier coefficients (closed form per flight; sticks contribute nothing)."""
        n = np.arange(-N, N + 1)
        nu = n / self.M
        c = np.zeros(2 * N + 1, dtype=complex)
        G = self.Gamma
        for kind, a, b, v in self.segments:
            if kind != "flight":
                continue
            d = b - a
            sa, ca = math.sin(a), math.cos(a)
            ea, eam = complex(math.cos(a), math.sin(a)), complex(math.cos(a), -math.sin(a))
            E0m, E1m, E2m = _moments(-nu, d)
            E0p, _, _ = _moments(1.0 - nu, d)
            E0q, _, _ = _moments(-1.0 - nu, d)
            if not height:
                part = (v + ca) * E0m - E1m / G - 0.5 * (ea * E0p + eam * E0q)
            else:
                part = ((v + ca) * E1m + sa * E0m - (ea * E0p - eam * E0q) / 2j - E2m / (2.0 * G))
            c += np.exp(-1j * nu * a) * part
        return c / self.period

    def peak_height(self):
        """Maximum height over the period."""
        best = 0.0
        for kind, a, b, v in self.segments:
            if kind != "flight":
                continue
            fl = Flight(a, v, self.Gamma)
            for p, q in fl.monotone_pieces(b - a):
                best = max(best, fl.z(p), fl.z(q))
        return best


def _moments(k, d):
    r"""E_p(k) = \int_0^d \tau^p e^{i k \tau} d\tau for p = 0, 1, 2, vectorised over k."""
    k = np.asarray(k, dtype=float)
    x = k * d
    small = np.abs(x) < 0.25
    E0 = np.empty(k.shape, dtype=complex)
    E1 = np.empty(k.shape, dtype=complex)
    E2 = np.empty(k.shape, dtype=complex)
    if np.any(small):
        ix = 1j * x[small]
        s0 = np.zeros(ix.shape, dtype=complex)
        s1 = np.zeros(ix.shape, dtype=complex)
        s2 = np.zeros(ix.shape, dtype=complex)
        term = np.ones(ix.shape, dtype=complex)  # (ix)^m / m!
        for m in range(20):
            s0 += term / (m + 1)
            s1 += term / (m + 2)
            s2 += term / (m + 3)
            term = term * ix / (m + 1)
        E0[small], E1[small], E2[small] = d * s0, d * d * s1, d ** 3 * s2
    big = ~small
    if np.any(big):
        kb = k[big]
        ekd = np.exp(1j * kb * d)
        e0 = (ekd - 1.0) / (1j * kb)
        e1 = (d * ekd - e0) / (1j * kb)
        e2 = (d * d * ekd - 2.0 * e1) / (1j * kb)
        E0[big], E1[big], E2[big] = e0, e1, e2
    return E0, E1, E2


def sticking_orbit(Gamma, e, M, tail_tol=1e-14, search_periods=8):
    r"""The orbit through a lift-off, if it returns to a stick after exactly M periods.

    Parameters
    ----------
    Gamma : float
    e : float
        Restitution in [0, 1).
    M : int
    tail_tol : float, optional
        Chatter tail error bound (see the module docstring).
    search_periods : int, optional
        How many periods beyond ``M`` to follow the node to report the period
        of a sticking orbit that is not of period ``2 pi M``.

    Returns
    -------
    orbit : ContactOrbit or None
    info : str
        Why there is no such orbit, or ``""``; for a sticking orbit of another
        period it says which (``"period 2*pi*k"``).

    Examples
    --------
    >>> orb, info = sticking_orbit(4.1, 0.0, 2)
    >>> [k for _, k in orb.events]
    ['liftoff', 'impact', 'liftoff', 'impact', 'stick']
    >>> sticking_orbit(2.0, 0.0, 2)[1]
    'the sticking orbit has period 2*pi*1 (M = 1)'
    """
    if Gamma <= 1.0:
        return None, f"Gamma = {Gamma} <= 1: g(t) <= 0 always, the node never lifts off"
    t0 = math.asin(1.0 / Gamma)
    T = _TWO_PI * M
    segs, ev, end = trace(Gamma, e, t0, 0.0, t0 + _TWO_PI * (M + search_periods), tail_tol)
    if end[0] == "max_impacts":
        return None, (f"more than {_MAX_IMPACTS} impacts without a stick (chatter that does not "
                      f"accumulate); no sticking orbit found")
    if end[0] == "horizon":
        return None, f"the node does not stick again within {M + search_periods} periods of a lift-off"
    k = liftoff_index(end[1], Gamma)
    if k != M:
        return None, f"the sticking orbit has period 2*pi*{k} (M = {k})"
    segs = segs + [("stick", end[1], t0 + T, None)]
    events = [(t0, "liftoff")] + ev
    return ContactOrbit("stick", Gamma, e, M, t0, segs, events, [0.0, 0.0]), ""


def _touch_landings(Gamma, phi, t_end):
    """Landing times of successive touch-and-go flights from rest at ``phi`` (e = 0), and the end kind."""
    out, t = [], phi
    while True:
        fl = Flight(t, 0.0, Gamma)
        tau = fl.first_landing(t_end - t)
        if tau is None:
            return out, "horizon"
        t1 = t + tau
        out.append(t1)
        if gravity(t1, Gamma) <= 0.0:
            return out, "stick"
        t = t1


def _touch_multiplier(Gamma, times):
    """Period-map multiplier prod Delta_i g(t_{i-1}) / w(t_i-) of a touch-and-go orbit."""
    mu = 1.0
    for a, b in zip(times[:-1], times[1:]):
        u = Flight(a, 0.0, Gamma).w(b - a)
        mu *= (b - a) * gravity(a, Gamma) / u
    return mu


def touch_orbits(Gamma, M, n_scan=160):
    r"""All touch-and-go orbits (e = 0, no stick) of minimal period 2 pi M found by a scan.

    The launch phase :math:`\varphi` is scanned over the take-off window
    :math:`g > 0` on ``n_scan`` uniform points plus points geometrically
    close to both ends (down to 1e-12 of the window); a root of
    :math:`F_j(\varphi) = t_j(\varphi) - \varphi - 2\pi M` (:math:`t_j` the
    j-th landing) bracketed by a sign change is refined by ``brentq`` and kept
    if :math:`|F_j| < 10^{-9}` there (rejecting jumps of the landing map at
    grazing flights), every landing before is a touch-and-go, and the orbit
    has no shorter period (a contact within 1e-6 periods of a whole period
    after the launch counts as a shorter period: near a flip, where the root
    of :math:`F_j` is ill-conditioned, this rejects the parent orbit; a
    genuine orbit within about 1e-12 in Gamma of its flip is rejected too).
    Orbits separated by less than the scan step may be missed.

    Returns
    -------
    orbits : list of ContactOrbit
        Sorted by increasing modulus of the multiplier.

    Examples
    --------
    >>> orbs = touch_orbits(3.8, 2)
    >>> len(orbs), [round(t, 6) for t, k in orbs[0].events if k == "impact"]
    (1, [...])
    """
    if Gamma <= 1.0:
        return []
    base = math.asin(1.0 / Gamma)
    T = _TWO_PI * M
    lo, hi = base, math.pi - base
    edge = (hi - lo) * 10.0 ** -np.arange(3.0, 13.0)   # orbits close to g = 0 at a contact
    grid = np.unique(np.concatenate([lo + (hi - lo) * (np.arange(n_scan) + 0.5) / n_scan,
                                     lo + edge, hi - edge]))
    n_scan = grid.size

    def landings(phi):
        return _touch_landings(Gamma, phi, phi + T + math.pi)[0]

    data = [landings(p) for p in grid]
    found = []
    for i in range(n_scan - 1):
        La, Lb = data[i], data[i + 1]
        for j in range(min(len(La), len(Lb))):
            Fa = La[j] - grid[i] - T
            Fb = Lb[j] - grid[i + 1] - T
            if Fa * Fb > 0.0:
                continue

            def F(p, j=j):
                L = landings(p)
                return L[j] - p - T if len(L) > j else math.nan

            try:
                phi = brentq(F, grid[i], grid[i + 1], xtol=1e-15, rtol=_RTOL)
            except ValueError:
                continue
            L = landings(phi)
            if len(L) <= j or abs(L[j] - phi - T) > 1e-9:
                continue
            times = [phi] + L[:j + 1]
            if any(gravity(t, Gamma) <= 0.0 for t in times):
                continue
            shorter = any(abs((t - phi) / _TWO_PI - round((t - phi) / _TWO_PI)) < 1e-6
                          and 0 < round((t - phi) / _TWO_PI) < M for t in L[:j])
            if shorter:
                continue
            phases = [math.fmod(t, _TWO_PI) for t in times[:-1]]
            t0 = min(phases)
            if any(abs(t0 - o.t0) < 1e-8 for o in found):
                continue
            found.append(_build_touch(Gamma, M, t0, j + 1))
    found = [o for o in found if o is not None]
    found.sort(key=lambda o: abs(o.multipliers[0]))
    return found


def _build_touch(Gamma, M, t0, n_contacts):
    """Polish the touch-and-go orbit through phase ``t0`` and build it."""
    T = _TWO_PI * M
    j = n_contacts - 1

    def F(p):
        L = _touch_landings(Gamma, p, p + T + math.pi)[0]
        return L[j] - p - T if len(L) > j else math.nan

    for h in (1e-12, 1e-10, 1e-8):
        a, b = t0 - h, t0 + h
        fa, fb = F(a), F(b)
        if fa * fb <= 0.0:
            t0 = brentq(F, a, b, xtol=1e-15, rtol=_RTOL)
            break
    L = _touch_landings(Gamma, t0, t0 + T + math.pi)[0][:n_contacts]
    times = [t0] + L
    segs = [("flight", a, b, 0.0) for a, b in zip(times[:-1], times[1:])]
    events = [(t0, "impact"), (t0, "liftoff")]
    for t in L[:-1]:
        events += [(t, "impact"), (t, "liftoff")]
    mu = _touch_multiplier(Gamma, times)
    return ContactOrbit("touch", Gamma, 0.0, M, t0, segs, events, [mu, 0.0])


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _encode_contact_orbit(orb):
    return {"pattern": orb.pattern, "Gamma": orb.Gamma, "e": orb.e, "M": orb.M, "t0": orb.t0}


def _decode_contact_orbit(d):
    """Rebuild from the parameters; the launch phase must come back bit for bit."""
    if d["pattern"] == "touch":
        candidates = touch_orbits(d["Gamma"], d["M"])
    else:
        candidates = [sticking_orbit(d["Gamma"], d["e"], d["M"])[0]]
    for orb in candidates:
        if orb is not None and orb.t0 == d["t0"]:
            return orb
    raise ValueError(f"the stored {d['pattern']!r} orbit (Gamma = {d['Gamma']}, e = {d['e']}, M = {d['M']}, "
                     f"t0 = {d['t0']!r}) is not an orbit of this version (the file is not from it)")


archive.register("ContactOrbit", ContactOrbit, encode=_encode_contact_orbit, decode=_decode_contact_orbit)
