r"""Time-periodic solutions with impact-and-stick contacts (restitution e, including e = 0).

The single-contact TPS of :mod:`tps_solver.solvers.tps` assumes one impact per node and
period with the impulse fixed by (44).  For small e every impact ends in sticking
until lift-off (docs/design.md, hazard 11), and a node may touch the plate several
times per period.  This module solves for periodic orbits with **K contacts per
node and period**, each an impact that is either

* ``"bounce"`` -- restitution :math:`w^+ = -e\,w^-` (for e = 0 a *touch-and-go*:
  the node lands, its free acceleration is positive and it leaves at once), or
* ``"stick"`` -- :math:`w^+ = 0` followed by a stick interval :math:`[t_k, \tau_k]`
  on which the plate's reaction holds :math:`w = \zeta = 0`; lift-off at
  :math:`\tau_k` is where the reaction would turn tensile.  Lift-off is either
  *smooth* (the reaction :math:`R = -g - (\underline L\,\underline w)_j` falls
  continuously to 0) or *triggered* by the impact of a lattice neighbour at the
  same instant (the neighbour's velocity jump makes :math:`R` jump negative).

Formulation
-----------
Per node the source of the antiplane equation (37) is

.. math:: \partial_t w - \nabla^2 w = g(t) + \sum_k J_k\,\delta_T(t - t_k)
          + \sum_{\text{stick } k} \chi_{[t_k,\tau_k]}(t)\,\big(\rho_k(t) - g(t)\big),

i.e. on a stick interval the gravity :math:`g` is replaced by the reaction-balanced
acceleration :math:`\rho_k = -\nabla^2 w` (so that :math:`\partial_t w = 0` there).
:math:`\rho_k` is an unknown expanded in Legendre polynomials on its interval
(``n_basis`` terms), and :math:`w = 0` is collocated at the ``n_basis``
Gauss-Legendre points of the interval.  The unknowns per node are the contact
times :math:`t_k`, the impulses :math:`J_k`, the lift-off times :math:`\tau_k`
and the reaction coefficients; the equations are

* restitution :math:`J_k = -(1 + e)\,w^-(t_k)` (bounce) or :math:`J_k = -w^-(t_k)` (stick), eq. (11);
* :math:`\zeta(t_{k+1}) = \zeta(t_k)`: :math:`\int_{t_k}^{t_{k+1}} w\,dt = 0` for
  consecutive contacts (the first contact fixes :math:`\hat\zeta_0`, eq. (40));
* the collocated stick constraint :math:`w = 0`;
* lift-off: :math:`\rho_k(\tau_k) = g(\tau_k)` (smooth) or :math:`\tau_k` equal to
  the triggering neighbour's impact time;
* the mean balance (44) generalised: :math:`\hat s_{0} = 0`, i.e.
  :math:`\sum_k J_k + \sum_k \int_{t_k}^{\tau_k}(\rho_k - g)\,dt = T/\Gamma`
  (which makes :math:`\hat w_0 = 0`, eq. (39)).

The Fourier series (38)-(39) with the per-harmonic lattice Helmholtz solve (45),
:math:`\hat w_n = (i n\alpha - \underline A)^{-1}\hat s_n`, is **summed to all
orders** in the eigenbasis :math:`\underline A = V\Lambda V^{-1}` of the lattice
operator (as in :mod:`tps_solver.lattice_cycle`):
:math:`\sum_{n \ne 0} e^{in\alpha\tau}/(T(in\alpha - \lambda)) = H(\lambda, \tau)`,

.. math:: H(\lambda,\tau) = \frac{e^{\lambda\tau}}{1 - e^{\lambda T}} + \frac{1}{\lambda T},
          \quad \tau \in (0, T), \qquad H(0, \tau) = \tfrac12 - \tau/T ,

so every jump is treated in closed form (the value at a node's own impact uses the
one-sided limit :math:`\tau \to T^-`, i.e. :math:`w^-`), the sin t forcing gives
:math:`-\cos t` exactly (Neumann lattice), and the interval sources are integrated
by Gauss-Legendre quadrature split at the evaluation time (the kernel jumps there).
For a flat layer :math:`\nabla^2 w = 0`, :math:`\rho = 0` is in the basis and the
flat e = 0 orbit comes out exact to rounding.  The only approximation on a lattice
is the polynomial reaction (spectral in ``n_basis`` while no neighbour event falls
inside a stick interval) and the quadrature (``n_quad`` points per sub-interval).

Where a lattice neighbour lands or lifts off inside a stick interval, the reaction
jumps or kinks there; the interval is then cut into *segments* at those (unknown)
times, each with its own Legendre expansion, so the expansion stays spectral.
Stick intervals shorter than 1e-10 (the chains of landings in near-flat regions,
where a node waits for its neighbour to land) are taken as impacts with
:math:`w^+ = 0`; segments shorter than 1e-6 carry one constant reaction term
balanced against the neighbours at their midpoint.

The nonlinear system is solved by Newton's method with a dense Jacobian: exact in
the linear unknowns (impulses, reaction coefficients), analytic in the impulse
times (the impulse kernels kink where two impacts coincide: docs/design.md, hazard 7),
by forward differences in the remaining smooth time dependence, where
only the rows and columns a time touches are recomputed; the Jacobian is reused
while it contracts the residual tenfold per step.

Scope: Neumann lattices (planar or axisymmetric).  The continuum kink (the
HelmholtzSolver Green's function) is not implemented here.  Cost: a 21-node
lattice takes about a minute, a 41-node one several minutes (dense Jacobian,
O(n_nodes^3) per residual).

The contact pattern (kinds, triggers) is fixed during the solve; it is taken from
a time-stepped FDA run (:func:`pattern_from_fda`) or given by the caller, and
checked afterwards on the solution (``checks``).
"""
import math
import time

import numpy as np
from numpy.polynomial.legendre import leggauss, legvander
from scipy.linalg import eigh, lu_factor, lu_solve
from scipy.optimize import brentq

from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_int, check_positive, check_real, check_restitution
from tps_solver.solvers.shooting.periodic import ShootingOrbit, find_periodic_orbit

__all__ = ["StickSolution", "StickPattern", "flat_stick_orbit", "solve_stick_flat", "check_with_fda",
           "solve_stick_lattice", "pattern_from_fda", "pattern_from_orbit", "kink_state"]

_KINDS = ("bounce", "stick")
_ZERO_MODE = 1e-10          # |lambda T| below this: the zero mode's closed form
_COLLAPSE = 1e-10           # stick intervals shorter than this: an impact with w+ = 0
_BREAK_MARGIN = 1e-12      # neighbour events closer than this to an end do not cut a segment
_MEDIUM = 1e-6              # segments shorter than this: at most 2 reaction terms (was 1e-3: too coarse at dx = 0.5)
_COLL_SCALE = 1e-2          # collocated w = 0 is divided by max(segment length, this)
_BREAK_DISTANCE = 3          # cut stick intervals at events of nodes up to this graph distance
_SHORT = 1e-6               # shorter than this: one reaction term, balanced at the midpoint
_CHUNK = 2 ** 22            # elements of the (requests, segments, modes) temporaries per chunk


# ----------------------------------------------------------------- flat layer
def _flight(t0, Gamma):
    """Height and velocity of a flight from rest on the plate at t0 (flat layer, (17))."""
    c0, s0 = math.cos(t0), math.sin(t0)
    z = lambda t: c0 * (t - t0) + s0 - math.sin(t) - (t - t0) ** 2 / (2 * Gamma)
    w = lambda t: c0 - math.cos(t) - (t - t0) / Gamma
    return z, w


def _next_landing(t0, Gamma, horizon):
    """First root of zeta after t0 of a flight from rest at t0 (bracketed on a fine grid)."""
    z, _ = _flight(t0, Gamma)
    # zeta ~ g'(t0) (t - t0)^3 / 6 near a smooth lift-off: start the scan a little later
    ts = np.linspace(t0, t0 + horizon, int(horizon * 400) + 2)[1:]
    vals = np.array([z(t) for t in ts])
    start = 1
    while start < ts.size and vals[start - 1] <= 0.0 and abs(vals[start - 1]) < 1e-12:
        start += 1
    neg = np.nonzero(vals[start:] < 0.0)[0]
    if neg.size == 0:
        return None
    i = neg[0] + start
    return brentq(z, ts[i - 1], ts[i], xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200)


