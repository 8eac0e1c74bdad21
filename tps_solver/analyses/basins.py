r"""Basins of attraction of the flat layer: one node, the bouncing ball, point or soft contact.

A flat layer is a single column of the FDA (53) with no coupling: the bouncing
ball of Luck & Mehta in the plate frame, :math:`\ddot\zeta = g(t) = \sin t -
1/\Gamma` (16) in flight.  It is multistable (docs/design.md, hazard 9): besides
the flat orbit of period :math:`T = 2\pi M` (17)-(19) it has chatter-and-stick
cycles and irregular motion.  :func:`flat_basins` measures the fraction of
random initial states that reach each attractor.

Models (the rules of :func:`tps_solver.simulate` for a uniform state)
----------------------------------------------------------------------
``model="point"``
    Restitution (11): :math:`w^+ = -e\,w^-`.  An impact slower than
    ``stick_velocity`` (the tail of a chatter sequence), or any impact when
    :math:`e = 0`, ends at rest; the ball then *sticks* while
    :math:`g \le 0` and lifts off when :math:`g` turns positive.
``model="soft"``
    The soft contact of cut-off length :math:`\ell` (``cutoff``): while
    :math:`\zeta < 0` the ball obeys
    :math:`\ddot\zeta + 2\beta\dot\zeta + \omega_0^2\zeta = 0` with
    :math:`\tau_c = \ell^2`, :math:`\omega_d = \pi/\tau_c`,
    :math:`\beta = -\ln e/\tau_c`, so every contact lasts exactly
    :math:`\tau_c` and returns :math:`w^+ = -e\,w^-`.  Needs :math:`e > 0`
    (:math:`\beta` is singular at :math:`e = 0`) (docs/design.md, hazard 11).
    This is the model of ``simulate(..., method="soft-radau")``, which has no
    sticking rule: a ball micro-chatters through a sticking phase (each
    contact lasts :math:`\tau_c`, speeds fall by :math:`e` per contact) and
    leaves at the end of the contact in progress when :math:`g` turns
    positive, so sticking does not reset it.  ``soft_sticking=True`` adds the
    rule (docs/design.md, hazard 10): an entry at or below ``stick_velocity``
    ends at rest, held while :math:`g \le 0`.

Integrators
-----------
``integrator="closed_form"`` (default) propagates the ball exactly: flights in
closed form (the height written with :math:`1-\cos\Delta` and
:math:`\sin\Delta - \Delta` so that short chatter flights keep their relative
precision), the next impact as the first root of the height on pieces where it
is monotone (split at the zeros of :math:`g` and of :math:`w`), contacts in
closed form.  ``integrator="simulate"`` runs :func:`tps_solver.simulate`
(``method="exact"`` or ``method="soft-radau"``) on a uniform 3-node Neumann lattice,
whose coupling vanishes on a uniform state; it is the cross-check (the tests
compare the two) and the place where a faster soft integrator plugs in.

Classification
--------------
Every sample starts at :math:`t_s` = ``t_section`` from a state drawn uniformly
from the box ``w_range`` x ``zeta_range`` (a free ball), and is followed through
the stroboscopic map :math:`P` over one forcing cycle :math:`2\pi`
(:math:`x_k` = the state :math:`(w, \zeta)` and the contact mode at
:math:`t_s + 2\pi k`).  After each cycle the smallest period
:math:`p \le` ``p_max`` with :math:`\max_{0\le j<p}|x_{k-j} - x_{k-j-p}|_\infty
<` ``tol`` (and equal modes) is sought: a full cycle has repeated.  A sample
with none within ``periods`` periods :math:`T` is *irregular* (chaotic,
quasi-periodic, or a transient slower than that).  Cycles of two samples are
one attractor if they have the same period and their points coincide within
``1e-5`` up to a cyclic shift; the shift gives the sample's *phase* (which
point it occupies at :math:`t_s + 2\pi k`, :math:`k \equiv 0 \bmod p`), so the
two phases of the flat orbit, the two sides of a kink, are counted separately
in ``phase_counts``.

For each attractor, a representative point is polished by Newton's method on
:math:`P^p(x) = x` and the *multipliers* are the eigenvalues of the central
finite-difference Jacobian of :math:`P^p` (step ``1e-6``).  Where the cycle
sticks to the plate the map resets and the multipliers are 0.  ``smooth``
says whether the forward and backward one-sided Jacobians agree (to 1e-4); if
not, the map is not differentiable there (a grazing or a sticking threshold)
and the multipliers are an average of two one-sided derivatives.  Fractions
carry the binomial standard error :math:`\sqrt{f(1-f)/n}` and a 95% Wilson
interval (meaningful also at :math:`f = 0` or 1).
"""
import contextlib
import functools
import math
import signal
import threading
import time

import numpy as np

from tps_solver.core import archive
from tps_solver.core.bunch import Bunch
from tps_solver.core.costs import check_cost
from tps_solver.core.newton import newton
from tps_solver.core.problem import Inadmissible, Problem
from tps_solver.model.restitution import RestitutionLaw, as_restitution
from tps_solver.core.checks import check_array, check_choice, check_int, check_positive, check_real, check_restitution
from tps_solver.solvers.shooting.floquet import multipliers as floquet_multipliers
from tps_solver.model.ball import CONTACT, FREE, MODE_NAMES, STUCK, ClosedFormBall

