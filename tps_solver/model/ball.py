r"""The one-node ball in closed form: point or soft contacts, sticking, exact events.

A flat layer is a single column of the FDA (53) with no coupling: the bouncing ball of Luck &
Mehta in the plate frame, :math:`\ddot\zeta = g(t) = \sin t - 1/\Gamma` (16) in flight.
:class:`ClosedFormBall` propagates it exactly, event by event:

* flights in closed form and the next landing by the certified search of
  :class:`tps_solver.model.flight.Flight` (the height written with :math:`1 - \cos d` and
  :math:`\sin d - d`, roots on pieces where it is monotone);
* ``model="point"``: restitution (11), :math:`w^+ = -e\,w^-`; an impact slower than
  ``stick_velocity`` (or any impact at e = 0) ends at rest, and the ball sticks while
  :math:`g \le 0` and lifts off when :math:`g` turns positive (Sec. 4, after (37));
* ``model="soft"``: while :math:`\zeta < 0` the damped oscillator
  :math:`\ddot\zeta + 2\beta\dot\zeta + \omega_0^2\zeta = 0` with :math:`\tau_c = \ell^2`,
  :math:`\omega_d = \pi/\tau_c`, :math:`\beta = -\ln e/\tau_c` in closed form (every contact
  lasts :math:`\tau_c` and returns :math:`w^+ = -e\,w^-`); ``soft_sticking`` adds the
  sticking rule for entries at or below ``stick_velocity`` (docs/design.md, hazards 10-11).

:func:`tps_solver.analyses.basins.flat_basins` classifies its stroboscopic map.
"""
import math

from tps_solver.model.flight import Flight, next_liftoff
from tps_solver.model.restitution import RestitutionLaw

__all__ = ["ClosedFormBall", "FREE", "STUCK", "CONTACT", "MODE_NAMES"]

#: Contact modes of a ball state ``(w, zeta, mode)``.
FREE, STUCK, CONTACT = 0, 1, 2
MODE_NAMES = ("free", "stuck", "contact")
_TWO_PI = 2.0 * math.pi