def flat_stick_orbit(Gamma, M=2):
    r"""The completely inelastic flat layer (e = 0): contacts, kinds and lift-off, in closed form.

    Lift-off from rest at :math:`t_L` with :math:`\sin t_L = 1/\Gamma`,
    :math:`\cos t_L > 0`; flight (17) with :math:`W_0 = 0`,
    :math:`w = \cos t_L - \cos t - (t - t_L)/\Gamma`; a landing where
    :math:`g > 0` is a touch-and-go (a new flight from rest), the first landing
    where :math:`g \le 0` ends in sticking until the next lift-off phase.  The
    landing times are roots of the flight equation, found by Brent's method to
    rounding.

    Parameters
    ----------
    Gamma : float
        Plate acceleration, ``Gamma > 1`` (otherwise the layer never lifts off).
    M : int
        Subharmonic order; the orbit must close after ``M`` forcing cycles.

    Returns
    -------
    Bunch
        ``t_liftoff`` (float, in [0, 2 pi)), ``t`` (contact times, ndarray of float,
        shape (K,), increasing, in (t_L, t_L + T)), ``kind`` (ndarray of str, shape
        (K,)), ``w_minus`` (pre-impact velocities, shape (K,)), ``tau`` (lift-off
        after each contact, nan for a bounce), ``period``.

    Raises
    ------
    ValueError
        If ``Gamma <= 1`` or the e = 0 orbit does not close with period
        ``2 pi M`` (it has another period at this Gamma).

    Examples
    --------
    >>> orb = flat_stick_orbit(4.1, 2)
    >>> [str(k) for k in orb.kind], bool(abs(np.sin(orb.t_liftoff) - 1 / 4.1) < 1e-15)
    (['bounce', 'stick'], True)
    """
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    if Gamma <= 1.0:
        raise ValueError(f"Gamma must be > 1 for the layer to lift off, got {Gamma}")
    T = 2 * math.pi * M
    tL = math.asin(1.0 / Gamma)
    ts, kinds, wm, taus = [], [], [], []
    t_start = tL
    while True:
        t_land = _next_landing(t_start, Gamma, T + 1.0)
        if t_land is None or t_land >= tL + T:
            raise ValueError(f"the e = 0 flat orbit at Gamma = {Gamma} does not close after "
                             f"M = {M} forcing cycles (no landing before t_L + T)")
        _, w = _flight(t_start, Gamma)
        ts.append(t_land)
        wm.append(w(t_land))
        if math.sin(t_land) - 1.0 / Gamma > 0.0:
            kinds.append("bounce")
            taus.append(math.nan)
            t_start = t_land
            continue
        kinds.append("stick")
        cycles = math.ceil((t_land - tL) / (2 * math.pi))
        tau = tL + 2 * math.pi * cycles
        taus.append(tau)
        if abs(tau - (tL + T)) < 1e-12:
            break
        if tau > tL + T:
            raise ValueError(f"the e = 0 flat orbit at Gamma = {Gamma} does not close after "
                             f"M = {M} forcing cycles")
        t_start = tau
    return Bunch(t_liftoff=tL, t=np.array(ts), kind=np.array(kinds), w_minus=np.array(wm),
                 tau=np.array(taus), period=T, Gamma=Gamma, M=M)


# ------------------------------------------------------------------ kernels
def _H(lam, tau, T):
    """Mean-free periodic response of y' = lam y + delta_T - 1/T (all Fourier orders)."""
    z = lam * T
    small = np.abs(z) < _ZERO_MODE
    zs = np.where(small, -1.0, z)
    full = np.exp(np.where(small, 0.0, lam) * tau) / (-np.expm1(zs)) + 1.0 / zs
    return np.where(small, 0.5 - tau / T, full)


def _H_int(lam, tau, T):
    """An antiderivative of _H in tau, periodic (continuous at tau = 0, T)."""
    small = np.abs(lam * T) < _ZERO_MODE
    ls = np.where(small, 1.0, lam)
    full = (_H(lam, tau, T) - 0.5 + tau / T) / ls
    return np.where(small, tau / 2 - tau * tau / (2 * T), full)


class _Modal:
    """Eigen-decomposition A = V diag(lam) V^-1 of a Neumann lattice operator, and the kernels.

    Both kernels are ``K_p(tau) = A_p e^{lam_p tau} + B_p + C_p tau + D_p tau^2`` per mode:
    :func:`_H` (``W=False``) and its periodic antiderivative :func:`_H_int` (``W=True``).
    """

    def __init__(self, lattice, period, coupling=1.0):
        D = np.asarray(lattice.volumes, dtype=float)
        S = np.asarray(lattice.flux, dtype=float)
        sq = np.sqrt(D)
        lam, U = eigh(S / np.outer(sq, sq))
        self.lam = coupling * np.minimum(lam, 0.0)
        self.V = U / sq[:, None]
        self.Vinv = U.T * sq[None, :]
        self.A = coupling * np.asarray(lattice.operator, dtype=float)
        self.n = D.size
        T = float(period)
        lam = self.lam
        zero = np.abs(lam * T) < _ZERO_MODE
        ls = np.where(zero, -1.0, lam)
        alpha = np.where(zero, 0.0, 1.0 / (-np.expm1(ls * T)))
        beta = np.where(zero, 0.5, 1.0 / (ls * T))
        self._tables = {
            False: (alpha, beta, np.where(zero, -1.0 / T, 0.0), np.zeros_like(lam)),
            True: (np.where(zero, 0.0, alpha / ls), np.where(zero, 0.0, (beta - 0.5) / ls),
                   np.where(zero, 0.5, 1.0 / (ls * T)), np.where(zero, -0.5 / T, 0.0)),
        }
        self._poly = {W: tuple(self.V @ (k[:, None] * self.Vinv) for k in tab[1:])
                      for W, tab in self._tables.items()}

    def table(self, W):
        return self._tables[bool(W)]

    def poly(self, W):
        return self._poly[bool(W)]


# ------------------------------------------------------------------ patterns
class StickPattern(Bunch):
    r"""A contact pattern with initial values: which contacts each node makes per period.

    Attributes
    ----------
    node : ndarray of int, shape (C,)
        Node of each contact; contacts are grouped by node, increasing in time.
    kind : ndarray of str, shape (C,)
        ``"bounce"`` or ``"stick"``.
    t : ndarray of float, shape (C,)
        Contact (impact) times, within one window of length T per node.
    J : ndarray of float, shape (C,)
        Impulses (velocity jumps) at the impacts.
    tau : ndarray of float, shape (C,)
        Lift-off time after a stick (nan for a bounce), ``tau > t``.
    trigger : ndarray of int, shape (C,)
        Index of the contact whose impact triggers the lift-off (-1: smooth lift-off).
    trigger_shift : ndarray of int, shape (C,)
        Period shift m with ``tau = t[trigger] + m T``.
    n_nodes : int
    period : float

    Examples
    --------
    The flat e = 0 orbit on one node: a touch-and-go, then a stick with a smooth lift-off.

    >>> p = solve_stick_flat(4.1).pattern
    >>> [str(k) for k in p.kind], p.trigger.tolist()
    (['bounce', 'stick'], [-1, -1])
    >>> bool(np.isnan(p.tau[0]) and p.tau[1] > p.t[1])
    True
    """


def _make_pattern(node, kind, t, J, tau, trigger, trigger_shift, n_nodes, period):
    node = np.asarray(node, dtype=int)
    t = np.asarray(t, float)
    if t.size:                            # move the window so that the earliest contact is in [0, T)
        shift = math.floor(float(np.min(t)) / period) * period
        t = t - shift
        tau = np.asarray(tau, float) - shift
    order = np.lexsort((np.asarray(t, float), node))
    inv = np.empty_like(order)
    inv[order] = np.arange(order.size)
    trig = np.asarray(trigger, dtype=int)[order]
    trig = np.where(trig >= 0, inv[np.maximum(trig, 0)], -1)
    p = StickPattern(node=node[order], kind=np.asarray(kind, dtype="U6")[order],
                     t=np.asarray(t, float)[order], J=np.asarray(J, float)[order],
                     tau=np.asarray(tau, float)[order], trigger=trig,
                     trigger_shift=np.asarray(trigger_shift, dtype=int)[order],
                     n_nodes=int(n_nodes), period=float(period))
    _check_pattern(p)
    return p


def _check_pattern(p):
    C = p.node.size
    if C == 0:
        raise ValueError("pattern must hold at least one contact per node (K >= 1), got none")
    counts = np.bincount(p.node, minlength=p.n_nodes)
    if p.node.min() < 0 or p.node.max() >= p.n_nodes:
        raise ValueError(f"pattern.node must lie in [0, {p.n_nodes}), got range "
                         f"[{p.node.min()}, {p.node.max()}]")
    if np.any(counts < 1):
        raise ValueError(f"every node needs K >= 1 contacts per period; nodes without a contact: "
                         f"{np.nonzero(counts < 1)[0][:10].tolist()}")
    bad = ~np.isin(p.kind, _KINDS)
    if np.any(bad):
        raise ValueError(f"pattern.kind must be 'bounce' or 'stick', got {p.kind[bad][0]!r}")
    for arr, name in ((p.t, "t"), (p.J, "J")):
        if arr.shape != (C,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"pattern.{name} must be finite with shape ({C},)")
    stick = p.kind == "stick"
    if not np.all(np.isfinite(p.tau[stick])) or np.any(p.tau[stick] <= p.t[stick]):
        raise ValueError("pattern.tau must be finite and > t for every stick contact")
    for j in range(p.n_nodes):
        tj = p.t[p.node == j]
        ends = np.where(stick[p.node == j], p.tau[p.node == j], tj)
        if tj.size and (tj[-1] - tj[0] >= p.period or np.any(tj[1:] < ends[:-1])
                        or ends[-1] > tj[0] + p.period):
            raise ValueError(f"pattern at node {j} does not exist: its contacts and stick "
                             "intervals must be disjoint and fit in one period")
    if np.any((p.trigger >= 0) & ~stick):
        raise ValueError("pattern.trigger must be -1 for bounce contacts")


def kink_state(lattice, Gamma, M=2, t=None):
    r"""A kink start for e = 0: the flat orbit for x < 0, the same half a period later for x >= 0.

    Parameters
    ----------
    lattice : tps_solver.Lattice
        Planar lattice.
    Gamma : float
    M : int
        Even (the half-period shift is a flat phase only for even M).
    t : float, optional
        Start time (default: lift-off + 0.5, a flight phase of both halves).

    Returns
    -------
    t : float
    w0, zeta0 : ndarray of float, shape (n_nodes,)

    Raises
    ------
    ValueError
        If ``M`` is odd.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=5, length=8.0)
    >>> t, w0, zeta0 = kink_state(lat, 4.1)
    >>> left = lat.nodes < 0                       # two flat halves, half a period apart
    >>> bool(np.all(w0[left] == w0[0]) and np.all(w0[~left] == w0[-1]) and w0[0] != w0[-1])
    True
    >>> w0.shape, bool(np.all(zeta0 >= 0))
    ((5,), True)
    """
    orb = flat_stick_orbit(Gamma, M)
    T = orb.period
    if M % 2:
        raise ValueError(f"M must be even for a kink start, got {M}")
    t = orb.t_liftoff + 0.5 if t is None else check_real(t, "t")
    w, z = _flat_functions(orb)
    x = np.asarray(lattice.nodes, dtype=float)
    wl, zl = w(t), z(t)
    wr, zr = w(t + T / 2), z(t + T / 2)
    return t, np.where(x < 0, wl, wr), np.where(x < 0, zl, zr)