__all__ = ["flat_basins", "BasinResult", "ball_cycle"]

MODELS = ("point", "soft")
INTEGRATORS = ("closed_form", "simulate")
ENGINES = ("auto", "compiled", "reference")
_CHUNK = 64                  # samples per call of the compiled ensemble (progress and Ctrl-C between calls)
_TWO_PI = 2.0 * math.pi
_MATCH_TOL = 1e-5
_FD_STEP = 1e-6
_Z95 = 1.959963984540054


class BasinResult(Bunch):
    """Result of :func:`flat_basins`.

    Attributes
    ----------
    attractors : list of Bunch
        By decreasing count.  Each has ``label`` (str, e.g. ``"f/2"``,
        ``"f/10 (17 impacts, 1 stick)"``), ``period`` (int, forcing cycles
        :math:`2\\pi`), ``period_T`` (float, in periods :math:`T`),
        ``impacts``, ``sticks`` (int, per period of the attractor),
        ``count``, ``fraction``, ``stderr``, ``interval`` (95% Wilson),
        ``points`` (ndarray of float, shape (period, 2): :math:`(w, \\zeta)` at
        :math:`t_s + 2\\pi j`, polished), ``modes`` (list of str),
        ``multipliers`` (ndarray of complex, shape (2,), by decreasing
        modulus), ``smooth`` (bool), ``stable`` (bool), ``residual`` (float,
        :math:`|P^p(x) - x|_\\infty` at the polished point), ``phase_counts``
        (ndarray of int, shape (period,)), ``is_flat`` (bool: the f/M state,
        period ``M`` forcing cycles whatever its contact pattern; at small
        ``e`` it chatters and sticks once per period) and ``mean_transient``
        (float, cycles until the cycle repeated).
    fractions, stderr : dict
        Label -> fraction of the samples and its binomial standard error,
        including ``"irregular"`` (and ``"failed"`` if any sample failed).
    irregular : Bunch
        ``count``, ``fraction``, ``stderr``, ``interval``, and
        ``near_periods``: dict p -> (count, median return distance) of the
        irregular samples by the period p <= ``p_max`` that comes closest to
        repeating over the last cycles (a noisy cycle shows a small distance).
    flat_fraction, flat_stderr : float
        Fraction of samples reaching an f/M state (``is_flat``), and its
        binomial standard error.
    labels : ndarray of int, shape (n_samples,)
        Attractor index per sample; -1 irregular, -2 failed.
    phases : ndarray of int, shape (n_samples,)
        The sample's phase on its attractor (-1 if none).
    n_cycles : ndarray of int, shape (n_samples,)
        Forcing cycles integrated per sample.
    initial_states : ndarray of float, shape (n_samples, 2)
        :math:`(w_0, \\zeta_0)` at ``t_section``.
    converged : bool
        True if every sample reached a cycle of period <= ``p_max``.
    status : int
        A code of :data:`tps_solver.STATUS`: 0 all classified; 1 some irregular after ``periods``;
        6 some integrations failed (event bound: chatter).
    message : str

    Examples
    --------
    At Gamma = 4.1, e = 0 every sample ends on the flat state, the f/2 orbit with one
    touch-and-go and one stick per period (:func:`tps_solver.model.sticking.sticking_orbit`):

    >>> res = flat_basins(4.1, 0.0, M=2, n_samples=4, seed=1, periods=40)
    >>> type(res).__name__, res.status, res.fractions, res.labels.tolist()
    ('BasinResult', 0, {'f/2 (1 impact, 1 stick)': 1.0, 'irregular': 0.0}, [0, 0, 0, 0])
    >>> res.flat_fraction, res.attractors[0].is_flat, res.attractors[0].period
    (1.0, True, 2)
    """

    def save(self, path):
        """Write the result to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return archive.save(self, path)


def _validate_basins(f):
    n = f.int("n_samples", minimum=1)
    f.array("labels", "iu", shape=(n,))
    f.array("initial_states", "f", shape=(n, 2), finite=True)
    f.float("Gamma")
    if not isinstance(f.get("e"), RestitutionLaw):
        f.float("e")


archive.register("BasinResult", BasinResult, validate=_validate_basins)


class _SimulateBall:
    """The same map through :func:`tps_solver.simulate` on a uniform 3-node lattice."""

    def __init__(self, Gamma, e, model, cutoff, stick_velocity, max_events, soft_sticking=False):
        from tps_solver.operators.lattice import Lattice
        self.Gamma, self.e, self.model, self.cutoff = Gamma, e, model, cutoff
        self.stick_velocity, self.max_events = stick_velocity, max_events
        self.lattice = Lattice.planar(n_nodes=3, length=100.0)

    def cycle(self, t_section, state, events=None):
        from tps_solver.solvers.fda import simulate
        w, z, mode = state
        kw = dict(t_start=t_section, t_end=t_section + _TWO_PI)
        if self.model == "soft":
            run = simulate(self.lattice, self.Gamma, self.e, np.full(3, w), np.full(3, z), method="soft-radau",
                           cutoff=self.cutoff, **kw)
        else:
            run = simulate(self.lattice, self.Gamma, self.e, np.full(3, w), np.full(3, z), method="exact",
                           stuck0=np.full(3, mode == STUCK), stick_velocity=self.stick_velocity,
                           max_events_per_cycle=3 * self.max_events, **kw)
        if not run.success:
            raise RuntimeError(run.message)
        if events is not None:
            for ev in run.events[run.events.node == 0]:
                events.append((float(ev.t), str(ev.kind)))
        w, z = float(run.w[0]), float(run.zeta[0])
        if self.model == "soft":
            return w, z, CONTACT if z < 0.0 else FREE
        return w, z, STUCK if run.stuck[0] else FREE


def _make_ball(Gamma, e, model, cutoff, stick_velocity, max_events, integrator, soft_sticking=False):
    cls = ClosedFormBall if integrator == "closed_form" else _SimulateBall
    return cls(Gamma, e, model, cutoff, stick_velocity, max_events, soft_sticking)


def ball_cycle(Gamma, e, w0, zeta0, n_cycles=1, t_section=0.0, *, model="point", cutoff=None, stuck=False,
               stick_velocity=1e-6, integrator="closed_form"):
    r"""Stroboscopic states of one node (the bouncing ball) at ``t_section + 2*pi*k``.

    Parameters
    ----------
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in [0, 1) (in (0, 1) for ``model="soft"``).
    w0, zeta0 : float
        State at ``t_section`` (``zeta0 >= 0`` for point impacts; < 0 is in
        contact for the soft model).
    n_cycles : int
        Forcing cycles :math:`2\pi`, >= 1.
    t_section : float
    model : {"point", "soft"}
    cutoff : float, optional
        Soft-contact length :math:`\ell` (``model="soft"`` only).
    stuck : bool
        Start stuck to the plate (point impacts, ``w0 = zeta0 = 0``).
    stick_velocity : float
        Impact speed at or below which a point impact ends at rest.
    integrator : {"closed_form", "simulate"}

    Returns
    -------
    states : ndarray of float, shape (n_cycles + 1, 2)
        :math:`(w, \zeta)` at ``t_section + 2*pi*k``, k = 0..n_cycles.
    events : list of (float, str)
        Times (as if the run were continuous) and kinds ("impact", "stick", "liftoff").

    Examples
    --------
    >>> import tps_solver as tps
    >>> fl = tps.FlatLayer(2.5, 2, 0.45)
    >>> ts = fl.t0 + 1.0
    >>> x, ev = ball_cycle(2.5, 0.45, fl.velocity(ts), fl.height(ts), n_cycles=2, t_section=ts)
    >>> bool(np.allclose(x[2], x[0], atol=1e-12)), [kind for _, kind in ev]
    (True, ['impact'])
    """
    Gamma, e, model, cutoff = _check_model(Gamma, e, model, cutoff)
    n_cycles = check_int(n_cycles, "n_cycles", minimum=1)
    t_section = check_real(t_section, "t_section")
    w0, zeta0 = check_real(w0, "w0"), check_real(zeta0, "zeta0")
    if model == "point" and zeta0 < 0.0:
        raise ValueError(f"zeta0 must be >= 0 for point impacts, got {zeta0}")
    if stuck and (w0 != 0.0 or zeta0 != 0.0 or model != "point"):
        raise ValueError("stuck=True needs model='point' and w0 = zeta0 = 0")
    integrator = check_choice(integrator, "integrator", INTEGRATORS)
    ball = _make_ball(Gamma, e, model, cutoff, float(stick_velocity), 10000, integrator)
    mode = STUCK if stuck else (CONTACT if zeta0 < 0.0 else FREE)
    state = (w0, zeta0, mode)
    out, events = [(w0, zeta0)], []
    for k in range(n_cycles):
        cyc = []
        state = ball.cycle(t_section, state, cyc)
        events += [(t + _TWO_PI * k, kind) for t, kind in cyc]
        out.append(state[:2])
    return np.array(out), events


# ------------------------------------------------------------- classification
def _dist(x, y):
    if x[2] != y[2]:
        return math.inf
    return max(abs(x[0] - y[0]), abs(x[1] - y[1]))


#: Strobe points closer than this are one point of a cycle that has not converged yet.
_CONVERGING = 1e-3


def _near_period(states, p_max):
    """Smallest p whose return distance (w, zeta only) is within twice the best, and that distance."""
    K = len(states) - 1
    d = []
    for p in range(1, min(p_max, K // 2) + 1):
        d.append(max(max(abs(states[K - j][0] - states[K - j - p][0]), abs(states[K - j][1] - states[K - j - p][1]))
                     for j in range(p)))
    best = min(d)
    p = next(i for i, v in enumerate(d) if v <= 2.0 * best) + 1
    return p, float(d[p - 1])


def _basin_sample(Gamma, e, model, cutoff, w0, zeta0, t_section, p_max, max_cycles, tol, stick_velocity,
                  integrator, max_events, soft_sticking=False):
    """Follow one sample to its cycle (module docstring); a picklable sweep task."""
    ball = _make_ball(Gamma, e, model, cutoff, stick_velocity, max_events, integrator, soft_sticking)
    states = [(w0, zeta0, FREE)]
    counts = []
    try:
        for k in range(1, max_cycles + 1):
            ev = []
            states.append(ball.cycle(t_section, states[-1], ev))
            counts.append((sum(kind == "impact" for _, kind in ev), sum(kind == "stick" for _, kind in ev)))
            for p in range(1, min(p_max, k // 2) + 1):
                if all(_dist(states[k - j], states[k - j - p]) < tol for j in range(p)):
                    if any(p % d == 0 and all(_dist(states[k - j], states[k - j - d]) < _CONVERGING
                                              for j in range(d)) for d in range(1, p)):
                        # a shorter cycle is still converging (e.g. an f/1 orbit with a multiplier
                        # near -1 repeats after 2 cycles first): follow it until it repeats itself
                        continue
                    pts = states[k - p + 1:k + 1]
                    imp = sum(c[0] for c in counts[k - p:k])
                    stk = sum(c[1] for c in counts[k - p:k])
                    return dict(status="periodic", period=p, n_cycles=k, first_index=k - p + 1,
                                points=[tuple(map(float, s[:2])) + (int(s[2]),) for s in pts],
                                impacts=int(imp), sticks=int(stk), message="")
    except RuntimeError as exc:
        return dict(status="failed", period=0, n_cycles=len(states) - 1, first_index=0, points=[],
                    impacts=0, sticks=0, message=str(exc))
    near, dist = _near_period(states, p_max)
    return dict(status="irregular", period=0, n_cycles=max_cycles, first_index=0,
                points=[tuple(map(float, states[-1][:2])) + (int(states[-1][2]),)], impacts=0, sticks=0,
                message="", near_period=near, near_distance=dist)


def _compiled_samples(Gamma, e, w0, zeta0, t_section, p_max, max_cycles, tol, stick_velocity, max_events,
                      progress):
    """The samples of :func:`_basin_sample`, as one compiled ensemble (:mod:`tps_solver.model.ball_kernel`).

    Returns the list of sample dicts, ``None`` where Ctrl-C stopped the run first."""
    from tps_solver.core.progress import Progress
    from tps_solver.model.ball_kernel import basin_ensemble

    n = w0.size
    out = [None] * n
    with Progress("flat_basins", total=n, enabled=progress is not False, unit="sample") as bar, \
            _deferred_sigint() as interrupted:
        for start in range(0, n, _CHUNK):
            if interrupted():
                break
            sl = slice(start, min(n, start + _CHUNK))
            states, status, info, t_fail = basin_ensemble(Gamma, e, stick_velocity, t_section, w0[sl], zeta0[sl],
                                                          max_cycles, p_max, tol, _CONVERGING, max_events)
            for i in range(states.shape[0]):
                out[start + i] = _sample_dict(states[i], status[i], info[i], t_fail[i], max_cycles, p_max,
                                              max_events)
            bar.update(states.shape[0])
    return out


def _sample_dict(states, status, info, t_fail, max_cycles, p_max, max_events):
    """One compiled sample as the dict of :func:`_basin_sample`."""
    period, k, first, imp, stk = (int(v) for v in info)
    if status == 0:
        pts = states[k - period + 1:k + 1]
        return dict(status="periodic", period=period, n_cycles=k, first_index=first,
                    points=[(float(q[0]), float(q[1]), int(q[2])) for q in pts], impacts=imp, sticks=stk,
                    message="")
    if status == 2:
        return dict(status="failed", period=0, n_cycles=k, first_index=0, points=[], impacts=0, sticks=0,
                    message=f"more than {max_events} events in one forcing cycle near t = {float(t_fail):.12g}")
    near, dist = _near_period(states, p_max)
    q = states[-1]
    return dict(status="irregular", period=0, n_cycles=max_cycles, first_index=0,
                points=[(float(q[0]), float(q[1]), int(q[2]))], impacts=0, sticks=0, message="",
                near_period=near, near_distance=dist)


@contextlib.contextmanager
def _deferred_sigint():
    """Ctrl-C during compiled calls: noted and acted on between calls (yields ``interrupted()``).

    A KeyboardInterrupt raised while a compiled kernel runs surfaces as a ``SystemError`` from the
    dispatcher, so in the main thread SIGINT only sets a flag here (the previous handler is
    restored on exit); elsewhere signals cannot be caught and nothing changes."""
    flag = []
    if threading.current_thread() is not threading.main_thread():
        yield lambda: False
        return
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, lambda signum, frame: flag.append(signum))
    try:
        yield lambda: bool(flag)
    finally:
        signal.signal(signal.SIGINT, previous)


def _period_map(ball, t_section, x, p):
    s = x
    for _ in range(p):
        s = ball.cycle(t_section, s)
    return s


def _jacobian(ball, t_section, x, p, h):
    """Central, forward and backward FD Jacobians of P^p at x (mode kept)."""
    base = _period_map(ball, t_section, x, p)
    Jc, Jf, Jb = np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2))
    for i in range(2):
        xp, xm = list(x), list(x)
        xp[i] += h
        xm[i] -= h
        fp = _period_map(ball, t_section, tuple(xp), p)
        fm = _period_map(ball, t_section, tuple(xm), p)
        for j in range(2):
            Jc[j, i] = (fp[j] - fm[j]) / (2 * h)
            Jf[j, i] = (fp[j] - base[j]) / h
            Jb[j, i] = (base[j] - fm[j]) / h
    return Jc, Jf, Jb, base


class _CyclePolish(Problem):
    """P^p(x) - x for the strobe point x = (w, zeta) of a p-cycle, its mode held fixed; steps that
    leave the mode's admissible set or move more than the matching tolerance are refused."""

    def __init__(self, ball, t_section, p, mode):
        self.ball, self.t_section, self.p, self.mode = ball, t_section, p, mode

    def residual(self, x):
        q = (float(x[0]), float(x[1]), self.mode)
        f = _period_map(self.ball, self.t_section, q, self.p)
        if f[2] != self.mode:
            return np.full(2, np.inf), f
        return np.array([f[0] - q[0], f[1] - q[1]]), f

    def jacobian(self, x, F, data):
        q = (float(x[0]), float(x[1]), self.mode)
        return _jacobian(self.ball, self.t_section, q, self.p, _FD_STEP)[0] - np.eye(2)

    def limit_step(self, x, dx):
        if float(np.max(np.abs(dx))) > _MATCH_TOL:
            raise Inadmissible(f"step {float(np.max(np.abs(dx))):.2g} > the matching tolerance {_MATCH_TOL:g}")
        return dx

    def project(self, x):
        if not _admissible((float(x[0]), float(x[1]), self.mode)):
            raise Inadmissible("the step leaves the mode of the strobe point")
        return x


