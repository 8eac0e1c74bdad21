r"""Independent checks of the flat layer's sticking, touch-and-go and chatter orbits.

The reference here shares no code with :mod:`tps_solver.model.sticking`:

* the ball is integrated in ``mpmath`` (``dps`` 30 for ``e = 0``, 50 with
  chatter) with the flight in the paper's *first* form of (17)-(18),
  :math:`\zeta = (v + \cos a)(t - a) + \sin a - \sin t - (t - a)^2/2\Gamma`;
* a landing is located by dense sampling of :math:`\zeta` (step ``2e-3``, or
  1/50 of the constant-g estimate :math:`2v/|g|` for short bounces) and
  refined by the bracketing ``illinois`` solver (bisection if it leaves its
  bracket) at full precision (no monotone-piece argument, no Newton polish);
* a chatter sequence is followed bounce by bounce until the rebound speed is
  below ``1e-18``; only then is the rest added as :math:`2v/(|g|(1-e))`
  (its error, :math:`O(v^2)`, is ~1e-36);
* Fourier coefficients are QUADPACK integrals (``scipy.integrate.quad``) of
  the reference's own piecewise velocity, segment by segment.

``main()`` prints the markdown tables (accuracy at Gamma = 3.9, 4.1, 4.4 with
e = 0 and at Gamma = 4.4 with e = 0.1; where the sticking f/2 orbit exists at
M = 2) quoted in the report.  Run ``python -m validation.flat_sticking`` from
the repository root.
"""
import math

import mpmath as mp
import numpy as np
from scipy import integrate

import tps_solver as tps
from tps_solver.model.sticking import sticking_orbit, touch_orbits

__all__ = ["reference_orbit", "reference_touch_landings", "reference_height", "reference_velocity", "quad_harmonics",
           "measure", "accuracy_table", "pattern_scan", "pattern_boundaries", "sequence_changes",
           "touch_window", "main"]


# ----------------------------------------------------------------------------- reference ball

def _z(a, v, G, t):
    return (v + mp.cos(a)) * (t - a) + mp.sin(a) - mp.sin(t) - (t - a) ** 2 / (2 * G)


def _w(a, v, G, t):
    return v + mp.cos(a) - mp.cos(t) - (t - a) / G


def _bracketed_root(f, lo, hi):
    """Root of f in [lo, hi] with f(lo) > 0 >= f(hi): illinois, or bisection if it leaves the bracket."""
    try:
        r = mp.findroot(f, (lo, hi), solver="illinois")
        if lo <= r <= hi:
            return r
    except (ValueError, ZeroDivisionError):
        pass
    tol = mp.mpf(10) ** (-mp.mp.dps + 2) * max(1, abs(hi))
    while hi - lo > tol:
        mid = (lo + hi) / 2
        if f(mid) > 0:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def _landing(a, v, G, horizon):
    """First t in (a, a + horizon] with zeta = 0, by dense sampling + illinois (mpmath)."""
    g_a = mp.sin(a) - 1 / G
    if v > 0 and g_a < 0 and 2 * v / -g_a < 0.2:      # a short bounce: sample in mpmath
        h = 2 * v / -g_a / 50
        ts = [a + i * h for i in range(1, 201)]       # up to 4x the constant-g estimate
        zs = [_z(a, v, G, t) for t in ts]
    else:                                             # sample in floating point, step 2e-3
        h = 2e-3
        tf = float(a) + h * np.arange(1, int(float(horizon) / h) + 2)
        af, vf, Gf = float(a), float(v), float(G)
        zf = (vf + math.cos(af)) * (tf - af) + math.sin(af) - np.sin(tf) - (tf - af) ** 2 / (2 * Gf)
        hit = np.nonzero(zf <= 0)[0]
        if hit.size == 0:
            return None
        i = int(hit[0])
        if i == 0:
            raise RuntimeError("reference: zeta <= 0 at the first sample (step too coarse)")
        ts = [a + (i) * h, a + (i + 1) * h]           # the bracket, re-checked in mpmath
        zs = [_z(a, v, G, t) for t in ts]
        if not (zs[0] > 0 >= zs[1]):
            raise RuntimeError("reference: float bracket not confirmed in mpmath")
    for (t1, z1), (t2, z2) in zip(zip(ts[:-1], zs[:-1]), zip(ts[1:], zs[1:])):
        if z1 > 0 >= z2:
            return _bracketed_root(lambda s: _z(a, v, G, s), t1, t2)
    if zs[0] <= 0:
        raise RuntimeError("reference: zeta <= 0 at the first sample (step too coarse)")
    return None