def pattern_from_fda(run, lattice, period, t_window=None, tol=1e-9):
    r"""Read the contact pattern of the last period of an FDA run (``tps.simulate`` events).

    Parameters
    ----------
    run : SimulationResult
        A run of at least two periods that has settled on a T-periodic state.
    lattice : tps_solver.Lattice
    period : float
    t_window : float, optional
        Start of the window of length T whose contacts are read; default: one
        and a half periods before the end, moved to the largest event-free gap.
    tol : float
        Coincidence tolerance for lift-offs triggered by a neighbour's impact.

    Returns
    -------
    StickPattern

    Raises
    ------
    ValueError
        If the run ends before a stick of the window lifts off, or the pattern read is
        not a valid one (a node without contacts: run longer or move ``t_window``).

    Examples
    --------
    A uniform 3-node lattice released at the flat lift-off settles at once on the flat orbit:

    >>> import tps_solver as tps
    >>> orb = flat_stick_orbit(4.1)
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> run = tps.simulate(lat, 4.1, 0.0, np.zeros(3), np.zeros(3), t_start=orb.t_liftoff + 1e-9,
    ...                    t_end=orb.t_liftoff + 3 * orb.period)
    >>> p = pattern_from_fda(run, lat, orb.period)
    >>> [str(k) for k in p.kind[p.node == 1]], bool(np.max(np.abs(p.t[p.node == 1] - orb.t)) < 1e-9)
    (['bounce', 'stick'], True)
    """
    ev = run.events
    T = float(period)
    n = lattice.n_nodes
    if t_window is None:
        lo = run.t - 1.5 * T
        sel = ev.t[(ev.t > lo) & (ev.t < lo + T)]
        ph = np.sort(np.concatenate([[lo, lo + T], sel]))
        gap = np.argmax(np.diff(ph))
        t_window = 0.5 * (ph[gap] + ph[gap + 1])
    A = np.asarray(lattice.operator)
    node, kind, t, J, tau = [], [], [], [], []
    for j in range(n):
        e_j = ev[ev.node == j]
        inside = np.nonzero((e_j.t >= t_window) & (e_j.t < t_window + T) & (e_j.kind != "liftoff"))[0]
        for i in inside:
            node.append(j)
            t.append(float(e_j.t[i]))
            J.append(-float(e_j.w_before[i]))
            if e_j.kind[i] == "stick":
                later = np.nonzero((e_j.kind == "liftoff") & (e_j.t >= e_j.t[i]))[0]
                if later.size == 0:
                    raise ValueError(f"the FDA run ends before node {j} lifts off: run longer")
                kind.append("stick")
                tau.append(float(e_j.t[later[0]]))
            else:
                kind.append("bounce")
                tau.append(math.nan)
    node, t, tau = np.array(node), np.array(t), np.array(tau)
    trigger = np.full(node.size, -1)
    shift = np.zeros(node.size, dtype=int)
    for c in np.nonzero(np.isfinite(tau))[0]:
        j = node[c]
        nb = np.nonzero((A[j] != 0) & (np.arange(n) != j))[0]
        cand = np.nonzero(np.isin(node, nb))[0]
        if cand.size == 0:
            continue
        m = np.round((tau[c] - t[cand]) / T)
        d = np.abs(tau[c] - t[cand] - m * T)
        k = np.argmin(d)
        if d[k] < tol:
            trigger[c], shift[c] = cand[k], int(m[k])
    return _make_pattern(node, kind, t, np.array(J), tau, trigger, shift, n, T)


def _same_lattice(a, b):
    return (a is b) or (a.n_nodes == b.n_nodes and a.geometry == b.geometry and a.boundary == b.boundary
                        and np.allclose(a.nodes, b.nodes, rtol=1e-12, atol=1e-12))


def pattern_from_orbit(orbit, lattice=None, tol=1e-9):
    r"""Read the contact pattern of a converged periodic orbit found by shooting.

    The orbit (:class:`~tps_solver.solvers.shooting.periodic.ShootingOrbit`, point impacts) is integrated
    by the exact FDA integrator for 2.5 periods from its section state (its stuck nodes
    held), and :func:`pattern_from_fda` reads the contacts of the window of length T
    that starts in the largest event-free gap after half a period.  On a converged
    orbit (residual ~1e-12) the contact times are those of the orbit to that accuracy,
    so the pattern is the orbit's own (an unsettled time-stepped run may still carry
    transient touch-and-go landings).

    Parameters
    ----------
    orbit : ShootingOrbit
        Result of :func:`tps_solver.find_periodic_orbit` with ``method="exact"`` or
        ``"point"``, preferably converged.
    lattice : tps_solver.Lattice, optional
        If given, it must be the orbit's lattice.
    tol : float
        Coincidence tolerance for triggered lift-offs (see :func:`pattern_from_fda`).

    Returns
    -------
    StickPattern

    Raises
    ------
    ValueError
        If ``orbit`` is not a ShootingOrbit of point impacts, or ``lattice`` is not its lattice.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, multipliers=False)
    >>> p = pattern_from_orbit(orb)
    >>> [str(k) for k in p.kind[p.node == 0]], bool(np.all(p.trigger == -1))
    (['bounce', 'stick'], True)
    """
    from tps_solver.solvers.fda import simulate

    if not isinstance(orbit, ShootingOrbit):
        raise ValueError(f"orbit must be a ShootingOrbit (tps.find_periodic_orbit), got {type(orbit).__name__}")
    if orbit.method not in ("exact", "point"):
        raise ValueError(f"orbit.method must be 'exact' or 'point' (point impacts), got {orbit.method!r}")
    if lattice is not None and not _same_lattice(lattice, orbit.lattice):
        raise ValueError("lattice must be the orbit's lattice (same nodes, geometry and boundary)")
    T = orbit.period
    run = simulate(orbit.lattice, orbit.Gamma, orbit.e, orbit.w0, orbit.zeta0, t_start=orbit.t_start,
                   t_end=orbit.t_start + 2.5 * T, method="exact", stuck0=orbit.stuck0)
    if run.status != 0:
        raise ValueError(f"the FDA run on the orbit failed: {run.message}")
    return pattern_from_fda(run, orbit.lattice, T, tol=tol)