def _admissible(q):
    """A strobe point whose +-FD-step perturbations stay in the same mode (a base for the FD Jacobian)."""
    return (q[2] == FREE and q[1] > 100 * _FD_STEP) or (q[2] == CONTACT and q[1] < -100 * _FD_STEP)


def _analyse_cycle(ball, t_section, pts, p):
    """Polish a p-cycle by Newton on P^p(x) = x and compute its multipliers.

    Returns the polished cycle (entry j at the strobe index of ``pts[j]``), the
    multipliers, whether the map is smooth there, and the residual.
    """
    pts = [tuple(q) for q in pts]
    base = [j for j, q in enumerate(pts) if _admissible(q)]
    j0 = base[0] if base else 0
    x = pts[j0]
    f = _period_map(ball, t_section, x, p)
    res = _dist(f, x)
    if base:
        polish = newton(_CyclePolish(ball, t_section, p, x[2]), np.array(x[:2]), tol=1e-14, max_iter=6,
                        linear="dense", decrease=0.0, min_step=1.0)
        x, res = (float(polish.x[0]), float(polish.x[1]), x[2]), float(polish.residual)
        Jc, Jf, Jb, _ = _jacobian(ball, t_section, x, p, _FD_STEP)
        smooth = bool(np.max(np.abs(Jf - Jb)) <= 1e-4 * (1.0 + np.max(np.abs(Jc))))
        mu = floquet_multipliers(Jc)
        mu[np.abs(mu) < 1e-9] = 0.0
    elif all(q[2] == STUCK for q in pts):
        smooth, mu = True, np.zeros(2, dtype=complex)        # stuck at every section: the map resets
    else:
        smooth, mu = False, np.full(2, np.nan, dtype=complex)
    cyc = [x]
    for _ in range(p - 1):
        cyc.append(ball.cycle(t_section, cyc[-1]))
    cyc = cyc[p - j0:] + cyc[:p - j0]
    return cyc, mu, smooth, float(res)


