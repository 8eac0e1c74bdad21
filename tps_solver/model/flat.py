r"""The periodically bouncing flat layer (the bouncing ball of Luck & Mehta).

Implements eqs. (17)-(19) of Goddard & Didwania.  In the plate frame, with
lengths scaled by the plate amplitude and time by :math:`1/\omega`, a flat
layer launched at phase :math:`t_0` with post-impact velocity :math:`W_0`
flies under :math:`g(t) = \sin t - 1/\Gamma` (16):

.. math::
    W(t) &= W_0 + \cos t_0 - \cos t - \tau/\Gamma, \\
    \zeta(t) &= \frac{\tau (T - \tau)}{2\Gamma} + \sin t_0 - \sin t,
    \qquad \tau = t - t_0 \in [0, T),

where the second form of (18) uses the periodicity conditions (19):
:math:`s = (2\Gamma/T)\cos t_0 = (1-e)/(1+e)` and
:math:`W_0 = T/(2\Gamma) - \cos t_0`, :math:`T = 2\pi M`.

For given :math:`(\Gamma, e, M)` there are two launch phases
:math:`t_0 = \pm\arccos(sT/2\Gamma)`.  The Jacobian of the exact impact map
(derived in :meth:`FlatLayer.impact_map_jacobian`) shows that the branch
:math:`t_0 > 0` is the one that is stable inside the window
:meth:`FlatLayer.stability_window`; :math:`t_0 < 0` is a saddle.  The two
branches merge at the fold :math:`\cos t_0 = 1`, i.e. :math:`\Gamma = s\pi M`,
where a multiplier equals +1 -- this is the paper's preset :math:`t_0 = 0`.
"""
import math

import numpy as np
from scipy.optimize import brentq

from tps_solver.core import archive
from tps_solver.core.checks import check_choice, check_int, check_positive, check_real, check_restitution
from tps_solver.core.costs import check_cost, harmonics_cost
from tps_solver.core.pattern import ContactPattern
from tps_solver.model.harmonics import flat_w_hat, height_from_velocity
from tps_solver.model.flight import Flight, flight_velocity
from tps_solver.model.restitution import RestitutionLaw, as_restitution
from tps_solver.model.sticking import sticking_orbit, touch_orbits

__all__ = ["FlatLayer"]

_BRANCHES = ("stable", "unstable")
_NO_LAW_CONTACT = ("touch-and-go orbits need e = 0 exactly (a speed-dependent law rebounds from every landing "
                   "with e(v) > 0)")
_PATTERNS = ("auto", "bounce", "stick", "touch")


class _NoBounceOrbit(ValueError):
    """The single-bounce orbit (17)-(19) does not exist or is inadmissible."""


def _law_speeds(Gamma, M, law, samples=257):
    """The impact speeds v in [max(a - 1, 0), a + 1] with v (1 + e(v)) = 2a, a = T/(2 Gamma), ascending.

    Sign changes on ``samples`` equispaced speeds, each refined by ``brentq``: roots closer than
    the sampling step that cancel in pairs are missed (no law of this module has any)."""
    a = math.pi * M / Gamma
    lo, hi = max(a - 1.0, 0.0), a + 1.0
    v = np.linspace(lo, hi, samples)
    f = v * (1.0 + law(v)) - 2.0 * a
    roots = [float(x) for x in v[f == 0.0]]
    for i in np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0):
        roots.append(brentq(lambda x: x * (1.0 + law(x)) - 2.0 * a, v[i], v[i + 1], xtol=1e-15, rtol=1e-15))
    return sorted(r for r in roots if r > 0.0)


#: Lower bounds per forcing cycle of the period searched for contact orbits: time (measured 3.4e-4 to
#: 3.6e-4 s per cycle at M = 1000, divided by three) and peak memory (230 B per cycle at M = 3000 by
#: tracemalloc, divided by 3.5).
_SECONDS_PER_CYCLE = 1.0e-4
_BYTES_PER_CYCLE = 64.0


def _check_order(M):
    """M as an int >= 1; integral floats (2.0) are accepted, 2.5 is not; a period out of reach is refused
    (the contact orbits are searched cycle by cycle over the period 2 pi M)."""
    if isinstance(M, (float, np.floating)) and math.isfinite(M) and float(M).is_integer():
        M = int(M)
    M = check_int(M, "M", minimum=1)
    if M > 1000:                 # up to a thousand cycles the search takes under 0.4 s
        check_cost("FlatLayer", "M", M, _BYTES_PER_CYCLE * M + 1e6, _SECONDS_PER_CYCLE * M,
                   hint="the orbits of period 2 pi M are searched cycle by cycle")
    return M


def _contact_orbit(Gamma, M, e, pattern, branch):
    """(ContactOrbit or None, reason) for pattern "stick" or "touch"."""
    if pattern == "stick":
        return sticking_orbit(Gamma, e, M)
    if isinstance(e, RestitutionLaw) or e != 0.0:
        return None, f"touch-and-go orbits need e = 0 (with e = {e} every landing rebounds)"
    orbits = touch_orbits(Gamma, M)
    if not orbits:
        return None, "no touch-and-go orbit of this period found"
    stable = [o for o in orbits if abs(o.multipliers[0]) < 1.0]
    unstable = [o for o in orbits if abs(o.multipliers[0]) >= 1.0]
    chosen = stable if branch == "stable" else unstable[::-1]
    if not chosen:
        return None, (f"no {branch} touch-and-go orbit (found {len(orbits)} with |multiplier| "
                      f"{', '.join(f'{abs(o.multipliers[0]):.4g}' for o in orbits)})")
    return chosen[0], ""