# ------------------------------------------------------------------ the problem
class _StickProblem:
    """Unknowns, requests and residual of the impact-and-stick TPS on a Neumann lattice.

    Unknowns ``x = [t (C), tau (S), J (C), coef]`` with ``theta = [t, tau]`` the times.
    Each stick interval is cut into *segments* at the impacts and lift-offs of its
    lattice neighbours that fall inside it (there the reaction jumps or kinks); every
    segment carries its own Legendre expansion of the reaction.  *Requests* are the
    values the equations need: ``w(t_c^-)`` ("minus"), the antiderivative ``W(t_c)``
    ("W"), ``w`` at the collocation points ("coll") and, on very short segments, the
    neighbours' ``w`` at the midpoint ("nbr").  Every request value is affine in ``J``
    and ``coef``: ``v = forcing + B_imp J + B_int coef + b_int.sum(1)``.
    """

    def __init__(self, modal, pattern, Gamma, e, n_basis, n_quad):
        self.m = modal
        self.p = pattern
        self.Gamma, self.e = Gamma, e
        self.T = T = pattern.period
        C = pattern.node.size
        self.C = C
        ell = pattern.tau - pattern.t
        is_stick = pattern.kind == "stick"
        # stick intervals below _COLLAPSE are an impact with w+ = 0 (their reaction impulse
        # ell |L w| is below ~1e-10)
        self.collapsed = is_stick & (ell < _COLLAPSE)
        self.stick = np.nonzero(is_stick & ~self.collapsed)[0]
        self.S = S = self.stick.size
        self.stick_of = np.full(C, -1)
        self.stick_of[self.stick] = np.arange(S)
        self.xq, self.wq = leggauss(n_quad)
        self.restit = np.where(pattern.kind == "bounce", 1.0 + e, 1.0)
        self.n_theta = C + S
        theta0 = np.concatenate([pattern.t, pattern.tau[self.stick]])
        A = modal.A
        nn = pattern.n_nodes
        # ---- segments: the reaction -(L w)_j jumps at a neighbour's impact and has weaker
        # singularities at events further away (graph distance d: impacts make a jump in the
        # (d-1)-th derivative, lift-offs one order weaker); cut at impacts with d <= 3 and
        # lift-offs with d <= 2
        adj = (A != 0) & ~np.eye(nn, dtype=bool)
        dist = np.full((nn, nn), 99)
        reach = np.eye(nn, dtype=bool)
        for d in range(1, _BREAK_DISTANCE + 1):
            reach = reach | (reach.astype(int) @ adj.astype(int) > 0)
            dist[(dist == 99) & reach] = d
        np.fill_diagonal(dist, 0)
        def canonical(idx, m):
            # a triggered lift-off *is* its trigger's impact (tau = t[trig] + shift T): the same
            # event, whatever the iterate
            if idx >= C:
                cc = self.stick[idx - C]
                if pattern.trigger[cc] >= 0:
                    return int(pattern.trigger[cc]), int(m + pattern.trigger_shift[cc])
            return int(idx), int(m)

        seg = []                      # (s, node, a_idx, a_shift, b_idx, b_shift)
        for s, c in enumerate(self.stick):
            j = pattern.node[c]
            a0, b0 = theta0[c], theta0[C + s]
            # the interval's own ends are never cuts, also where a neighbour event coincides
            # with them structurally (the impact that triggers this lift-off, a neighbour's
            # lift-off triggered by this landing) but not numerically at the initial iterate
            own = {(int(c), 0), canonical(C + s, 0)}
            pts = []
            for k in np.nonzero((dist[j, pattern.node] >= 1) & (dist[j, pattern.node] <= _BREAK_DISTANCE))[0]:
                cands = [(k, theta0[k])]
                if self.stick_of[k] >= 0 and dist[j, pattern.node[k]] < _BREAK_DISTANCE:
                    cands.append((C + self.stick_of[k], theta0[C + self.stick_of[k]]))
                for idx, tv in cands:
                    m = math.floor((a0 - tv) / T) + 1
                    while tv + m * T < b0:
                        tm = tv + m * T
                        key = canonical(idx, m)
                        if key not in own and a0 + _BREAK_MARGIN < tm < b0 - _BREAK_MARGIN:
                            pts.append((tm, key[0], key[1]))
                        m += 1
            pts.sort()
            kept, seen = [], set()
            for tm, idx, m in pts:         # one cut per event (a triggered lift-off is its trigger)
                if (idx, m) in seen:
                    continue
                if not kept or tm - kept[-1][0] > _BREAK_MARGIN:
                    kept.append((tm, idx, m))
                elif idx < C:
                    kept[-1] = (tm, idx, m)
                seen.add((idx, m))
            ends = [(c, 0)] + [(idx, m) for _, idx, m in kept] + [(C + s, 0)]
            for (ia, ma), (ib, mb) in zip(ends[:-1], ends[1:]):
                seg.append((s, j, ia, ma, ib, mb))
        self.G = len(seg)
        self.seg_s = np.array([g[0] for g in seg], dtype=int)
        self.seg_node = np.array([g[1] for g in seg], dtype=int)
        self.seg_a = np.array([g[2] for g in seg], dtype=int)
        self.seg_ash = np.array([g[3] for g in seg], dtype=float)
        self.seg_b = np.array([g[4] for g in seg], dtype=int)
        self.seg_bsh = np.array([g[5] for g in seg], dtype=float)
        lens = self.seg_ends(theta0)
        self.short = (lens[1] - lens[0]) < _SHORT
        seg_len = lens[1] - lens[0]
        self.nb = np.where(self.short, 1, np.where(seg_len < _MEDIUM, min(2, n_basis), n_basis)).astype(int)
        self.nbmax = int(self.nb.max()) if self.G else 1
        self.coef_off = np.concatenate([[0], np.cumsum(self.nb)]).astype(int)
        self.n_coef = int(self.coef_off[-1])
        self.last_seg = np.array([np.nonzero(self.seg_s == s)[0][-1] for s in range(S)], dtype=int)
        self.n_unknowns = self.n_theta + C + self.n_coef
        # ---- requests: (node, W, own, kind, ia, ca, ib, cb, const, seg)
        rows = []
        for c in range(C):
            rows.append((pattern.node[c], False, c, "minus", c, 1.0, -1, 0.0, 0.0, -1))
        for c in range(C):
            rows.append((pattern.node[c], True, -1, "W", c, 1.0, -1, 0.0, 0.0, -1))
        for g in range(self.G):
            j = self.seg_node[g]
            ia, ib, ma, mb = self.seg_a[g], self.seg_b[g], self.seg_ash[g], self.seg_bsh[g]
            if self.short[g]:
                for i in np.nonzero((A[j] != 0) & (np.arange(nn) != j))[0]:
                    rows.append((i, False, -1, "nbr", ia, 0.5, ib, 0.5, 0.5 * (ma + mb) * T, g))
            else:
                for xq in leggauss(self.nb[g])[0]:
                    ca, cb = (1 - xq) / 2, (1 + xq) / 2
                    rows.append((j, False, -1, "coll", ia, ca, ib, cb, (ca * ma + cb * mb) * T, g))
        self.rq_node = np.array([r[0] for r in rows], dtype=int)
        self.rq_W = np.array([r[1] for r in rows], dtype=bool)
        self.rq_own = np.array([r[2] for r in rows], dtype=int)
        self.rq_kind = np.array([r[3] for r in rows])
        self.rq_ia = np.array([r[4] for r in rows], dtype=int)
        self.rq_ca = np.array([r[5] for r in rows])
        self.rq_ib = np.array([r[6] for r in rows], dtype=int)
        self.rq_cb = np.array([r[7] for r in rows])
        self.rq_const = np.array([r[8] for r in rows])
        self.rq_g = np.array([r[9] for r in rows], dtype=int)
        self.E = len(rows)
        self.rows_of_theta = [np.nonzero((self.rq_ia == k) | (self.rq_ib == k))[0] for k in range(self.n_theta)]
        self.segs_of_theta = [np.nonzero((self.seg_a == k) | (self.seg_b == k))[0] for k in range(self.n_theta)]
        self.coll_rows = [np.nonzero((self.rq_g == g) & (self.rq_kind == "coll"))[0] for g in range(self.G)]
        self.nbr_rows = [np.nonzero((self.rq_g == g) & (self.rq_kind == "nbr"))[0] for g in range(self.G)]
        self.by_node = [np.nonzero(pattern.node == j)[0] for j in range(nn)]

    # --------------------------------------------------------------- packing
    def pack(self, t, tau_s, J, coef):
        return np.concatenate([t, tau_s, J, coef])

    def unpack(self, x):
        C, S = self.C, self.S
        return x[:C], x[C:C + S], x[C + S:2 * C + S], x[2 * C + S:]

    def initial(self):
        p = self.p
        return self.pack(p.t, p.tau[self.stick], p.J, np.zeros(self.n_coef))

    def seg_ends(self, theta, segs=None):
        segs = np.arange(self.G) if segs is None else segs
        return (theta[self.seg_a[segs]] + self.seg_ash[segs] * self.T,
                theta[self.seg_b[segs]] + self.seg_bsh[segs] * self.T)

    def request_times(self, theta, rows=None):
        rows = np.arange(self.E) if rows is None else np.asarray(rows, dtype=int)
        ib = self.rq_ib[rows]
        tb = np.where(ib >= 0, theta[np.maximum(ib, 0)], 0.0)
        return self.rq_ca[rows] * theta[self.rq_ia[rows]] + self.rq_cb[rows] * tb + self.rq_const[rows]

    # --------------------------------------------------------------- kernels
    def _impulse(self, req_node, req_time, req_W, req_own, imp, t, deriv=False):
        """R_{j,i}(tau) (or dR/dtau) for requests x impulses; shape (E, len(imp)) (in chunks of requests)."""
        E = req_node.size
        step = max(1, _CHUNK // max(1, imp.size * self.m.lam.size))
        if E <= step:
            return self._impulse_chunk(req_node, req_time, req_W, req_own, imp, t, deriv)
        out = np.empty((E, imp.size))
        for i in range(0, E, step):
            sl = slice(i, i + step)
            out[sl] = self._impulse_chunk(req_node[sl], req_time[sl], req_W[sl], req_own[sl], imp, t, deriv)
        return out

    def _impulse_chunk(self, req_node, req_time, req_W, req_own, imp, t, deriv=False):
        T, md = self.T, self.m
        tau = np.mod(req_time[:, None] - t[imp][None, :], T)
        tau = np.where(req_own[:, None] == imp[None, :], T, tau)
        out = np.empty(tau.shape)
        i = self.p.node[imp]
        for W in (False, True):
            r = np.nonzero(req_W == W)[0]
            if r.size == 0:
                continue
            kA = md.table(W)[0]
            j = req_node[r]
            ex = np.exp(md.lam[None, None, :] * tau[r][:, :, None])        # (E, X, P)
            VA = md.V[j] * (kA * (md.lam if deriv else 1.0))[None, :]
            core = np.einsum("ep,exp,px->ex", VA, ex, md.Vinv[:, i])
            MB, MC, MD = md.poly(W)
            tr = tau[r]
            if deriv:
                out[r] = core + MC[j][:, i] + 2 * MD[j][:, i] * tr
            else:
                out[r] = core + MB[j][:, i] + MC[j][:, i] * tr + MD[j][:, i] * tr * tr
        return out

    def _f_values(self, xi, s, nb):
        """Source values at points: Legendre P_0..P_{nb-1}(xi) padded, and -g(s) last."""
        Fv = np.zeros(s.shape + (self.nbmax + 1,))
        Fv[..., :self.nbmax] = legvander(xi, self.nbmax - 1)
        Fv[..., :self.nbmax] *= np.arange(self.nbmax) < np.reshape(nb, nb.shape + (1,) * (s.ndim - nb.ndim + 1))
        Fv[..., -1] = -(np.sin(s) - 1.0 / self.Gamma)
        return Fv

    def _intervals(self, req_node, req_time, req_W, segs, theta):
        """Responses of requests to segment sources; shape (E, len(segs), nbmax + 1).

        Evaluated in chunks of requests so that the (requests, segments, modes) temporaries
        stay below ~``_CHUNK`` elements (a 81-node kink has ~300 segments and 81 modes)."""
        E = req_node.size
        per = max(1, segs.size * self.m.lam.size)
        step = max(1, _CHUNK // per)
        if E <= step:
            return self._intervals_chunk(req_node, req_time, req_W, segs, theta)
        out = np.empty((E, segs.size, self.nbmax + 1))
        for i in range(0, E, step):
            sl = slice(i, i + step)
            out[sl] = self._intervals_chunk(req_node[sl], req_time[sl], req_W[sl], segs, theta)
        return out

    def _intervals_chunk(self, req_node, req_time, req_W, segs, theta):
        T, md = self.T, self.m
        E = req_node.size
        out = np.zeros((E, segs.size, self.nbmax + 1))
        if E == 0 or segs.size == 0:
            return out
        a, b = self.seg_ends(theta, segs)
        h = (b - a) / 2
        s = a[:, None] + h[:, None] * (1 + self.xq)[None, :]                 # (X, Q)
        wts = h[:, None] * self.wq[None, :]
        Fv = self._f_values(np.broadcast_to(self.xq, s.shape), s, self.nb[segs])
        u = b[:, None] - s
        i = self.seg_node[segs]
        tp = a[None, :] + np.mod(req_time[:, None] - a[None, :], T)           # (E, X) in [a, a+T)
        d = tp - b[None, :]
        inside = d < 0.0
        ex_u = np.exp(md.lam[None, None, :] * u[:, :, None])                 # (X, Q, P)
        mu = [np.einsum("xq,xqm->xm", wts * u ** k, Fv) for k in range(3)]
        dd = np.maximum(d, 0.0)
        for W in (False, True):
            r = np.nonzero(req_W == W)[0]
            if r.size == 0:
                continue
            kA = md.table(W)[0]
            Gx = np.einsum("xq,xqp,xqm->xmp", wts, ex_u, Fv) * (kA[None, :] * md.Vinv[:, i].T)[:, None, :]
            j = req_node[r]
            ed = np.exp(md.lam[None, None, :] * dd[r][:, :, None])
            val = np.einsum("ep,exp,xmp->exm", md.V[j], ed, Gx)
            MB, MC, MD = md.poly(W)
            mb, mc, mdd = MB[j][:, i][..., None], MC[j][:, i][..., None], MD[j][:, i][..., None]
            dr = dd[r][..., None]
            val += (mb * mu[0][None] + mc * (dr * mu[0][None] + mu[1][None])
                    + mdd * (dr ** 2 * mu[0][None] + 2 * dr * mu[1][None] + mu[2][None]))
            out[r] = val
        er, xr = np.nonzero(inside)
        if er.size:
            xq, wq = self.xq, self.wq
            aa, bb, tt = a[xr], b[xr], tp[er, xr]
            h1, h2 = (tt - aa) / 2, (bb - tt) / 2
            s1 = aa[:, None] + h1[:, None] * (1 + xq)
            s2 = tt[:, None] + h2[:, None] * (1 + xq)
            sq = np.concatenate([s1, s2], axis=1)
            wsq = np.concatenate([h1[:, None] * wq, h2[:, None] * wq], axis=1)
            tau = np.concatenate([tt[:, None] - s1, tt[:, None] - s2 + T], axis=1)
            xi = (2 * sq - (aa + bb)[:, None]) / (bb - aa)[:, None]
            Fq = self._f_values(xi, sq, self.nb[segs][xr])
            jn, inode = req_node[er], i[xr]
            Rk = np.empty(tau.shape)
            for W in (False, True):
                m = req_W[er] == W
                if not np.any(m):
                    continue
                kA, kB, kC, kD = md.table(W)
                ex = np.exp(md.lam[None, None, :] * tau[m][:, :, None])
                coefp = md.V[jn[m]] * md.Vinv[:, inode[m]].T
                tm = tau[m][..., None]
                Rk[m] = np.einsum("np,nqp->nq", coefp, kA * ex + kB + kC * tm + kD * tm * tm)
            out[er, xr] = np.einsum("nq,nq,nqm->nm", Rk, wsq, Fq)
        return out

    def _scatter(self, vals, segs):
        """(E, X, nbmax+1) -> B_int columns (E, sum nb[segs]) and b_int (E, X)."""
        cols = [vals[:, k, :self.nb[g]] for k, g in enumerate(segs)]
        B = np.concatenate(cols, axis=1) if cols else np.zeros((vals.shape[0], 0))
        return B, vals[:, :, -1]

    def _cols(self, segs):
        if len(segs) == 0:
            return np.zeros(0, dtype=int)
        return np.concatenate([np.arange(self.coef_off[g], self.coef_off[g + 1]) for g in segs])

    def evaluate(self, x, req_node, req_time, req_W, req_own=None):
        """Request values at arbitrary (node, time) pairs."""
        t, tau_s, J, coef = self.unpack(x)
        theta = x[:self.n_theta]
        own = np.full(req_node.size, -1) if req_own is None else req_own
        Bi = self._impulse(req_node, req_time, req_W, own, np.arange(self.C), t)
        Bn, bn = self._scatter(self._intervals(req_node, req_time, req_W, np.arange(self.G), theta),
                               np.arange(self.G))
        forcing = np.where(req_W, -np.sin(req_time), -np.cos(req_time))
        return forcing + Bi @ J + Bn @ coef + bn.sum(axis=1)

    def assemble(self, x):
        t = x[:self.C]
        theta = x[:self.n_theta]
        rt = self.request_times(theta)
        B_imp = self._impulse(self.rq_node, rt, self.rq_W, self.rq_own, np.arange(self.C), t)
        vals = self._intervals(self.rq_node, rt, self.rq_W, np.arange(self.G), theta)
        B_int, b_int = self._scatter(vals, np.arange(self.G))
        return dict(rt=rt, B_imp=B_imp, B_int=B_int, b_int=b_int)

    def values(self, x, st):
        t, tau_s, J, coef = self.unpack(x)
        rt = st["rt"]
        forcing = np.where(self.rq_W, -np.sin(rt), -np.cos(rt))
        return forcing + st["B_imp"] @ J + st["B_int"] @ coef + st["b_int"].sum(axis=1)

    def equations(self, x, v):
        """Residual from request values v and unknowns x (see the module docstring)."""
        t, tau_s, J, coef = self.unpack(x)
        theta = x[:self.n_theta]
        S, T, G, C = self.S, self.T, self.Gamma, self.C
        A = self.m.A
        vm, vW = v[:C], v[C:2 * C]
        F = [J + self.restit * vm]
        zeta = [vW[idx[1:]] - vW[idx[:-1]] for idx in self.by_node if idx.size > 1]
        F.append(np.concatenate(zeta) if zeta else np.zeros(0))
        a, b = self.seg_ends(theta)
        ell = b - a
        loc = []
        for g in range(self.G):
            if self.short[g]:
                r = self.nbr_rows[g]
                loc.append(np.atleast_1d(coef[self.coef_off[g]] + A[self.seg_node[g], self.rq_node[r]] @ v[r]))
            else:
                loc.append(v[self.coll_rows[g]] / max(ell[g], _COLL_SCALE))
        F.append(np.concatenate(loc) if loc else np.zeros(0))
        lift = np.empty(S)
        for s, c in enumerate(self.stick):
            trig = self.p.trigger[c]
            if trig >= 0:
                lift[s] = tau_s[s] - (t[trig] + self.p.trigger_shift[c] * T)
            else:
                g = self.last_seg[s]
                lift[s] = np.sum(coef[self.coef_off[g]:self.coef_off[g + 1]]) - (math.sin(tau_s[s]) - 1.0 / G)
        F.append(lift)
        mean = np.zeros(self.p.n_nodes)
        np.add.at(mean, self.p.node, J)
        np.add.at(mean, self.seg_node, ell * coef[self.coef_off[:-1]])
        ta, tb = t[self.stick], tau_s
        np.add.at(mean, self.p.node[self.stick], -(np.cos(ta) - np.cos(tb) - (tb - ta) / G))
        F.append(mean - T / G)
        return np.concatenate(F)

    def residual(self, x):
        st = self.assemble(x)
        v = self.values(x, st)
        return self.equations(x, v), st, v

    # --------------------------------------------------------------- jacobian
    def jacobian(self, x, st, v, F, times=True):
        """Dense Jacobian: exact in J and coef; in the times, the impulse kernels (which
        kink where two impacts coincide) analytically, the smooth rest by forward differences.
        ``times=False``: only the (cheap, exact) columns of the linear unknowns J and coef
        (the time columns are left unset)."""
        t, tau_s, J, coef = self.unpack(x)
        n = self.n_unknowns
        Jm = np.empty((F.size, n))
        dv_lin = np.concatenate([st["B_imp"], st["B_int"]], axis=1)
        base = self.equations(x, v)
        for k in range(self.n_theta, n):
            xk = x.copy()
            xk[k] += 1.0
            Jm[:, k] = self.equations(xk, v + dv_lin[:, k - self.n_theta]) - base
        if not times:
            return Jm
        rt = st["rt"]
        allg = np.arange(self.G)
        dR = self._impulse(self.rq_node, rt, self.rq_W, self.rq_own, np.arange(self.C), t, deriv=True)
        for k in range(self.n_theta):
            rows = self.rows_of_theta[k]
            kap = self.rq_ca[rows] * (self.rq_ia[rows] == k) + self.rq_cb[rows] * (self.rq_ib[rows] == k)
            segs = self.segs_of_theta[k]
            h = 1e-7 * max(1.0, abs(x[k]))
            if segs.size:
                a, b = self.seg_ends(x[:self.n_theta], segs)
                shortest = float(np.min(b - a))
                if shortest > 0.0:
                    h = min(h, 1e-3 * shortest)
            xk = x.copy()
            xk[k] += h
            thk = xk[:self.n_theta]
            dv = np.zeros(self.E)
            if rows.size:
                dv[rows] += kap * (dR[rows] @ J)
                rtr = rt[rows]
                dv[rows] += kap * np.where(self.rq_W[rows], -np.cos(rtr), np.sin(rtr))
            if k < self.C:
                dv -= dR[:, k] * J[k]
            rt_new = rt.copy()
            rt_new[rows] = self.request_times(thk, rows)
            delta = np.zeros(self.E)
            if rows.size:
                others = np.setdiff1d(allg, segs)
                if others.size:
                    vals = self._intervals(self.rq_node[rows], rt_new[rows], self.rq_W[rows], others, thk)
                    Bn, bn = self._scatter(vals, others)
                    cols = self._cols(others)
                    delta[rows] += (Bn @ coef[cols] + bn.sum(axis=1)
                                    - st["B_int"][rows][:, cols] @ coef[cols]
                                    - st["b_int"][rows][:, others].sum(axis=1))
            if segs.size:
                vals = self._intervals(self.rq_node, rt_new, self.rq_W, segs, thk)
                Bn, bn = self._scatter(vals, segs)
                cols = self._cols(segs)
                delta += (Bn @ coef[cols] + bn.sum(axis=1) - st["B_int"][:, cols] @ coef[cols]
                          - st["b_int"][:, segs].sum(axis=1))
            Jm[:, k] = (self.equations(xk, v + h * dv + delta) - base) / h
        return Jm


# ------------------------------------------------------------------ result
class StickSolution(Bunch):
    r"""A time-periodic orbit with impact-and-stick contacts.

    Attributes
    ----------
    converged, success : bool
    status : int
        0 converged; 1 iteration limit; 2 line search failed (no decrease of the residual);
        3 singular Jacobian or non-finite residual.
    message : str
    nit : int
    residual : float
        Final max-norm of the residual (the equations in the module docstring).
    residual_history : ndarray of float, shape (nit + 1,)
    nodes : ndarray of float, shape (n_nodes,)
    contact_times : ndarray of float, shape (n_nodes, K)
        Impact times per node (nan where a node has fewer than K contacts).
    contact_kinds : ndarray of str, shape (n_nodes, K)
        ``"bounce"`` / ``"stick"`` ("" where absent).
    liftoff_times : ndarray of float, shape (n_nodes, K)
        Lift-off after each stick contact (nan for a bounce).
    impulses : ndarray of float, shape (n_nodes, K)
        Velocity jumps at the impacts.
    pattern : StickPattern
        The solved pattern (flat arrays over contacts).
    w_hat : ndarray of complex, shape (2N+1, n_nodes)
        Velocity harmonics n = -N..N (computed from the source in closed form), N = ``n_harmonics``.
    period, Gamma, e : float
    M, K : int
    checks : Bunch
        ``stick_w_max`` (max |w| on the stick intervals between collocation points),
        ``min_zeta``, ``min_reaction`` (min of the plate reaction on stick intervals),
        ``touch_and_go_acceleration`` (min free acceleration just after bounces, e = 0),
        ``all_pass``.
    time, solve_time : float
        Wall-clock seconds of the whole call and of the Newton solve alone (without the
        checks and harmonics).

    Examples
    --------
    >>> sol = solve_stick_flat(4.1, perturbation=1e-3)
    >>> sol.converged, sol.K, [str(k) for k in sol.contact_kinds[0]]
    (True, 2, ['bounce', 'stick'])
    >>> bool(abs(sol.velocity([sol.liftoff_times[0, 1] - 0.1])[0, 0]) < 1e-12)   # stuck: w = 0
    True
    """

    def velocity(self, t):
        """Velocity w(t) at the nodes (post-impact value at an impact instant).

        Parameters
        ----------
        t : array_like of float, shape (n_times,)

        Returns
        -------
        ndarray of float, shape (n_times, n_nodes)
        """
        return self._eval(t, False)

    def height(self, t):
        """Height zeta(t) at the nodes, zeta = 0 at each node's first contact.

        Parameters
        ----------
        t : array_like of float, shape (n_times,)

        Returns
        -------
        ndarray of float, shape (n_times, n_nodes)
        """
        z = self._eval(t, True)
        first = np.array([idx[0] for idx in self._problem.by_node])
        ref = self._eval_at(self._problem.p.node[first], self._t[first], True)
        return z - ref[None, :]

    def _eval_at(self, nodes, times, integral):
        return self._problem.evaluate(self._x, nodes, times, np.full(nodes.size, bool(integral)))

    def _eval(self, t, integral):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        n = self.nodes.size
        nodes = np.tile(np.arange(n), t.size)
        times = np.repeat(t, n)
        return self._eval_at(nodes, times, integral).reshape(t.size, n)


def _newton(problem, x, tol, max_iter):
    """Newton's method with a reused (chord) Jacobian while it contracts by 10 per step."""
    F, st, v = problem.residual(x)
    lu, fresh = None, False
    # the residual is affine in the impulses and reaction coefficients: start with their
    # least-squares values for the initial times (the initial reaction is unknown)
    # (only the cheap linear columns are needed for that; the time columns, the expensive part
    # of the Jacobian, are computed only if the times must move)
    if problem.n_unknowns > problem.n_theta:
        Jm = problem.jacobian(x, st, v, F, times=False)
        step = np.linalg.lstsq(Jm[:, problem.n_theta:], -F, rcond=None)[0]
        x_lin = x.copy()
        x_lin[problem.n_theta:] += step
        F_lin, st_lin, v_lin = problem.residual(x_lin)
        if np.max(np.abs(F_lin)) < np.max(np.abs(F)):
            x, F, st, v = x_lin, F_lin, st_lin, v_lin
    history = [float(np.max(np.abs(F)))]
    status, message, nit = 1, f"iteration limit ({max_iter}) reached", 0
    n_jac = 0
    nit = 0
    while nit < max_iter:
        if history[-1] <= tol:
            break
        if lu is None:
            lu = _factor(problem.jacobian(x, st, v, F))
            n_jac += 1
            fresh = True
        if isinstance(lu, str):
            status, message = 3, f"singular or non-finite Jacobian at iteration {nit + 1}: {lu}"
            break
        with np.errstate(all="ignore"):
            dx = -lu_solve(lu, F)
        if not np.all(np.isfinite(dx)):
            if not fresh:
                lu = None
                continue
            status, message = 3, f"non-finite Newton step at iteration {nit + 1}"
            break
        # keep times ordered: limit the time step
        cap = 0.25
        big = np.max(np.abs(dx[:problem.n_theta])) if problem.n_theta else 0.0
        if big > cap:
            dx *= cap / big
        lam, accepted = 1.0, False
        while lam >= 1.0 / 256:
            trial = x + lam * dx
            try:
                _validate_times(problem, trial)
                F_t, st_t, v_t = problem.residual(trial)
                r_t = float(np.max(np.abs(F_t)))
            except ValueError:
                r_t = math.inf
            if np.isfinite(r_t) and (r_t < (1.0 - 1e-4 * lam) * history[-1] or r_t <= tol):
                accepted = True
                break
            lam *= 0.5 if fresh else 0.0
        if not accepted:
            if not fresh:
                lu = None
                continue
            status = 2
            message = (f"Newton stagnated at iteration {nit + 1}: no decrease of max|F| = {history[-1]:.3e} "
                       "along the Newton direction; try a better initial pattern (a longer FDA run) or "
                       "more reaction terms (n_basis)")
            break
        nit += 1
        if r_t > 0.1 * history[-1]:
            lu = None
        fresh = False
        x, F, st, v = trial, F_t, st_t, v_t
        history.append(r_t)
    if history[-1] <= tol:
        status, message = 0, f"converged: max|F| = {history[-1]:.3e} <= tol = {tol:.1e}"
    elif status == 1:
        message += f" with max|F| = {history[-1]:.3e}; raise max_iter or improve the initial pattern"
    return x, status, message, nit, history


def _factor(Jm):
    try:
        return lu_factor(Jm, check_finite=True)
    except (ValueError, np.linalg.LinAlgError) as exc:
        return str(exc)


def _validate_times(problem, x):
    t, tau_s, _, _ = problem.unpack(x)
    a, b = problem.seg_ends(x[:problem.n_theta])
    if np.any(b <= a):
        raise ValueError("a stick segment collapsed")
    for idx in problem.by_node:
        tj = t[idx]
        if np.any(np.diff(tj) <= 0) or tj[-1] - tj[0] >= problem.T:
            raise ValueError("contact order changed")


def _harmonics(problem, x, N):
    """Velocity harmonics from the source in closed form: w_n = (i n alpha - A)^-1 s_n."""
    t, tau_s, J, coef = problem.unpack(x)
    T, M = problem.T, round(problem.T / (2 * math.pi))
    n = np.arange(-N, N + 1)
    om = n / M
    nn = problem.p.n_nodes
    s = np.zeros((2 * N + 1, nn), dtype=complex)
    # sin t - 1/Gamma on the whole period
    if M <= N:
        s[N + M] += -0.5j
        s[N - M] += 0.5j
    s[N] += -1.0 / problem.Gamma
    for c in range(problem.C):
        s[:, problem.p.node[c]] += J[c] * np.exp(-1j * om * t[c]) / T
    xq, wq = leggauss(48)
    sa, sb = problem.seg_ends(x[:problem.n_theta])
    for k in range(problem.G):
        a, b = sa[k], sb[k]
        sq = a + (b - a) * (1 + xq) / 2
        P = legvander(xq, problem.nb[k] - 1)
        f = P @ coef[problem.coef_off[k]:problem.coef_off[k + 1]] - (np.sin(sq) - 1 / problem.Gamma)
        s[:, problem.seg_node[k]] += (np.exp(-1j * np.outer(om, sq)) @ (wq * f)) * (b - a) / 2 / T
    w = np.zeros_like(s)
    A = problem.m.A
    for k, o in enumerate(om):
        if n[k] == 0:
            continue
        w[k] = np.linalg.solve(1j * o * np.eye(nn) - A, s[k])
    return w


def _to_table(problem, values, fill):
    K = max(idx.size for idx in problem.by_node)
    out = np.full((problem.p.n_nodes, K), fill, dtype=np.asarray(values).dtype if fill != "" else "U6")
    for j, idx in enumerate(problem.by_node):
        out[j, :idx.size] = values[idx]
    return out


def _checks(sol, problem, x):
    t, tau_s, J, coef = problem.unpack(x)
    T, G = problem.T, problem.Gamma
    # w on stick intervals between the collocation points, and the reaction there
    stick_w, min_reac = 0.0, math.inf
    sa, sb = problem.seg_ends(x[:problem.n_theta])
    for k in range(problem.G):
        a, b = sa[k], sb[k]
        ts = a + (b - a) * np.linspace(0.02, 0.98, 9)
        j = problem.seg_node[k]
        wv = sol._eval_at(np.full(ts.size, j), ts, False)
        stick_w = max(stick_w, float(np.max(np.abs(wv))))
        xi = 2 * (ts - a) / (b - a) - 1
        rho = legvander(xi, problem.nb[k] - 1) @ coef[problem.coef_off[k]:problem.coef_off[k + 1]]
        min_reac = min(min_reac, float(np.min(rho - (np.sin(ts) - 1 / G))))
    # heights between contacts
    tt = np.linspace(0.0, T, 1024, endpoint=False)
    zeta = sol.height(tt)
    min_zeta = float(np.min(zeta))
    # free acceleration just after a touch-and-go (e = 0): g + (A w)_j at t+
    acc = math.inf
    bounce = np.nonzero(problem.p.kind == "bounce")[0]
    if problem.e == 0.0 and bounce.size:
        for c in bounce:
            tp = t[c] + 1e-9
            w_all = sol.velocity([tp])[0]
            w_all[problem.p.node[c]] = 0.0
            acc = min(acc, float(math.sin(tp) - 1 / G + problem.m.A[problem.p.node[c]] @ w_all))
    scale = max(1.0, float(np.max(np.abs(zeta))))
    ok = (stick_w < 1e-6) and (min_zeta > -1e-8 * scale) and (min_reac > -1e-8) and (acc > -1e-8)
    return Bunch(stick_w_max=stick_w, min_zeta=min_zeta, min_reaction=min_reac,
                 touch_and_go_acceleration=acc, all_pass=bool(ok))


def _solve_pattern(modal, pattern, lattice_nodes, Gamma, M, e, n_basis, n_quad, tol, max_iter,
                   n_harmonics):
    start = time.perf_counter()
    problem = _StickProblem(modal, pattern, Gamma, e, n_basis, n_quad)
    x, status, message, nit, history = _newton(problem, problem.initial(), tol, max_iter)
    solve_time = time.perf_counter() - start
    t, tau_s, J, coef = problem.unpack(x)
    tau_full = np.full(problem.C, np.nan)
    tau_full[problem.stick] = tau_s
    for c in np.nonzero(problem.collapsed)[0]:      # zero-length sticks: lift-off at the impact
        trig = pattern.trigger[c]
        tau_full[c] = t[trig] + pattern.trigger_shift[c] * problem.T if trig >= 0 else t[c]
    solved = StickPattern(dict(pattern))
    solved.update(t=t.copy(), J=J.copy(), tau=tau_full)
    sol = StickSolution(
        converged=status == 0, success=status == 0, status=status, message=message, nit=nit,
        residual=history[-1], residual_history=np.asarray(history), nodes=np.asarray(lattice_nodes, float),
        contact_times=_to_table(problem, t, np.nan), contact_kinds=_to_table(problem, pattern.kind, ""),
        liftoff_times=_to_table(problem, tau_full, np.nan), impulses=_to_table(problem, J, np.nan),
        pattern=solved, period=problem.T, Gamma=Gamma, e=e, M=M,
        K=int(max(idx.size for idx in problem.by_node)), n_basis=n_basis, n_quad=n_quad)
    if status != 0:
        sol.message += " (the fields hold the last iterate, not a solution)"
    sol._problem, sol._x, sol._t = problem, x, t
    sol.w_hat = _harmonics(problem, x, n_harmonics)
    sol.checks = _checks(sol, problem, x)
    sol.time = time.perf_counter() - start
    sol.solve_time = solve_time
    return sol


def _check_args(Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics):
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    e = check_restitution(e, "e")
    n_basis = check_int(n_basis, "n_basis", minimum=1, maximum=12)
    n_quad = check_int(n_quad, "n_quad", minimum=2, maximum=128)
    tol = check_positive(tol, "tol")
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    n_harmonics = check_int(n_harmonics, "n_harmonics", minimum=1)
    return Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics


# ------------------------------------------------------------------ front ends
def solve_stick_flat(Gamma=4.1, M=2, e=0.0, n_harmonics=32, *, n_nodes=1, length=1.0,
                     perturbation=0.0, n_basis=4, n_quad=16, tol=1e-13, max_iter=20):
    r"""The flat e = 0 orbit solved by the impact-and-stick TPS from a (perturbed) uniform start.

    The contact pattern is that of :func:`flat_stick_orbit` (touch-and-go, then
    stick until lift-off at :math:`\sin t_L = 1/\Gamma`), put on a uniform Neumann
    lattice of ``n_nodes`` nodes; the Newton solve starts from the closed-form
    times shifted by ``perturbation`` and must return them.

    Parameters
    ----------
    Gamma : float
    M : int
    e : float
        Must be 0 (the flat orbit with sticking is the completely inelastic one).
    n_harmonics : int
        N of the returned ``w_hat``.
    n_nodes : int, keyword-only
    length : float, keyword-only
        Lattice length (irrelevant for a flat layer; ``n_nodes >= 2`` only).
    perturbation : float, keyword-only
        Shift of all initial times and impulses (a test of the Newton solve).
    n_basis, n_quad, tol, max_iter
        As in :func:`solve_stick_lattice`.

    Returns
    -------
    StickSolution
        With ``exact`` (the :func:`flat_stick_orbit` bunch).

    Examples
    --------
    >>> sol = solve_stick_flat(4.1, perturbation=1e-3)
    >>> orb = flat_stick_orbit(4.1)
    >>> bool(sol.converged and np.max(np.abs(sol.contact_times[0] - orb.t)) < 1e-12)
    True
    """
    from tps_solver.solvers.fda import Lattice

    Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics = _check_args(
        Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics)
    if e != 0.0:
        raise ValueError(f"e must be 0 for the flat stick orbit (for e > 0 use tps.FlatLayer), got {e}")
    n_nodes = check_int(n_nodes, "n_nodes", minimum=1)
    perturbation = check_real(perturbation, "perturbation")
    orb = flat_stick_orbit(Gamma, M)
    K = orb.t.size
    if n_nodes == 1:
        lat = Bunch(nodes=np.zeros(1), volumes=np.ones(1), flux=np.zeros((1, 1)),
                    operator=np.zeros((1, 1)), n_nodes=1)
    else:
        lat = Lattice.planar(n_nodes=n_nodes, length=check_positive(length, "length"),
                             boundary="neumann")
    node = np.repeat(np.arange(n_nodes), K)
    pat = _make_pattern(node, np.tile(orb.kind, n_nodes), np.tile(orb.t + perturbation, n_nodes),
                        np.tile(-orb.w_minus + perturbation, n_nodes),
                        np.tile(orb.tau + perturbation, n_nodes), np.full(node.size, -1),
                        np.zeros(node.size, dtype=int), n_nodes, orb.period)
    sol = _solve_pattern(_Modal(lat, orb.period), pat, lat.nodes, Gamma, M, e, n_basis, n_quad, tol, max_iter,
                         n_harmonics)
    sol.exact = orb
    w, z = _flat_functions(orb)
    sol._flat_state = (w, z)
    return sol


def _flat_functions(orb):
    """Vectorised closed-form w(t), zeta(t) of the flat e = 0 orbit (zeta = 0 at the first contact)."""
    T, G, tL = orb.period, orb.Gamma, orb.t_liftoff
    starts = np.concatenate([[tL], orb.t[orb.kind == "bounce"]])
    ends = orb.t
    # flights: [starts[k], ends[k]) with starts[0] = tL, then each bounce restarts from rest
    flights = []
    s = tL
    for k in range(orb.t.size):
        flights.append((s, orb.t[k]))
        if orb.kind[k] == "bounce":
            s = orb.t[k]
        else:
            s = orb.tau[k]
    del starts, ends

    def w(t):
        t = np.asarray(t, dtype=float)
        ph = tL + np.mod(t - tL, T)
        out = np.zeros_like(ph)
        for a, b in flights:
            m = (ph >= a) & (ph < b)
            out[m] = np.cos(a) - np.cos(ph[m]) - (ph[m] - a) / G
        return out

    def z(t):
        t = np.asarray(t, dtype=float)
        ph = tL + np.mod(t - tL, T)
        out = np.zeros_like(ph)
        for a, b in flights:
            m = (ph >= a) & (ph < b)
            d = ph[m] - a
            out[m] = np.cos(a) * d + np.sin(a) - np.sin(ph[m]) - d * d / (2 * G)
        return out

    return w, z


def solve_stick_lattice(lattice, Gamma=4.1, M=2, e=0.0, pattern=None, *, w0=None, zeta0=None,
                        t_start=None, periods=20, n_basis=8, n_quad=16, tol=1e-10, max_iter=15,
                        n_harmonics=32, refresh=1, shoot=True):
    r"""Periodic orbit with impact-and-stick contacts on a Neumann FDA lattice.

    Parameters
    ----------
    lattice : tps_solver.Lattice
        Planar or axisymmetric lattice with Neumann ends.
    Gamma : float
    M : int
    e : float
        Restitution of ``"bounce"`` contacts, in [0, 1) (stick contacts end with w = 0).
    pattern : StickPattern or ShootingOrbit, optional
        Contact pattern with initial values, or a periodic orbit found by shooting
        (:func:`tps_solver.find_periodic_orbit` on ``lattice`` with the same ``Gamma``,
        ``M``, ``e``), whose pattern and times are read by :func:`pattern_from_orbit`
        (recommended: a converged orbit carries the orbit's own pattern).  Default: read from a time-stepped FDA run
        (``tps.simulate``, exact integrator, ``periods`` periods) from ``w0, zeta0`` at
        ``t_start`` (default: :func:`kink_state`), see :func:`pattern_from_fda`.
    w0, zeta0 : array_like of float, shape (n_nodes,), keyword-only
    t_start : float, keyword-only
    periods : int, keyword-only
    n_basis : int, keyword-only
        Legendre terms of the reaction per stick segment (1..12; default 8: with 6 the dx = 0.5
        e = 0 kink agrees with the FDA only to 5e-7 in lift-off times).
    n_quad : int, keyword-only
        Gauss-Legendre points per quadrature sub-interval.
    tol : float, keyword-only
        Target of the max-norm residual.
    max_iter : int, keyword-only
    n_harmonics : int, keyword-only
        N of the returned ``w_hat``.
    refresh : int, keyword-only
        If Newton fails, re-read the pattern from a 3-period FDA run started on the last
        iterate and solve again, up to this many times.
    shoot : bool, keyword-only
        Without ``pattern``: converge the FDA run's final state to a periodic orbit by
        shooting (:func:`tps_solver.find_periodic_orbit`) and read the pattern from that
        orbit (:func:`pattern_from_orbit`); the pattern of an unsettled run may be wrong
        (a transient touch-and-go, a missing triggered lift-off), and its times are far
        from the orbit's along the slowly decaying front mode, where Newton does not
        converge.  If shooting fails the FDA run's pattern is used (``pattern_source``
        says so).  False: the FDA run's pattern.

    Returns
    -------
    StickSolution
        Also ``fda`` (the FDA run of the default start, if any), ``orbit`` (the shooting
        orbit the pattern came from, if any), ``lattice`` and ``pattern_source``.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=5, length=8.0)
    >>> sol = solve_stick_lattice(lat, 4.1, periods=12)
    >>> sol.converged, sol.contact_times.shape
    (True, (5, 2))
    """
    from tps_solver.solvers.fda import Lattice, simulate

    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    if lattice.boundary != "neumann":
        raise ValueError(f"lattice.boundary must be 'neumann', got {lattice.boundary!r}")
    Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics = _check_args(
        Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics)
    T = 2 * math.pi * M
    run = orbit = None
    if pattern is None:
        periods = check_int(periods, "periods", minimum=2)
        if w0 is None or zeta0 is None:
            t_start, w0, zeta0 = kink_state(lattice, Gamma, M)
        elif t_start is None:
            t_start = 0.0
        run = simulate(lattice, Gamma, e, w0, zeta0, t_start=t_start, t_end=t_start + periods * T,
                       method="exact")
        if run.status != 0:
            raise ValueError(f"the FDA run for the initial pattern failed: {run.message}")
        source = f"FDA run of {periods} periods (exact integrator)"
        if shoot:
            orbit = find_periodic_orbit(lattice, Gamma=Gamma, M=M, e=e, guess=run, max_iter=80,
                                        multipliers=False)
        if orbit is not None and orbit.converged:
            pattern = pattern_from_orbit(orbit)
            source += f", then shooting (residual {orbit.residual:.1e})"
        else:
            pattern = pattern_from_fda(run, lattice, T)
            if orbit is not None:
                source += f" (shooting did not converge: {orbit.message}; pattern of the FDA run)"
    elif isinstance(pattern, ShootingOrbit):
        if not _same_lattice(lattice, pattern.lattice):
            raise ValueError("pattern (a ShootingOrbit) must be an orbit on this lattice (same nodes, "
                             f"geometry and boundary); got one on {pattern.lattice.n_nodes} nodes")
        if abs(pattern.period - T) > 1e-12 or abs(pattern.Gamma - Gamma) > 1e-12 or pattern.e != e:
            raise ValueError(f"pattern (a ShootingOrbit) must have Gamma = {Gamma}, period 2 pi M = {T:.6g} "
                             f"and e = {e}; got Gamma = {pattern.Gamma}, period {pattern.period:.6g}, "
                             f"e = {pattern.e}")
        source = f"shooting orbit (residual {pattern.residual:.1e})"
        orbit = pattern
        pattern = pattern_from_orbit(pattern)
    else:
        if not isinstance(pattern, StickPattern):
            raise ValueError(f"pattern must be a StickPattern or a ShootingOrbit, got {type(pattern).__name__}")
        if pattern.n_nodes != lattice.n_nodes or abs(pattern.period - T) > 1e-12:
            raise ValueError("pattern must be for this lattice (n_nodes) and period 2 pi M")
        _check_pattern(pattern)
        source = "user pattern"
    modal = _Modal(lattice, T)
    sol = _solve_pattern(modal, pattern, lattice.nodes, Gamma, M, e, n_basis, n_quad, tol,
                         max_iter, n_harmonics)
    sol.fda = run
    sol.orbit = orbit
    sol.lattice = lattice
    refresh = check_int(refresh, "refresh", minimum=0)
    for k in range(refresh):
        if sol.converged:
            break
        # no solution with this pattern near the start: re-read the pattern from the FDA
        # started on the last iterate (the transient's pattern may differ from the orbit's)
        chk = check_with_fda(sol, periods=3)
        if chk.run.status != 0:
            break
        try:
            pattern = pattern_from_fda(chk.run, lattice, T)
        except ValueError:
            break
        source += f"; pattern re-read from an FDA run on the last iterate ({k + 1})"
        sol = _solve_pattern(modal, pattern, lattice.nodes, Gamma, M, e, n_basis, n_quad, tol,
                             max_iter, n_harmonics)
        sol.fda = run
        sol.orbit = orbit
        sol.lattice = lattice
    sol.pattern_source = source
    return sol


def check_with_fda(sol, periods=1, t_start=None):
    r"""Time-step the FDA (exact integrator) from the TPS state and compare the events.

    Parameters
    ----------
    sol : StickSolution
        A lattice solution (``sol.lattice`` set).
    periods : int
        Periods to integrate.
    t_start : float, optional
        Start time; default: the middle of the largest event-free gap of the TPS orbit.

    Returns
    -------
    Bunch
        ``contact_error`` and ``liftoff_error`` (max over nodes and periods of the
        distance between each TPS time and the nearest FDA event of the same node
        and type), ``events_per_period`` (FDA impacts+sticks per node and period, shape
        (n_nodes,)), ``run`` (the FDA result), ``t_start``.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> orb = tps.find_periodic_orbit(lat, Gamma=4.1, M=2, e=0.0, multipliers=False)
    >>> sol = solve_stick_lattice(lat, 4.1, pattern=orb)
    >>> chk = check_with_fda(sol, periods=2)
    >>> bool(chk.contact_error < 1e-10 and chk.liftoff_error < 1e-10), chk.events_per_period.tolist()
    (True, [2.0, 2.0, 2.0])
    """
    from tps_solver.solvers.fda import simulate

    lat = sol.lattice
    T = sol.period
    p = sol.pattern
    periods = check_int(periods, "periods", minimum=1)
    if t_start is None:
        ev = np.mod(np.concatenate([p.t, p.tau[np.isfinite(p.tau)]]), T)
        ph = np.sort(np.concatenate([ev, ev[:1] + T]))
        k = int(np.argmax(np.diff(ph)))
        t_start = 0.5 * (ph[k] + ph[k + 1])
    w0 = sol.velocity([t_start])[0]
    z0 = sol.height([t_start])[0]
    # nodes inside a stick interval at t_start are held on the plate
    stuck = np.zeros(p.n_nodes, dtype=bool)
    for c in np.nonzero(p.kind == "stick")[0]:
        ph = p.t[c] + np.mod(t_start - p.t[c], T)
        if ph < p.tau[c]:
            stuck[p.node[c]] = True
    w0 = np.where(stuck, 0.0, w0)
    z0 = np.where(stuck, 0.0, np.maximum(z0, 0.0))
    run = simulate(lat, sol.Gamma, sol.e, w0, z0, t_start=t_start, t_end=t_start + periods * T,
                   method="exact", stuck0=stuck)
    ev = run.events
    c_err, l_err = 0.0, 0.0
    counts = np.zeros(p.n_nodes)
    for j in range(p.n_nodes):
        e_j = ev[ev.node == j]
        imp = e_j.t[e_j.kind != "liftoff"]
        lif = e_j.t[e_j.kind == "liftoff"]
        counts[j] = imp.size / periods
        for c in np.nonzero(p.node == j)[0]:
            for m in range(periods):
                tc = t_start + np.mod(p.t[c] - t_start, T) + m * T
                c_err = max(c_err, float(np.min(np.abs(imp - tc))) if imp.size else math.inf)
                if np.isfinite(p.tau[c]):
                    tl = tc + (p.tau[c] - p.t[c])
                    if tl < run.t:
                        l_err = max(l_err, float(np.min(np.abs(lif - tl))) if lif.size else math.inf)
    return Bunch(contact_error=c_err, liftoff_error=l_err, events_per_period=counts, run=run,
                 t_start=t_start)