def _wilson(k, n):
    f = k / n
    z2 = _Z95 * _Z95
    den = 1.0 + z2 / n
    c = (f + z2 / (2 * n)) / den
    h = _Z95 * math.sqrt(f * (1 - f) / n + z2 / (4 * n * n)) / den
    return (max(0.0, c - h), min(1.0, c + h))


def _stats(k, n):
    if n == 0:                      # an interrupted run with no finished sample
        return dict(count=0, fraction=math.nan, stderr=math.nan, interval=(math.nan, math.nan))
    f = k / n
    return dict(count=int(k), fraction=f, stderr=math.sqrt(f * (1.0 - f) / n), interval=_wilson(k, n))


def _pattern(impacts, sticks):
    parts = []
    if impacts:
        parts.append(f"{impacts} impact" + ("s" if impacts != 1 else ""))
    if sticks:
        parts.append(f"{sticks} stick" + ("s" if sticks != 1 else ""))
    return ", ".join(parts) or "no contact"


def _check_model(Gamma, e, model, cutoff):
    Gamma = check_positive(Gamma, "Gamma")
    law = as_restitution(e)
    e = check_restitution(law.e, "e") if law.constant else law
    model = check_choice(model, "model", MODELS)
    if not law.constant and model != "point":
        raise ValueError(f"e must be a constant restitution with model={model!r} (the soft contact's "
                         f"restitution belongs to its damped oscillator), got {law!r}; use model='point'")
    if model == "soft":
        if cutoff is None:
            raise ValueError("cutoff must be a finite number > 0 when model='soft', got None")
        cutoff = check_positive(cutoff, "cutoff")
        if cutoff * cutoff >= _TWO_PI:
            raise ValueError(f"cutoff must give a contact time cutoff**2 < 2*pi, got {cutoff!r}")
        if e == 0.0:
            raise ValueError("e must be in (0, 1) for model='soft': the damping -ln(e)/tau_c is singular at "
                             "e = 0 (docs/design.md, hazard 11); use model='point' for e = 0")
    elif cutoff is not None:
        raise ValueError(f"cutoff is only used with model='soft', got cutoff={cutoff!r} with model='point'")
    return Gamma, e, model, cutoff