def _bounce_branch_exists(Gamma, M, e, branch):
    """True if the single-bounce orbit of ``branch`` exists and is admissible."""
    try:
        layer = FlatLayer.__new__(FlatLayer)
        if isinstance(e, RestitutionLaw):
            layer._init_bounce_law(Gamma, M, e, None, branch)
        else:
            layer._init_bounce(Gamma, M, e, None, branch)
    except ValueError:
        return False
    return True


def _pattern_table(Gamma, M, e, exclude=None):
    """{pattern: (exists, branches or reason)} for "bounce", "stick" and (e = 0) "touch"."""
    table = {}
    if isinstance(e, RestitutionLaw):
        if "bounce" != exclude:
            br = [b for b in _BRANCHES if _bounce_branch_exists(Gamma, M, e, b)]
            table["bounce"] = (bool(br), br if br else "no admissible single-bounce orbit with the law")
        if "stick" != exclude:
            orbit, why = _contact_orbit(Gamma, M, e, "stick", "stable")
            table["stick"] = (True, ["stable"]) if orbit is not None else (False, why)
        if "touch" != exclude:
            table["touch"] = (False, _NO_LAW_CONTACT)
        return table
    for pat in ("bounce", "stick", "touch"):
        if pat == exclude:
            continue
        if pat == "bounce":
            br = [b for b in _BRANCHES if _bounce_branch_exists(Gamma, M, e, b)]
            table[pat] = (bool(br), br if br else "no admissible single-bounce orbit (17)-(19)")
        elif pat == "touch" and e != 0.0:
            table[pat] = (False, "touch-and-go orbits need e = 0")
        else:
            br, why = [], ""
            for b in (("stable",) if pat == "stick" else _BRANCHES):
                orbit, why_b = _contact_orbit(Gamma, M, e, pat, b)
                if orbit is not None:
                    br.append(b)
                elif not why:
                    why = why_b
            table[pat] = (bool(br), br if br else why)
    return table


def _existing_patterns(Gamma, M, e, exclude=None):
    """A sentence saying which patterns exist for (Gamma, e, M), for error messages."""
    found, reasons = [], []
    for pat, (ok, info) in _pattern_table(Gamma, M, e, exclude).items():
        if ok:
            found.append(repr(pat) if info == ["stable"] or pat == "bounce" and len(info) == 2
                         else f"{pat!r} (branch={'/'.join(repr(b) for b in info)})")
        elif not (pat == "touch" and e != 0.0):
            reasons.append(f"{pat}: {info}")
    head = (f"patterns that exist for Gamma = {Gamma}, e = {e}, M = {M}: "
            f"{', '.join(found) if found else 'none'}")
    return head + (f" ({'; '.join(reasons)})" if reasons else "")