def reference_orbit(Gamma, e, M=2, dps=None, v_stop="1e-18", t_start=None, v_start=0.0):
    r"""One period of the orbit through a lift-off, in mpmath.

    Parameters
    ----------
    Gamma : float
    e : float
        Restitution in [0, 1).
    M : int
    dps : int, optional
        Working precision (default 30 for ``e = 0``, 50 otherwise).
    v_stop : str
        Rebound speed below which a chatter sequence is summed.
    t_start, v_start : float, optional
        Start from a launch at ``t_start`` (default: the lift-off phase) with
        velocity ``v_start`` (default 0) instead; used to perturb the orbit.

    Returns
    -------
    events : list of (mpf, str)
        ``(t, kind)`` from the lift-off ``t0 = asin(1/Gamma)`` to the next
        lift-off (included).
    flights : list of (mpf, mpf, mpf)
        ``(a, b, v)``: launch time, landing time, launch velocity.
    """
    dps = dps or (30 if e == 0 else 50)
    with mp.workdps(dps):
        G, e_mp = mp.mpf(Gamma), mp.mpf(e)
        base = mp.asin(1 / G)
        t = base if t_start is None else mp.mpf(t_start)
        v = mp.mpf(v_start)
        events, flights = [(t, "liftoff")], []
        while True:
            b = _landing(t, v, G, 2 * mp.pi * (M + 2) - (t - events[0][0]))
            if b is None:
                raise RuntimeError("reference: no landing within the horizon")
            flights.append((t, b, v))
            wm = _w(t, v, G, b)
            events.append((b, "impact"))
            gb = mp.sin(b) - 1 / G
            v = -e_mp * wm
            if v == 0 or (gb < 0 and v < mp.mpf(v_stop)):
                if gb > 0 and v == 0:
                    events.append((b, "liftoff"))
                    t = b
                    continue
                ts = b + (2 * v / (-gb * (1 - e_mp)) if v > 0 else 0)
                events.append((ts, "stick"))
                k = mp.ceil((ts - base) / (2 * mp.pi))
                events.append((base + 2 * mp.pi * k, "liftoff"))
                return events, flights
            t = b


def reference_touch_landings(Gamma, t_start, n, dps=30):
    """The first ``n`` landing times of successive flights from rest (e = 0, no stick check), in mpmath."""
    with mp.workdps(dps):
        G, t, out = mp.mpf(Gamma), mp.mpf(t_start), []
        for _ in range(n):
            t = _landing(t, mp.mpf(0), G, 6 * mp.pi)
            if t is None:
                raise RuntimeError("reference: no landing within 3 periods")
            out.append(t)
        return out


def _evaluate(flights, Gamma, t, f):
    out = []
    for x in np.atleast_1d(t):
        x = mp.mpf(float(x))
        val = mp.mpf(0)
        for a, b, v in flights:
            if a <= x < b:
                val = f(a, v, mp.mpf(Gamma), x)
                break
        out.append(val)
    return out


def reference_height(flights, Gamma, t):
    """Height of the reference orbit at times ``t`` (floats in its period), in mpmath (50 digits)."""
    with mp.workdps(50):
        return _evaluate(flights, Gamma, t, _z)


def reference_velocity(flights, Gamma, t):
    """Velocity of the reference orbit at times ``t`` (0 outside flights), in mpmath (50 digits)."""
    with mp.workdps(50):
        return _evaluate(flights, Gamma, t, _w)


def quad_harmonics(flights, Gamma, M, N):
    r"""QUADPACK Fourier coefficients :math:`T^{-1}\int w e^{-in t/M} dt` of the reference, n = -N..N."""
    T = 2 * math.pi * M
    c = np.zeros(2 * N + 1, dtype=complex)
    segs = [(float(a), float(b), float(v)) for a, b, v in flights]
    for j, n in enumerate(range(-N, N + 1)):
        nu = n / M
        re = im = 0.0
        for a, b, v in segs:
            def w(t, a=a, v=v):
                return v + math.cos(a) - math.cos(t) - (t - a) / Gamma
            re += integrate.quad(lambda t: w(t) * math.cos(nu * t), a, b, epsabs=1e-13, epsrel=1e-13,
                                 limit=200)[0]
            im -= integrate.quad(lambda t: w(t) * math.sin(nu * t), a, b, epsabs=1e-13, epsrel=1e-13,
                                 limit=200)[0]
        c[j] = complex(re, im) / T
    return c


# ----------------------------------------------------------------------------- measured errors