class ClosedFormBall:
    r"""The exact event-driven one-node ball (module docstring); :meth:`cycle` maps one forcing cycle.

    Parameters
    ----------
    Gamma : float
        Plate acceleration, > 0.
    e : float or RestitutionLaw
        Restitution in [0, 1] (> 0 for ``model="soft"``), or a speed-dependent law
        (:mod:`tps_solver.model.restitution`, ``model="point"``).
    model : {"point", "soft"}
    cutoff : float or None
        Soft contact cut-off length :math:`\ell` (``model="soft"``).
    stick_velocity : float
        Impacts slower than this end at rest (point), or are held (soft with ``soft_sticking``).
    max_events : int
        Events per call of :meth:`advance` before a ``RuntimeError``.
    soft_sticking : bool, optional
        The sticking rule for the soft contact.

    A state is ``(w, zeta, mode)`` with ``mode`` in :data:`FREE`, :data:`STUCK`, :data:`CONTACT`.

    Examples
    --------
    The completely inelastic ball at Gamma = 4.1 from rest on the plate: the f/2 sticking orbit,
    one touch-and-go and one stick every two forcing cycles:

    >>> ball = ClosedFormBall(4.1, 0.0, "point", None, 1e-6, 1000)
    >>> ev = []
    >>> state = ball.advance(0.0, 4 * math.pi, 0.0, 0.0, STUCK, ev)
    >>> [k for _, k in ev], state[2] == STUCK
    (['liftoff', 'impact', 'stick'], True)
    >>> round(ev[1][0], 9) == round(math.asin(1 / 4.1) + 7.188565375314, 9)
    True
    """

    def __init__(self, Gamma, e, model, cutoff, stick_velocity, max_events, soft_sticking=False):
        self.Gamma, self.e, self.model = Gamma, e, model
        self._law = e if isinstance(e, RestitutionLaw) else None
        self.soft_sticking = soft_sticking
        self.inv_G = 1.0 / Gamma
        self.stick_velocity, self.max_events = stick_velocity, max_events
        if model == "soft":
            self.tau_c = cutoff * cutoff
            self.omega_d = math.pi / self.tau_c
            self.beta = -math.log(e) / self.tau_c

    def _g(self, t):
        return math.sin(t) - self.inv_G

    def _impact(self, t_a, w_a, z_a, t_end):
        """First root of the height in (t_a, t_end] -> (d, w_minus), or None (:meth:`Flight.first_landing`)."""
        fl = Flight(t_a, w_a, self.Gamma, z_a)
        d = fl.first_landing(t_end - t_a)
        return None if d is None else (d, min(fl.w(d), 0.0))

    def _contact_exit(self, w0, z0):
        """Soft contact from (w0, z0 <= 0): time to the exit and the exit velocity."""
        A = z0
        B = (w0 + self.beta * z0) / self.omega_d
        if A == 0.0:
            if B > 0.0:                # at the plate and leaving it
                return 0.0, w0
            phi = -math.pi             # entering (w0 <= 0): half an oscillation
        else:
            phi = math.atan2(A, B)     # A < 0: phi in (-pi, 0)
        s = -phi / self.omega_d
        return s, math.hypot(A, B) * self.omega_d * math.exp(-self.beta * s)

    def _contact_state(self, w0, z0, s):
        """State a time s < exit time into the contact from (w0, z0)."""
        A = z0
        B = (w0 + self.beta * z0) / self.omega_d
        ex = math.exp(-self.beta * s)
        c, sn = math.cos(self.omega_d * s), math.sin(self.omega_d * s)
        z = ex * (A * c + B * sn)
        w = ex * ((B * self.omega_d - self.beta * A) * c - (A * self.omega_d + self.beta * B) * sn)
        return w, (z if z < 0.0 else -0.0)

    def advance(self, t, t_end, w, z, mode, events=None):
        """Propagate from t to t_end; returns (w, z, mode) at t_end; appends (t, kind) to ``events``.

        Examples
        --------
        >>> ClosedFormBall(2.5, 0.5, "point", None, 1e-6, 1000).advance(0.0, 0.1, 0.2, 1.0, FREE)[2] == FREE
        True
        """
        n_events = 0
        lifted = False                 # just lifted off: g turns positive here, no contact at once
        while True:
            if n_events > self.max_events:
                raise RuntimeError(f"more than {self.max_events} events in one forcing cycle near t = {t:.12g}")
            if mode == STUCK:
                tl = t if self._g(t) > 0.0 else next_liftoff(t, self.Gamma)
                if tl is None or tl >= t_end:
                    return 0.0, 0.0, STUCK
                t, w, z, mode, lifted = tl, 0.0, 0.0, FREE, True
                if events is not None:
                    events.append((t, "liftoff"))
                n_events += 1
                continue
            if mode == CONTACT:
                s, v = self._contact_exit(w, z)
                if t + s >= t_end:
                    w, z = self._contact_state(w, z, t_end - t)
                    return w, z, CONTACT
                t, w, z, mode = t + s, v, 0.0, FREE
                continue
            # free flight; at the plate and not leaving it -> contact now
            if not lifted and z <= 0.0 and (w < 0.0 or (w == 0.0 and self._g(t) <= 0.0)):
                hit = (0.0, min(w, 0.0))
            else:
                hit = self._impact(t, w, z, t_end)
            lifted = False
            if hit is None:
                fl = Flight(t, w, self.Gamma, z)
                d = t_end - t
                return fl.w(d), max(fl.z(d), 0.0), FREE
            d, w_minus = hit
            t = t + d
            n_events += 1
            if self.model == "soft" and not (self.soft_sticking and abs(w_minus) <= self.stick_velocity):
                if events is not None:
                    events.append((t, "impact"))
                w, z, mode = w_minus, 0.0, CONTACT
                continue
            z = 0.0
            if abs(w_minus) <= self.stick_velocity or (self._law is None and self.e == 0.0):
                w = 0.0
                if self._g(t) <= 0.0:
                    mode = STUCK
                    if events is not None:
                        events.append((t, "stick"))
                    continue
            elif self._law is not None:
                w = self._law.rebound(-w_minus)
            else:
                w = -self.e * w_minus
            if events is not None:
                events.append((t, "impact"))

    def cycle(self, t_section, state, events=None):
        """One forcing cycle :math:`2\\pi` from ``t_section``: ``state`` -> the state after it.

        Examples
        --------
        >>> ball = ClosedFormBall(4.1, 0.0, "point", None, 1e-6, 1000)
        >>> ball.cycle(0.0, ball.cycle(0.0, (0.0, 0.0, STUCK))) == (0.0, 0.0, STUCK)     # period 2
        True
        """
        w, z, mode = state
        return self.advance(t_section, t_section + _TWO_PI, w, z, mode, events)