class FlatLayer:
    r"""The T-periodic flat layer: the bouncing orbit (17)-(19), or sticking and touch-and-go orbits.

    Parameters
    ----------
    Gamma : float
        Dimensionless plate acceleration :math:`\Gamma = A\omega^2/g_0 > 0`.
    M : int, optional
        Subharmonic order, period :math:`T = 2\pi M` (default 2; integral
        floats such as 2.0 are accepted).
    e : float or RestitutionLaw, optional
        Restitution in [0, 1).  Exactly one of ``e`` and ``t0`` is normally
        given; if both are, they must satisfy (19).  A speed-dependent law
        (:mod:`tps_solver.model.restitution`) gives the single bounce only:
        (19) becomes :math:`v(1 + e(v)) = T/\Gamma` for the impact speed
        :math:`v = T/2\Gamma + \cos t_0` (the fastest root; all of them in
        :meth:`bounce_orbits`), and :attr:`e` is :math:`e(v)`; a
        :class:`~tps_solver.model.restitution.ConstantRestitution` is its
        float, bit for bit.
    t0 : float, optional
        Launch (contact) phase of the single-bounce orbit.  The paper's preset
        is ``t0 = 0``, which fixes ``e`` through (19) and sits exactly at the
        fold of the flat orbit.  Only with ``pattern`` "auto" or "bounce".
    branch : {"stable", "unstable"}, optional
        Single-bounce orbit with ``e`` given: ``"stable"`` selects
        :math:`t_0 = +\arccos(sT/2\Gamma)` (stable inside
        :meth:`stability_window`), ``"unstable"`` the saddle :math:`t_0 < 0`.
        Ignored (but checked) when ``t0`` is given.  For ``pattern="touch"``
        it picks a touch-and-go orbit with |multiplier| < 1 (the smallest) or
        >= 1 (the largest); a sticking orbit is unique and always "stable".
    pattern : {"auto", "bounce", "stick", "touch"}, optional
        Which periodic orbit (see :mod:`tps_solver.model.sticking` for the physics):

        * ``"bounce"``: one impact per period with rebound, (17)-(19);
        * ``"stick"``: the orbit through a lift-off (at :math:`\sin t =
          1/\Gamma`, :math:`\cos t > 0`) that lands to rest -- directly for
          ``e = 0``, at the end of a chatter sequence for ``e > 0`` -- and
          lifts off again exactly M periods later; touch-and-go contacts
          (``e = 0``) and rebounds (``e > 0``) may come before;
        * ``"touch"`` (``e = 0`` only): touch-and-go contacts only, no stick;
        * ``"auto"`` (default): ``"bounce"`` where it exists and is
          admissible.  Where it does not (and ``t0`` is not given, ``branch``
          is ``"stable"``), the orbit that :meth:`patterns` lists: the
          ``"stick"`` orbit if it exists, else (``e = 0``) a stable ``"touch"``
          orbit; :attr:`pattern` says which was chosen.  Code that needs the
          single bounce (the single-contact TPS, the soft flat orbit) asks for
          ``pattern="bounce"``, which raises where it does not exist.

    Attributes
    ----------
    Gamma, e, period : float
    t0 : float
        Single bounce: the impact phase.  Stick: the lift-off phase
        :math:`\arcsin(1/\Gamma)`.  Touch: the phase of one touch-and-go
        contact (the smallest mod :math:`2\pi`).
    W0 : float
        Velocity right after ``t0``: the post-impact velocity of (19), or 0
        (the node leaves from rest) for "stick" and "touch".
    M : int
    pattern : str
        "bounce", "stick" or "touch".
    branch : str
        Single bounce: ``"stable"`` if ``t0 >= 0`` else ``"unstable"``.
        Otherwise ``"stable"`` iff the multipliers lie inside the unit circle.
    events : list of (float, str)
        See :attr:`events`.

    Raises
    ------
    ValueError
        If a parameter is out of range, or the requested orbit does not exist
        (single bounce: :math:`sT/2\Gamma > 1`, or the orbit touches the plate
        before the period ends; "stick": the orbit through a lift-off does not
        return to rest after exactly M periods).  The message says which
        patterns do exist for the parameters.

    Examples
    --------
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> round(fl.t0, 6), fl.is_stable
    (0.30678, True)
    >>> fl = FlatLayer(Gamma=2.5, M=2, t0=0.0)      # the paper's preset
    >>> round(fl.e, 4)
    0.4307
    >>> fl = FlatLayer(Gamma=4.1, e=0.0)            # completely inelastic: touch-and-go, then stick
    >>> fl.pattern, fl.contact_sequence, [k for _, k in fl.events]
    ('stick', 'TS', ['liftoff', 'impact', 'liftoff', 'impact', 'stick'])
    >>> fl.floquet_multipliers()
    array([0.+0.j, 0.+0.j])
    >>> from tps_solver.model.restitution import PowerLawRestitution
    >>> fl = FlatLayer(2.2, 2, e=PowerLawRestitution(e0=0.3, v0=6.0))   # e tunes itself to the forcing
    >>> round(fl.e, 6), round(fl.impact_velocity, 6), fl.is_stable
    (0.503001, -3.800388, True)
    """

    def __init__(self, Gamma, M=2, e=None, t0=None, branch="stable", pattern="auto"):
        Gamma = check_positive(Gamma, "Gamma")
        M = _check_order(M)
        branch = check_choice(branch, "branch", _BRANCHES)
        pattern = check_choice(pattern, "pattern", _PATTERNS)
        if e is None and t0 is None:
            raise ValueError("e or t0 must be given (e in [0, 1), or t0 with e from (19))")
        self._law = None
        if isinstance(e, RestitutionLaw) and e.constant:
            e = e.e                       # a constant law is the float, bit for bit
        if isinstance(e, RestitutionLaw):
            self._inputs = {"Gamma": Gamma, "M": M, "e": e, "t0": t0, "branch": branch, "pattern": pattern}
            if pattern == "touch":
                raise ValueError(f"pattern='touch' is not available with {e!r}: {_NO_LAW_CONTACT}")
            if pattern == "stick":
                if t0 is not None:
                    raise ValueError(f"t0 can only be given with pattern='bounce' or 'auto', got t0 = {t0!r}")
                self._law = e
                self._init_contact(Gamma, M, e, pattern, branch)
                return
            try:
                self._init_bounce_law(Gamma, M, e, t0, branch)
            except _NoBounceOrbit as exc:
                if pattern == "auto" and t0 is None and branch == "stable":
                    orbit, _ = _contact_orbit(Gamma, M, e, "stick", "stable")
                    if orbit is not None:
                        self._law = e
                        self._set_contact(Gamma, M, e, orbit)
                        return
                raise ValueError(f"{exc}; {_existing_patterns(Gamma, M, e)}") from None
            return
        if e is not None:
            e = check_restitution(e, "e")
        # the constructor inputs, so that a saved layer is rebuilt bit for bit (archive codec below)
        self._inputs = {"Gamma": Gamma, "M": M, "e": e, "t0": t0, "branch": branch, "pattern": pattern}
        if pattern in ("stick", "touch"):
            if t0 is not None:
                raise ValueError(f"t0 can only be given with pattern='bounce' or 'auto' (the {pattern!r} "
                                 f"orbit fixes its own lift-off phase), got t0 = {t0!r}")
            self._init_contact(Gamma, M, e, pattern, branch)
            return
        try:
            self._init_bounce(Gamma, M, e, t0, branch)
        except _NoBounceOrbit as exc:
            if pattern == "auto" and t0 is None and e is not None and branch == "stable":
                # no single-bounce orbit: the orbit with a rest on the plate that patterns() lists
                # (.pattern says which was chosen)
                for alt in ("stick", "touch"):
                    orbit, _ = _contact_orbit(Gamma, M, e, alt, "stable")
                    if orbit is not None:
                        self._set_contact(Gamma, M, e, orbit)
                        return
            if e is None:
                raise ValueError(str(exc)) from None
            raise ValueError(f"{exc}; {_existing_patterns(Gamma, M, e)}") from None

    def _init_contact(self, Gamma, M, e, pattern, branch):
        orbit, why = _contact_orbit(Gamma, M, e, pattern, branch)
        if orbit is None:
            raise ValueError(f"pattern={pattern!r} does not exist for Gamma = {Gamma}, e = {e}, M = {M} "
                             f"({why}); {_existing_patterns(Gamma, M, e, exclude=pattern)}")
        self._set_contact(Gamma, M, e, orbit)

    def _set_contact(self, Gamma, M, e, orbit):
        self.Gamma, self.M, self.e = Gamma, M, e
        self.period = 2.0 * math.pi * M
        self.pattern = orbit.pattern
        self._orbit = orbit
        self.t0 = orbit.t0
        self.W0 = 0.0
        self.branch = "stable" if abs(orbit.multipliers[0]) < 1.0 else "unstable"

    def _init_bounce(self, Gamma, M, e, t0, branch):
        """The single-bounce orbit (17)-(19) (the constructor before contact patterns existed)."""
        T = 2.0 * math.pi * M
        if t0 is not None:
            t0 = check_real(t0, "t0")
            s = 2.0 * Gamma * math.cos(t0) / T
            if not 0.0 < s <= 1.0:
                raise ValueError(
                    f"t0 must give a restitution e = (1-s)/(1+s) in [0, 1) through (19), i.e. "
                    f"0 < s = 2*Gamma*cos(t0)/T <= 1; got s = {s:.6g} for t0 = {t0!r}, Gamma = {Gamma}, M = {M}")
            e_t0 = (1.0 - s) / (1.0 + s)
            if not 0.0 <= e_t0 < 1.0:
                raise ValueError(f"t0 must give a restitution e in [0, 1) through (19); t0 = {t0!r} "
                                 f"gives e = {e_t0!r}")
            if e is not None:
                e = check_restitution(e, "e")
                if abs(e - e_t0) > 1e-12:
                    raise ValueError(f"e and t0 are inconsistent: t0 = {t0} gives e = {e_t0:.15g} by (19), "
                                     f"got e = {e}")
            e = e_t0
            # wrap t0 into (-pi, pi]
            t0 = math.atan2(math.sin(t0), math.cos(t0))
        else:
            e = check_restitution(e, "e")
            s = (1.0 - e) / (1.0 + e)
            c = s * T / (2.0 * Gamma)
            if c > 1.0:
                raise _NoBounceOrbit(
                    f"Gamma is too small for a period-{M} orbit with e = {e}: (19) needs "
                    f"Gamma >= s*pi*M = {s * math.pi * M:.12g}, got Gamma = {Gamma}")
            t0 = math.acos(c) if branch == "stable" else -math.acos(c)
        self.Gamma = Gamma
        self.M = M
        self.e = e
        self.t0 = t0
        self.period = T
        self.W0 = T / (2.0 * Gamma) - math.cos(t0)
        self.branch = "stable" if t0 >= 0 else "unstable"
        self.pattern = "bounce"
        self._orbit = None
        self._check_admissible()

    def _init_bounce_law(self, Gamma, M, law, t0, branch):
        r"""The single bounce with a speed-dependent law: (19) becomes :math:`v\,(1 + e(v)) = T/\Gamma`
        for the impact speed :math:`v = T/2\Gamma + \cos t_0`, and :math:`W_0 = e(v)\,v`."""
        T = 2.0 * math.pi * M
        a = T / (2.0 * Gamma)
        if t0 is not None:
            t0 = check_real(t0, "t0")
            t0 = math.atan2(math.sin(t0), math.cos(t0))
            v = a + math.cos(t0)
            if v <= 0.0:
                raise ValueError(f"t0 = {t0!r} gives a non-positive impact speed v = T/(2 Gamma) + cos t0 = {v:.6g}")
            defect = v * (1.0 + law(v)) - 2.0 * a
            if abs(defect) > 1e-12 * max(1.0, 2.0 * a):
                raise ValueError(f"t0 and the law are inconsistent: v (1 + e(v)) - T/Gamma = {defect:.3g} at "
                                 f"t0 = {t0!r} (v = {v:.15g}, {law!r}); FlatLayer.bounce_orbits lists the t0 "
                                 "that are consistent")
        else:
            speeds = _law_speeds(Gamma, M, law)
            if not speeds:
                raise _NoBounceOrbit(
                    f"no period-{M} single bounce for Gamma = {Gamma} with {law!r}: no impact speed v in "
                    f"[T/(2 Gamma) - 1, T/(2 Gamma) + 1] solves v (1 + e(v)) = T/Gamma")
            v = speeds[-1]                                  # the fastest (see bounce_orbits)
            c = min(max(v - a, -1.0), 1.0)
            t0 = math.acos(c) if branch == "stable" else -math.acos(c)
        self._law = law
        self.Gamma, self.M, self.period, self.t0 = Gamma, M, T, t0
        self.W0 = a - math.cos(t0)
        self.e = law(v)
        self.branch = "stable" if t0 >= 0 else "unstable"
        self.pattern = "bounce"
        self._orbit = None
        self._check_admissible()

    @property
    def restitution(self):
        """The restitution law (a :class:`~tps_solver.model.restitution.ConstantRestitution` of
        :attr:`e` unless a speed-dependent law was given; then :attr:`e` is its value at the
        orbit's impact speed)."""
        return self._law if getattr(self, "_law", None) is not None else as_restitution(self.e)

    @staticmethod
    def bounce_orbits(Gamma, M=2, e=0.45):
        r"""Every single-bounce orbit of (Gamma, M) with the restitution ``e`` (float or law).

        A speed-dependent law can have several impact speeds with :math:`v(1 + e(v)) = T/\Gamma`
        (the constructor takes the fastest); each gives the two launch phases
        :math:`\pm\arccos(v - T/2\Gamma)`.  Inadmissible orbits are left out.

        Returns
        -------
        orbits : list of FlatLayer
            Sorted by impact speed, the stable-side phase (t0 >= 0) first.

        Examples
        --------
        >>> [round(o.t0, 6) for o in FlatLayer.bounce_orbits(2.5, 2, 0.45)]
        [0.30678, -0.30678]
        """
        Gamma = check_positive(Gamma, "Gamma")
        M = _check_order(M)
        law = as_restitution(e)
        a = math.pi * M / Gamma
        speeds = [a * 2.0 / (1.0 + law.e)] if law.constant else _law_speeds(Gamma, M, law)
        out = []
        for v in speeds:
            c = v - a
            if abs(c) > 1.0:
                continue
            for sign in (1.0, -1.0):
                try:
                    out.append(FlatLayer(Gamma, M, e=law, t0=sign * math.acos(c), pattern="bounce"))
                except ValueError:
                    pass
                if c == 1.0:
                    break
        return out

    # ------------------------------------------------------------------ orbit
    def __repr__(self):
        extra = "" if self.pattern == "bounce" else f", pattern={self.pattern!r}"
        return (f"FlatLayer(Gamma={self.Gamma!r}, M={self.M!r}, e={self.e!r}, "
                f"t0={self.t0!r}, branch={self.branch!r}{extra})")

    @property
    def events(self):
        """Contact events in one period ``[t0, t0 + T)``: a list of ``(t, kind)``.

        ``kind`` is ``"impact"`` (a landing; with ``e > 0`` a rebound, with
        ``e = 0`` followed at the same instant by ``"stick"`` or, for a
        touch-and-go, ``"liftoff"``), ``"stick"`` (the node comes to rest; for
        ``e > 0`` the accumulation time of a chatter sequence, whose last,
        geometrically small bounces are summed in closed form and not listed)
        or ``"liftoff"`` (the node leaves the plate from rest).  The
        single-bounce orbit has the one event ``(t0, "impact")``.

        Returns
        -------
        events : list of (float, str)
        """
        if self._orbit is None:
            return [(self.t0, "impact")]
        return list(self._orbit.events)

    def contacts(self, n_nodes=1):
        """The contact pattern of one period, ``[t0, t0 + T)``, on ``n_nodes`` identical nodes.

        A :class:`~tps_solver.core.pattern.ContactPattern` in the package's one alphabet:
        its letters are :attr:`contact_sequence`; a landing to rest (``"stick"``) or a
        chatter tail (``"chatter"``, at its first impact) carries the lift-off that ends the
        rest (smooth: the plate's reaction falls to zero where g turns positive).

        Parameters
        ----------
        n_nodes : int
            Nodes of a uniform lattice in this state (default 1).

        Returns
        -------
        ContactPattern

        Examples
        --------
        >>> fl = FlatLayer(4.1, e=0.0)
        >>> p = fl.contacts()
        >>> p.sequence(0) == fl.contact_sequence, bool(p.liftoff[1] == fl.t0 + fl.period)
        (True, True)
        >>> FlatLayer(4.4, e=0.1, pattern="stick").contacts(2).sequences()
        ['BC', 'BC']
        """
        n_nodes = check_int(n_nodes, "n_nodes", minimum=1)
        letters = self.contact_sequence
        events = self.events
        T = self.period
        impacts = [t for t, k in events if k == "impact"]
        kinds = {"B": "bounce", "T": "touch", "S": "stick", "C": "chatter"}
        times, kind, lift = [], [], []
        for i, letter in enumerate(letters):
            t = impacts[i] if i < len(impacts) else next(t for t, k in events if k == "stick")
            times.append(t)
            kind.append(kinds[letter])
            if letter in "SC":
                after = [u for u, k in events if k == "liftoff" and u > t]
                lift.append(after[0] if after else self.t0 + T)
            else:
                lift.append(math.nan)
        node = np.repeat(np.arange(n_nodes), len(times))
        return ContactPattern.from_contacts(node, np.tile(times, n_nodes), np.tile(kind, n_nodes), n_nodes,
                                            T, t_start=self.t0, liftoff=np.tile(lift, n_nodes))

    @property
    def contact_sequence(self):
        """The landings of one period as letters.

        "B" a rebound (e > 0), "T" a touch-and-go (e = 0, g > 0 at the
        landing), "S" a landing to rest (e = 0, g <= 0), "C" a chatter
        sequence accumulating to rest (e > 0): the impacts from the last one
        after which all impacts happen at g < 0 with decreasing rebound speeds
        (so the letter count does not depend on how many bounces are resolved
        before the tail is summed).  The single-bounce orbit is "B" ("T" if
        e = 0).

        Returns
        -------
        sequence : str

        Examples
        --------
        >>> FlatLayer(4.1, e=0.0).contact_sequence, FlatLayer(4.4, e=0.1, pattern="stick").contact_sequence
        ('TS', 'BC')
        """
        if self._orbit is None:
            return "B" if self.e > 0.0 else "T"
        return self._orbit.contact_sequence()

    @property
    def chatter_error(self):
        """Bound on the error of the closed-form chatter accumulation times (0 if none)."""
        return 0.0 if self._orbit is None else self._orbit.tail_error

    def _check_admissible(self):
        """Raise ValueError unless zeta > 0 on the open period (rigorous, see :meth:`Flight.first_landing`)."""
        t0, T, G = self.t0, self.period, self.Gamma
        if self.W0 < 0.0 or (self.W0 == 0.0 and math.sin(t0) - 1.0 / G <= 0.0):
            raise _NoBounceOrbit(
                f"inadmissible orbit: post-impact velocity W0 = {self.W0:.6g} with g(t0) = "
                f"{math.sin(t0) - 1.0 / G:.6g} does not lift off (for e = 0 the layer sticks; "
                f"sticking orbits are not of the form (17)-(19))")
        d_hit = Flight(t0, self.W0, G).first_landing(T * (1.0 + 1e-9))
        t_hit = None if d_hit is None else t0 + d_hit
        if t_hit is None or t_hit < t0 + T * (1.0 - 1e-10):
            where = "never" if t_hit is None else f"at t = {t_hit:.12g} < t0 + T = {t0 + T:.12g}"
            raise _NoBounceOrbit(
                f"inadmissible orbit for Gamma = {G}, e = {self.e:.12g}, M = {self.M}, t0 = {t0:.12g}: "
                f"the layer touches the plate {where} (zeta must be > 0 on the open period)")

    def _phase(self, t):
        """tau = (t - t0) mod T in [0, T); a tau within round-off of T (t = t0 + kT computed in
        floating point) is snapped to 0, so contact instants give the post-impact state."""
        t = np.asarray(t, dtype=float)
        tau = np.mod(t - self.t0, self.period)
        slack = 8.0 * np.finfo(float).eps * (np.abs(t) + self.period)
        return np.where(self.period - tau <= slack, 0.0, tau)

    def velocity(self, t):
        """Plate-frame velocity W(t) of (17), T-periodic; post-impact value at contact instants.

        Parameters
        ----------
        t : array_like of float

        Returns
        -------
        W : ndarray of float, same shape as ``t``
        """
        if self._orbit is not None:
            return self._orbit.velocity(t)
        tau = self._phase(t)
        return self.W0 + math.cos(self.t0) - np.cos(self.t0 + tau) - tau / self.Gamma

    def height(self, t):
        """Plate-frame height zeta(t) of (18), T-periodic.

        Parameters
        ----------
        t : array_like of float

        Returns
        -------
        zeta : ndarray of float, same shape as ``t``
        """
        if self._orbit is not None:
            return self._orbit.height(t)
        tau = self._phase(t)
        return (tau * (self.period - tau) / (2.0 * self.Gamma) + math.sin(self.t0)
                - np.sin(self.t0 + tau))

    @property
    def impact_velocity(self):
        """Pre-impact velocity W(t0 + T -) = W0 - T/Gamma (< 0).

        For the other patterns: the pre-impact velocity of the first landing after ``t0``.
        """
        if self._orbit is not None:
            kind, a, b, v = self._orbit.segments[0]
            return float(flight_velocity(b, a, v, self.Gamma))
        return self.W0 - self.period / self.Gamma

    @property
    def peak_height(self):
        """Maximum of zeta over the period (at the interior zero of W)."""
        if self._orbit is not None:
            return self._orbit.peak_height()
        best = 0.0
        for a, b in Flight(self.t0, self.W0, self.Gamma).monotone_pieces(self.period):
            for d in (a, b):
                best = max(best, float(self.height(self.t0 + d)))
        return best

    def harmonics(self, N):
        r"""Exact Fourier coefficients of W(t) in the package convention.

        :math:`\hat W_n = e^{-in\alpha t_0}/(i n\alpha\Gamma) - \tfrac12\delta_{|n|M}`,
        :math:`\hat W_0 = 0` (closed form, no FFT; see :func:`~tps_solver.model.harmonics.flat_w_hat`).

        For the sticking and touch-and-go patterns each flight segment
        :math:`[a, b]` contributes
        :math:`T^{-1}\int_a^b (v + \cos a - \cos t - (t-a)/\Gamma)\,e^{-in\alpha t}\,dt`
        in closed form and sticks contribute nothing; the unresolved chatter
        tails of ``e > 0`` add at most ``self._orbit.harmonic_tail_bound`` (of
        order 1e-15 or less) to any coefficient and are left out.

        Parameters
        ----------
        N : int
            Truncation order, ``N >= 1``.

        Returns
        -------
        w_hat : ndarray of complex, shape (2N+1,)
            Entry ``N + n`` is :math:`\hat W_n`, ``n = -N..N``.
        """
        N = check_int(N, "N", minimum=1)
        check_cost("FlatLayer.harmonics", "N", N, *harmonics_cost(N))
        if self._orbit is not None:
            return self._orbit.harmonics(N)
        return flat_w_hat(N, self.M, self.Gamma, self.t0)

    def height_harmonics(self, N):
        r"""Exact Fourier coefficients of zeta(t): :math:`\hat\zeta_n = \hat W_n/(in\alpha)`,
        :math:`\hat\zeta_0 = T^2/(12\Gamma) + \sin t_0` (the period mean).

        Returns
        -------
        zeta_hat : ndarray of complex, shape (2N+1,)
            For the sticking and touch-and-go patterns: closed form per flight
            segment, entry ``N`` the period mean.
        """
        N = check_int(N, "N", minimum=1)
        check_cost("FlatLayer.height_harmonics", "N", N, *harmonics_cost(N))
        if self._orbit is not None:
            return self._orbit.harmonics(N, height=True)
        z = height_from_velocity(self.harmonics(N), self.M)
        z[N] = self.period ** 2 / (12.0 * self.Gamma) + math.sin(self.t0)
        return z

    # -------------------------------------------------------------- stability
    def impact_map(self, t, v):
        """The exact impact map (t_k, v_k) -> (t_{k+1}, v_{k+1}).

        The next impact is the first root of the flight height after ``t``
        (found rigorously on monotone pieces), and ``v_{k+1} = -e W(t_{k+1}-)``.

        Parameters
        ----------
        t : float
            Impact phase.
        v : float
            Post-impact velocity (> 0).

        Returns
        -------
        t_next, v_next : float

        Raises
        ------
        ValueError
            If the flight does not return to the plate within 4 periods.
        """
        t = check_real(t, "t")
        v = check_real(v, "v")
        if v <= 0.0:
            raise ValueError(f"v must be > 0 (post-impact velocity), got {v}")
        d = Flight(t, v, self.Gamma).first_landing(4.0 * self.period)
        if d is None:
            raise ValueError("no impact within 4 periods of t")
        t_next = t + d
        if self._law is not None:
            return t_next, self._law.rebound(-flight_velocity(t_next, t, v, self.Gamma))
        return t_next, -self.e * flight_velocity(t_next, t, v, self.Gamma)

    def impact_map_jacobian(self, t=None, v=None):
        r"""Jacobian of the impact map at (t, v) (default: the periodic orbit).

        With :math:`F(t', t, v) = (v + \cos t)(t'-t) + \sin t - \sin t' - (t'-t)^2/2\Gamma = 0`,
        :math:`u = W(t'^-)`, :math:`\Delta = t' - t` and :math:`g(t) = \sin t - 1/\Gamma`:

        .. math::
            \partial_t t' = (v + \Delta g(t))/u, \quad \partial_v t' = -\Delta/u,\\
            dv' = -e\,[dv - g(t)\,dt + g(t')\,dt'],

        whence :math:`\det J = -e v/u`, which equals :math:`e^2` on the periodic orbit.  With a
        speed-dependent law (:mod:`tps_solver.model.restitution`) e is replaced by
        :math:`\phi'(|u|) = e(|u|) + |u|\,e'(|u|)` and :math:`\det J = e(v)\,\phi'(v)` on the orbit.

        Returns
        -------
        J : ndarray of float, shape (2, 2)
            Rows (t', v'), columns (t, v).
        """
        if t is None:
            if self._orbit is not None:
                raise ValueError(f"t and v must be given: the {self.pattern!r} orbit is not a single-impact "
                                 f"orbit (its period-map multipliers are in floquet_multipliers())")
            t, v = self.t0, self.W0
            t_next = t + self.period
        else:
            t_next, _ = self.impact_map(t, v)
        G, e = self.Gamma, self.e
        d = t_next - t
        u = flight_velocity(t_next, t, v, G)
        if self._law is not None:
            e = self._law.rebound_derivative(-u)        # phi'(|u|) in place of e
        g0 = math.sin(t) - 1.0 / G
        g1 = math.sin(t_next) - 1.0 / G
        dtt = (v + d * g0) / u
        dtv = -d / u
        return np.array([[dtt, dtv],
                         [-e * (-g0 + g1 * dtt), -e * (1.0 + g1 * dtv)]])

    def floquet_multipliers(self):
        r"""The two multipliers of the period (impact) map, by decreasing modulus.

        For ``pattern="stick"`` both are 0: every nearby state lands, sticks
        and lifts off at the same phase from the same state (w = zeta = 0), so
        the period map is locally constant.  For ``pattern="touch"`` (e = 0)
        the state at a contact is the contact time alone (w = 0 after it);
        the map has the multipliers :math:`\prod_i \Delta_i g(t_{i-1})/w(t_i^-)`
        and 0, with :math:`\Delta_i` the flight durations.

        Returns
        -------
        mu : ndarray of complex, shape (2,)
        """
        if self._orbit is not None:
            mu = np.array(self._orbit.multipliers, dtype=complex)
            return mu[np.argsort(-np.abs(mu), kind="stable")]
        mu = np.linalg.eigvals(self.impact_map_jacobian()).astype(complex)
        return mu[np.argsort(-np.abs(mu), kind="stable")]

    @property
    def is_stable(self):
        """True if both multipliers lie strictly inside the unit circle."""
        return bool(np.max(np.abs(self.floquet_multipliers())) < 1.0)

    @staticmethod
    def patterns(Gamma, M=2, e=0.0):
        """Which orbit patterns exist for (Gamma, e, M), and on which branches.

        Parameters
        ----------
        Gamma : float
        M : int, optional
        e : float, optional
            Restitution in [0, 1).

        Returns
        -------
        table : dict
            ``{pattern: (exists, info)}`` for "bounce", "stick" and "touch";
            ``info`` is the list of branches that exist, or the reason there is
            none.

        Examples
        --------
        >>> t = FlatLayer.patterns(4.1, 2, e=0.0)
        >>> t["stick"], t["bounce"][0], t["touch"][0]
        ((True, ['stable']), False, False)
        """
        Gamma = check_positive(Gamma, "Gamma")
        M = _check_order(M)
        law = as_restitution(e)
        return _pattern_table(Gamma, M, law.e if law.constant else law)

    @staticmethod
    def stability_window(e, M):
        r"""Interval of Gamma in which the stable branch is linearly stable.

        The lower end is the fold :math:`\Gamma = s\pi M` (multiplier +1, where
        the two branches are born); the upper end is the period doubling where
        :math:`\operatorname{tr}J = -(1 + e^2)` (multiplier -1), found by
        ``brentq``.  Admissibility is checked at the returned ends.

        Parameters
        ----------
        e : float or RestitutionLaw
            Restitution in (0, 1), or a speed-dependent law: then the lower end is the fold
            :math:`v(1 - e(v)) = 2` (:math:`\cos t_0 = 1`), and the upper end the first
            :math:`\Gamma` above it where the largest multiplier of the stable branch reaches
            modulus 1 (scanned in steps of 1 %, refined by ``brentq``).
        M : int

        Returns
        -------
        Gamma_low, Gamma_high : float

        Examples
        --------
        >>> lo, hi = FlatLayer.stability_window(0.45, 2)
        >>> round(lo, 6)
        2.383277
        """
        law = as_restitution(e)
        if not law.constant:
            return _law_stability_window(law, check_int(M, "M", minimum=1))
        e = check_restitution(law.e, "e")
        if e == 0.0:
            raise ValueError("e must be > 0 for the stability window (e = 0 orbits stick)")
        M = check_int(M, "M", minimum=1)
        s = (1.0 - e) / (1.0 + e)
        low = s * math.pi * M

        def pd(G):
            J = FlatLayer(G, M, e=e).impact_map_jacobian()
            return np.trace(J) + 1.0 + e * e

        G = low * (1.0 + 1e-6)
        if pd(G) < 0.0:
            raise ValueError("no stable interval found above the fold")
        step = 1.05
        while pd(G * step) > 0.0:
            G *= step
            if G > 1e6:
                raise ValueError("period doubling not found below Gamma = 1e6")
        high = brentq(pd, G, G * step, xtol=1e-14, rtol=1e-15)
        return low, high