def _compiled_inapplicable(model, e, integrator, executor, store):
    """Why the compiled ensemble does not apply ('' if it does)."""
    from tps_solver.core import jit

    if model != "point":
        return f"model={model!r} (the compiled ball has point impacts)"
    if isinstance(e, RestitutionLaw):
        return "a speed-dependent restitution law (the compiled ball has a constant e)"
    if integrator != "closed_form":
        return f"integrator={integrator!r}"
    if not (isinstance(executor, str) and executor == "serial") or store is not None:
        return "an executor or a store (the compiled ensemble runs in this process)"
    if not jit.enabled():
        return ("numba is not installed (pip install tps-solver[fast])" if not jit.available()
                else "TPS_SOLVER_NUMBA=0 disables the compiled kernels")
    return ""


def _check_range(value, name, low_bound=None):
    arr = check_array(value, name, shape=(2,))
    if not arr[0] < arr[1]:
        raise ValueError(f"{name} must be (low, high) with low < high, got {tuple(arr)}")
    if low_bound is not None and arr[0] < low_bound:
        raise ValueError(f"{name} must lie in [{low_bound}, inf), got {tuple(arr)}")
    return float(arr[0]), float(arr[1])


#: Above this many samples the reference engine times its first :data:`_PROBE_SAMPLES` samples and
#: refuses a run whose pace puts it beyond the time limit (its per-sample time ranges from 0.2 ms
#: to tens of ms with the attractors: no a-priori bound is useful).
_PROBE_ABOVE = 4096
_PROBE_SAMPLES = 16