def measure(Gamma, e, M=2, N=16, n_samples=2001):
    """Errors of ``FlatLayer(Gamma, M, e, pattern="stick")`` against the mpmath reference.

    Returns
    -------
    row : dict
        ``event_err`` (max over the events FlatLayer lists, matched in order
        against the reference; a chatter's summed tail is matched to the
        reference's stick), ``height_err`` and ``velocity_err`` (max over
        ``n_samples`` times in the period), ``harmonics_err`` (max over
        n = -N..N against QUADPACK on the reference), ``chatter_bound``,
        the contact sequence and the event counts.
    """
    fl = tps.FlatLayer(Gamma, M, e=e, pattern="stick")
    ref_events, flights = reference_orbit(Gamma, e, M)
    mine = fl.events
    ref = ref_events[:-1]                       # drop the next period's lift-off
    errs = []
    ref_impacts = [t for t, k in ref if k == "impact"]
    my_impacts = [t for t, k in mine if k == "impact"]
    for a, b in zip(my_impacts, ref_impacts):
        errs.append(abs(a - float(b)))
    for kind in ("stick", "liftoff"):
        for a, b in zip([t for t, k in mine if k == kind], [t for t, k in ref if k == kind]):
            errs.append(abs(a - float(b)))
    errs.append(abs(fl.t0 + fl.period - float(ref_events[-1][0])))
    t = fl.t0 + fl.period * (np.arange(n_samples) + 0.5) / n_samples
    zr = np.array([float(z) for z in reference_height(flights, Gamma, t)])
    wr = np.array([float(w) for w in reference_velocity(flights, Gamma, t)])
    h_mine = fl.harmonics(N)
    h_ref = quad_harmonics(flights, Gamma, M, N)
    return dict(Gamma=Gamma, e=e, M=M, pattern=fl.pattern, sequence=fl.contact_sequence,
                n_events=len(mine), n_ref_impacts=len(ref_impacts),
                event_err=max(errs), height_err=float(np.max(np.abs(fl.height(t) - zr))),
                velocity_err=float(np.max(np.abs(fl.velocity(t) - wr))),
                harmonics_err=float(np.max(np.abs(h_mine - h_ref))),
                chatter_bound=fl.chatter_error, multipliers=fl.floquet_multipliers())


def accuracy_table(cases=((3.9, 0.0), (4.1, 0.0), (4.4, 0.0), (4.4, 0.1)), M=2, N=16):
    """Rows of :func:`measure` for the given (Gamma, e)."""
    return [measure(G, e, M, N) for G, e in cases]


# ----------------------------------------------------------------------------- where the orbit exists

def _stick_period(Gamma, e):
    """Period (in forcing periods) of the orbit through a lift-off, or None if it never sticks again."""
    for k in range(1, 9):
        orb, info = sticking_orbit(Gamma, e, k, search_periods=0)
        if orb is not None:
            return k
        if "period 2*pi*" in info:
            return int(info.split("period 2*pi*")[1].split()[0])
    return None


def pattern_scan(e, M=2, Gammas=None):
    """For each Gamma: the period of the lift-off orbit and the touch-and-go f/M orbits (e = 0).

    Returns
    -------
    rows : list of dict
        ``Gamma``, ``stick_period`` (None: no return to a stick within 8
        periods), ``touch`` (list of multipliers of touch-and-go f/M orbits).
    """
    Gammas = np.arange(1.05, 8.0, 0.05) if Gammas is None else Gammas
    rows = []
    for G in Gammas:
        touch = [complex(o.multipliers[0]) for o in touch_orbits(G, M)] if e == 0 else []
        rows.append(dict(Gamma=float(G), stick_period=_stick_period(G, e), touch=touch))
    return rows


def _bisect(pred, a, b, tol=1e-12):
    """Boundary between pred(a) and not pred(a) on [a, b] by bisection."""
    pa = pred(a)
    if pred(b) == pa:
        raise ValueError("no change of the predicate on the interval")
    while b - a > tol * max(1.0, abs(a)):
        c = 0.5 * (a + b)
        if pred(c) == pa:
            a = c
        else:
            b = c
    return 0.5 * (a + b)