def _law_stability_window(law, M):
    """:meth:`FlatLayer.stability_window` for a speed-dependent law."""
    T = 2.0 * math.pi * M

    def fold(v):
        return v * (1.0 - law(v)) - 2.0

    hi = 1.0
    while fold(hi) < 0.0:
        hi *= 2.0
        if hi > 1e6:
            raise ValueError(f"no fold below impact speed 1e6 for {law!r}: v (1 - e(v)) stays below 2")
    v_f = brentq(fold, 0.0, hi, xtol=1e-15, rtol=1e-15)
    low = T / (v_f * (1.0 + law(v_f)))

    def mu(G):
        try:
            return float(np.max(np.abs(FlatLayer(G, M, e=law, pattern="bounce").floquet_multipliers())))
        except ValueError:
            return math.nan

    G = low * (1.0 + 1e-6)
    if not mu(G) < 1.0:
        raise ValueError(f"no stable interval found above the fold Gamma = {low:.12g} for {law!r}")
    step = 1.01
    while True:
        m = mu(G * step)
        if not m < 1.0:
            break
        G *= step
        if G > 1e4:
            raise ValueError(f"the stable branch of {law!r} stays stable up to Gamma = 1e4")
    if math.isnan(m):
        lo_g, hi_g = G, G * step                      # the orbit ceased to exist: bisect existence
        while hi_g - lo_g > 1e-13 * hi_g:
            mid = 0.5 * (lo_g + hi_g)
            lo_g, hi_g = (mid, hi_g) if mu(mid) < 1.0 else (lo_g, mid)
        return low, lo_g
    return low, brentq(lambda g: mu(g) - 1.0, G, G * step, xtol=1e-14, rtol=1e-15)


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _encode_flat(layer):
    return {"inputs": dict(layer._inputs), "e": layer.e, "t0": layer.t0}


def _decode_flat(data):
    layer = FlatLayer(**data["inputs"])
    if layer.e != data["e"] or layer.t0 != data["t0"]:
        raise ValueError(f"inconsistent: the stored layer has e = {data['e']!r}, t0 = {data['t0']!r}, its "
                         f"inputs give e = {layer.e!r}, t0 = {layer.t0!r}")
    return layer


archive.register("FlatLayer", FlatLayer, encode=_encode_flat, decode=_decode_flat)