def _keyable(e):
    """Whether a sweep store can key ``e`` (a number, or a law with parameters)."""
    return not isinstance(e, RestitutionLaw) or bool(e.parameters)


def flat_basins(Gamma, e, M=2, n_samples=64, seed=0, model="point", cutoff=None, periods=200, *,
                p_max=None, tol=1e-8, t_section=0.0, w_range=None, zeta_range=None, stick_velocity=1e-6,
                integrator="closed_form", soft_sticking=False, max_events_per_cycle=10000, executor="serial",
                store=None, progress=False, engine="auto"):
    r"""Fractions of random initial states of one node that reach each attractor.

    See the module docstring for the models and how attractors are classified.

    Parameters
    ----------
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in [0, 1) (in (0, 1) for ``model="soft"``).
    M : int
        The flat orbit's period is :math:`T = 2\pi M` (sets ``is_flat``, the
        unit of ``periods`` and the default sampling box).
    n_samples : int
        Number of random initial states, >= 1.
    seed : int or None
        Seed of ``numpy.random.default_rng``; the states are drawn in order, so
        the first ``n`` samples of a larger run are the samples of a run with
        ``n_samples = n``.
    model : {"point", "soft"}
    cutoff : float, optional
        Soft-contact length :math:`\ell > 0` (``model="soft"`` only).
    periods : int
        Longest integration per sample, in periods :math:`T` (``periods * M``
        forcing cycles).
    p_max : int, optional
        Longest cycle sought, in forcing cycles; default ``8 * M``.
    tol : float
        Return distance (max norm) of a repeated cycle.
    t_section : float
        Phase of the stroboscopic section and of the initial states.
    w_range, zeta_range : (float, float), optional
        Box of initial states; default :math:`w_0 \in [-\pi M/\Gamma, \pi M/\Gamma]`
        (the flat orbit's take-off speed scale :math:`T/2\Gamma`) and
        :math:`\zeta_0 \in [0, (\pi M)^2/2\Gamma]` (its height scale :math:`T^2/8\Gamma`).
    stick_velocity : float
        Point impacts at or below this speed end at rest (as in :func:`~tps_solver.simulate`).
    integrator : {"closed_form", "simulate"}
    soft_sticking : bool
        Soft model only, closed form only: a contact entered at a speed at or
        below ``stick_velocity`` ends at rest, held while :math:`g \le 0`
        (the sticking rule proposed in (docs/design.md, hazard 10)).  The default
        ``False`` is the model of ``simulate(..., method="soft-radau")``, which has no
        such rule: a ball then micro-chatters through every sticking phase and
        leaves it at a phase set by the chatter, so sticking does not reset it.
    max_events_per_cycle : int
        A sample with more events in a forcing cycle fails (``labels == -2``).
    executor, store, progress
        Passed to :func:`~tps_solver.analyses.sweep.sweep` (one point per sample);
        default in this process.  ``progress`` also counts the samples of the compiled engine.
    engine : {"auto", "compiled", "reference"}
        ``"compiled"`` runs all samples as one ensemble of compiled kernels
        (:mod:`tps_solver.model.ball_kernel`; needs the ``fast`` extra, numba, and applies to
        ``model="point"`` with a constant ``e``, ``integrator="closed_form"``, in this process:
        ``executor="serial"``, no ``store``); ``"reference"`` follows each sample with
        :class:`~tps_solver.model.ball.ClosedFormBall` through
        :func:`~tps_solver.analyses.sweep.sweep`; ``"auto"`` (default) is ``"compiled"`` where it
        applies and numba is there, else ``"reference"``.  The two give the same classifications
        (the states agree to the last bits; a chaotic sample can part from them over many cycles).

    Returns
    -------
    BasinResult

    Examples
    --------
    >>> res = flat_basins(4.1, 0.0, M=2, n_samples=4, seed=1, periods=40)
    >>> [(a.label, a.count, a.multipliers.tolist()) for a in res.attractors]
    [('f/2 (1 impact, 1 stick)', 4, [0j, 0j])]
    >>> round(res.flat_fraction, 3), res.converged
    (1.0, True)
    """
    from tps_solver.analyses.sweep import SweepInterrupted, sweep

    Gamma, e, model, cutoff = _check_model(Gamma, e, model, cutoff)
    M = check_int(M, "M", minimum=1)
    n_samples = check_int(n_samples, "n_samples", minimum=1)
    if seed is not None:
        seed = check_int(seed, "seed", minimum=0)
    periods = check_int(periods, "periods", minimum=1)
    p_max = 8 * M if p_max is None else check_int(p_max, "p_max", minimum=1)
    tol = check_positive(tol, "tol")
    t_section = check_real(t_section, "t_section")
    scale_w = math.pi * M / Gamma
    w_lo, w_hi = (-scale_w, scale_w) if w_range is None else _check_range(w_range, "w_range")
    z_lo, z_hi = ((0.0, (math.pi * M) ** 2 / (2.0 * Gamma)) if zeta_range is None
                  else _check_range(zeta_range, "zeta_range", 0.0))
    stick_velocity = check_positive(stick_velocity, "stick_velocity")
    integrator = check_choice(integrator, "integrator", INTEGRATORS)
    if not isinstance(soft_sticking, (bool, np.bool_)):
        raise ValueError(f"soft_sticking must be True or False, got {soft_sticking!r}")
    if soft_sticking and (model != "soft" or integrator != "closed_form"):
        raise ValueError("soft_sticking=True needs model='soft' and integrator='closed_form'")
    max_events = check_int(max_events_per_cycle, "max_events_per_cycle", minimum=1)
    engine = check_choice(engine, "engine", ENGINES)
    why_not = _compiled_inapplicable(model, e, integrator, executor, store)
    if engine == "compiled" and why_not:
        raise ValueError(f"engine='compiled' does not apply: {why_not}; use engine='reference'")
    compiled = engine == "compiled" or (engine == "auto" and not why_not)
    max_cycles = periods * M
    if 2 * p_max > max_cycles:
        raise ValueError(f"periods must give at least 2 * p_max = {2 * p_max} forcing cycles, "
                         f"got periods * M = {max_cycles}")

    # the parameter dicts (about 1 kB each) and at least 1e-6 s per sample and forcing cycle
    check_cost("flat_basins", "n_samples", n_samples, 1.0e3 * n_samples + 1e6, 1.0e-6 * n_samples * max_cycles,
               hint=f"{n_samples} samples of up to {max_cycles} forcing cycles")
    rng = np.random.default_rng(seed)
    u = rng.random((n_samples, 2))
    w0 = w_lo + (w_hi - w_lo) * u[:, 0]
    z0 = z_lo + (z_hi - z_lo) * u[:, 1]
    common = dict(Gamma=Gamma, e=e, model=model, cutoff=cutoff, t_section=t_section, p_max=p_max,
                  max_cycles=max_cycles, tol=tol, stick_velocity=stick_velocity, integrator=integrator,
                  max_events=max_events, soft_sticking=bool(soft_sticking))
    requested = n_samples
    if compiled:
        results = _compiled_samples(Gamma, e, w0, z0, t_section, p_max, max_cycles, tol, stick_velocity,
                                    max_events, progress)
    else:
        task = _basin_sample
        if not _keyable(e):
            # a user's function has no parameters to key a store by: it goes with the task, not the points
            if store is not None:
                raise ValueError(f"store cannot be used with e = {e!r}: a user's function has no parameters to "
                                 "key the stored samples by; run without store")
            task = functools.partial(_basin_sample, e=e)
            del common["e"]
        if n_samples > _PROBE_ABOVE:
            # the reference engine's pace varies with the attractors: time a few samples first
            tic = time.perf_counter()
            for a, b in zip(w0[:_PROBE_SAMPLES], z0[:_PROBE_SAMPLES]):
                task(**dict(common, w0=float(a), zeta0=float(b)))
            pace = (time.perf_counter() - tic) / _PROBE_SAMPLES
            check_cost("flat_basins", "n_samples", n_samples, 1.0e3 * n_samples + 1e6, pace * n_samples,
                       hint=f"engine='reference': the first {_PROBE_SAMPLES} samples took {pace:.3g} s each"
                            + (f" ({why_not})" if why_not else ""))
        params = [dict(common, w0=float(a), zeta0=float(b)) for a, b in zip(w0, z0)]
        try:
            # a sample that raises is a bug, not a fault of the sample (those are status 'failed'): raise it
            results = sweep(task, params, executor=executor, store=store, progress=progress,
                            on_error="raise")
        except SweepInterrupted as exc:
            # Ctrl-C: classify the samples that finished (status 5); the store keeps them for a rerun
            results = exc.results
    done = np.array([s is not None for s in results], dtype=bool)
    interrupted = not bool(np.all(done))
    samples = [s for s in results if s is not None]
    w0, z0 = w0[done], z0[done]
    n_samples = len(samples)

    ball = _make_ball(Gamma, e, model, cutoff, stick_velocity, max_events, integrator, bool(soft_sticking))
    attractors, raw = [], []                 # raw: (canonical points (index = 0 mod p), period)
    labels = np.full(n_samples, -1, dtype=int)
    phases = np.full(n_samples, -1, dtype=int)
    transients = []
    for i, s in enumerate(samples):
        if s["status"] == "failed":
            labels[i] = -2
            continue
        if s["status"] != "periodic":
            continue
        p, k1, pts = s["period"], s["first_index"], s["points"]
        found = None
        for a, (canon, pa) in enumerate(raw):
            if pa != p:
                continue
            for shift in range(p):
                if all(_dist(pts[j], canon[(j + shift) % p]) < _MATCH_TOL for j in range(p)):
                    found = (a, (shift - k1) % p)
                    break
            if found:
                break
        if found is None:
            r = (-k1) % p                    # rotate so that entry 0 sits at a strobe index = 0 mod p
            canon = [pts[(j + r) % p] for j in range(p)]
            raw.append((canon, p))
            attractors.append(dict(period=p, impacts=s["impacts"], sticks=s["sticks"], members=[], first=i,
                                   k1=k1, pts=pts))
            transients.append([])
            found = (len(raw) - 1, 0)
        a, ph = found
        labels[i], phases[i] = a, ph
        attractors[a]["members"].append(i)
        transients[a].append(s["n_cycles"])

    out = []
    names = {}
    for a, info in enumerate(attractors):
        p = info["period"]
        cyc, mu, smooth, res = _analyse_cycle(ball, t_section, info["pts"], p)
        r = (-info["k1"]) % p
        cyc = [cyc[(j + r) % p] for j in range(p)]
        is_flat = p == M
        label = f"f/{p}" if (info["impacts"], info["sticks"]) == (p // M if p % M == 0 else -1, 0) \
            else f"f/{p} ({_pattern(info['impacts'], info['sticks'])})"
        if label in names:
            names[label] += 1
            label = f"{label} #{names[label]}"
        else:
            names[label] = 1
        ph = np.bincount(phases[labels == a], minlength=p)
        st = _stats(len(info["members"]), n_samples)
        out.append(Bunch(label=label, period=p, period_T=p / M, impacts=info["impacts"], sticks=info["sticks"],
                         **st, points=np.array([c[:2] for c in cyc], dtype=float),
                         modes=[MODE_NAMES[c[2]] for c in cyc], multipliers=mu, smooth=smooth,
                         stable=bool(np.max(np.abs(mu)) < 1.0), residual=res, phase_counts=ph,
                         is_flat=bool(is_flat), mean_transient=float(np.mean(transients[a]))))
    order = sorted(range(len(out)), key=lambda a: (-out[a].count, a))
    remap = {old: new for new, old in enumerate(order)}
    out = [out[a] for a in order]
    labels = np.array([remap.get(x, x) if x >= 0 else x for x in labels], dtype=int)

    n_irr = int(np.sum(labels == -1))
    n_fail = int(np.sum(labels == -2))
    irregular = Bunch(**_stats(n_irr, n_samples))
    near = {}
    for s in samples:
        if s["status"] == "irregular":
            near.setdefault(s["near_period"], []).append(s["near_distance"])
    irregular.near_periods = {p: (len(d), float(np.median(d))) for p, d in sorted(near.items())}
    fractions = {a.label: a.fraction for a in out}
    stderr = {a.label: a.stderr for a in out}
    fractions["irregular"], stderr["irregular"] = irregular.fraction, irregular.stderr
    if n_fail:
        fs = _stats(n_fail, n_samples)
        fractions["failed"], stderr["failed"] = fs["fraction"], fs["stderr"]
    flat = [a for a in out if a.is_flat]
    flat_fraction = sum(a.fraction for a in flat)
    flat_stderr = math.sqrt(flat_fraction * (1.0 - flat_fraction) / n_samples) if n_samples else math.nan
    if interrupted:
        status = 5
        message = (f"interrupted (KeyboardInterrupt) after {n_samples} of {requested} samples; the fractions "
                   f"are over those {n_samples} (rerun with the same store to finish)")
    elif n_fail:
        status = 6
        first = next(s["message"] for s in samples if s["status"] == "failed")
        message = (f"{n_fail} of {n_samples} samples failed ({first}); raise max_events_per_cycle or "
                   f"stick_velocity if they chatter")
    elif n_irr:
        status = 1
        message = (f"{n_irr} of {n_samples} samples did not repeat a cycle of period <= p_max = {p_max} "
                   f"forcing cycles within {periods} periods; they are counted as irregular. If they are slow "
                   f"transients, raise periods or p_max (or loosen tol)")
    else:
        status, message = 0, f"all {n_samples} samples reached one of {len(out)} periodic attractors"
    return BasinResult(
        attractors=out, fractions=fractions, stderr=stderr, irregular=irregular, flat_fraction=flat_fraction,
        flat_stderr=flat_stderr, labels=labels, phases=phases,
        n_cycles=np.array([s["n_cycles"] for s in samples], dtype=int),
        initial_states=np.column_stack((w0, z0)), converged=status == 0, status=status, message=message,
        Gamma=Gamma, e=e, M=M, model=model, cutoff=cutoff, n_samples=n_samples, seed=seed, periods=periods,
        p_max=p_max, tol=tol, t_section=t_section, integrator=integrator, soft_sticking=bool(soft_sticking))