def pattern_boundaries(e, M=2, Gammas=None):
    """Gamma intervals in which the lift-off orbit has period M, with bisected ends.

    Returns
    -------
    intervals : list of (float, float, str, str)
        ``(low, high, below, above)``: the ends and the lift-off orbit's
        period just outside (``"none"``: no return to a stick within 8 periods).
    rows : list of dict
        The scan (see :func:`pattern_scan`).
    """
    rows = pattern_scan(e, M, Gammas)

    def pred(G):
        return _stick_period(G, e) == M

    out = []
    flags = [r["stick_period"] == M for r in rows]
    i = 0
    while i < len(rows):
        if not flags[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(rows) and flags[j + 1]:
            j += 1
        lo = _bisect(pred, rows[i - 1]["Gamma"], rows[i]["Gamma"]) if i > 0 else rows[i]["Gamma"]
        hi = _bisect(pred, rows[j]["Gamma"], rows[j + 1]["Gamma"]) if j + 1 < len(rows) else rows[j]["Gamma"]
        below = _stick_period(lo * (1 - 1e-9), e)
        above = _stick_period(hi * (1 + 1e-9), e)
        out.append((lo, hi, str(below or "none"), str(above or "none")))
        i = j + 1
    return out, rows


def sequence_changes(e, lo, hi, M=2, n=60):
    """Gamma values in [lo, hi] where the sticking orbit's contact sequence changes, by bisection.

    Returns
    -------
    changes : list of (float, str, str)
        ``(Gamma, sequence below, sequence above)``.
    """
    def seq(G):
        return tps.FlatLayer(G, M, e=e, pattern="stick").contact_sequence

    grid = np.linspace(lo, hi, n)
    seqs = [seq(G) for G in grid]
    out = []
    for a, b, sa, sb in zip(grid[:-1], grid[1:], seqs[:-1], seqs[1:]):
        if sa != sb:
            G = _bisect(lambda x: seq(x) == sa, a, b)
            out.append((G, sa, sb))
    return out


def touch_window(M=2, lo=3.6, hi=4.0):
    """Gamma range of the touch-and-go f/M orbit (e = 0) near sqrt(pi^2 + 4), by bisection on existence."""
    def exists(G):
        return any(abs(m) < 1 for m in (o.multipliers[0] for o in touch_orbits(G, M)))

    grid = np.linspace(lo, hi, 41)
    flags = [exists(G) for G in grid]
    ends = []
    for a, b, fa, fb in zip(grid[:-1], grid[1:], flags[:-1], flags[1:]):
        if fa != fb:
            ends.append(_bisect(exists, a, b, tol=1e-10))
    return ends


# ----------------------------------------------------------------------------- report

def _fmt(x):
    return f"{x:.2e}"


def main():
    """Print the markdown tables of this module."""
    print("### Sticking orbits of the flat layer against an mpmath ball (M = 2)\n")
    print("| Gamma | e | contacts | events | ref. impacts | event times | height | velocity | "
          "harmonics (N=16) vs quad | chatter bound |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in accuracy_table():
        print(f"| {r['Gamma']} | {r['e']} | {r['sequence']} | {r['n_events']} | {r['n_ref_impacts']} | "
              f"{_fmt(r['event_err'])} | {_fmt(r['height_err'])} | {_fmt(r['velocity_err'])} | "
              f"{_fmt(r['harmonics_err'])} | {_fmt(r['chatter_bound'])} |")
    print()
    print("### Where the sticking f/2 orbit exists (M = 2)\n")
    print("Scan of Gamma in [1.05, 8) with step 0.05 (windows narrower than the step can be missed), "
          "ends bisected to 1e-12 on 'the orbit through a lift-off returns to rest after exactly "
          "2 periods'.\n")
    print("| e | Gamma low | Gamma high | lift-off orbit period below / above (in 2 pi) | "
          "contact-sequence changes inside |")
    print("|---|---|---|---|---|")
    for e in (0.0, 0.05, 0.1, 0.2, 0.3):
        ints, _ = pattern_boundaries(e, 2)
        for lo, hi, below, above in ints:
            ch = sequence_changes(e, lo * (1 + 1e-9), hi * (1 - 1e-9))
            chs = "; ".join(f"{a} -> {b} at {G:.10f}" for G, a, b in ch) or "none"
            print(f"| {e} | {lo:.10f} | {hi:.10f} | {below} / {above} | {chs} |")
    print()
    ends = touch_window(2)
    print(f"Touch-and-go f/2 orbit (e = 0, contacts TT): exists and is stable for Gamma in "
          f"{', '.join(f'{x:.10f}' for x in ends)} (ends bisected on existence with |multiplier| < 1); "
          f"sqrt(pi^2 + 4) = {math.sqrt(math.pi ** 2 + 4):.10f}, sqrt(pi^2 + 1) = "
          f"{math.sqrt(math.pi ** 2 + 1):.10f}.")


if __name__ == "__main__":
    main()
