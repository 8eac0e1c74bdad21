r"""Kinks and oscillons on FDA lattices, any contact pattern: :func:`lattice_kink`, :func:`lattice_oscillon`.

The user's question -- *is there a periodic kink (or oscillon) at these parameters, on this
lattice, and is it stable?* -- in one call, for every contact model of the package:
point impacts with any restitution :math:`0 \le e < 1` (including the completely
inelastic layer, whose nodes stick to the plate every period) and the soft contact
of cut-off length :math:`\ell`.

Recipe (the one of Sec. 4.3.1 of the paper, completed by a Newton solve):

1. **Far field.**  The flat layer of the chosen model: :class:`~tps_solver.FlatLayer`
   with the requested ``pattern`` (single bounce, stick, touch-and-go) for point
   impacts, :class:`~tps_solver.SoftFlatOrbit` for the soft contact.
2. **Start.**  A kink: the flat orbit for :math:`x < 0` and the same orbit half a
   period later for :math:`x > 0`, joined linearly over ``width``
   (:func:`tps_solver.solvers.fda.kink_state`).  An oscillon: the shifted orbit inside the
   core :math:`r < r_c` of an axisymmetric lattice (:func:`tps_solver.solvers.fda.oscillon_state`).
   The start time is a quarter period after the lift-off when the far field sticks
   (the start of the e = 0 studies), otherwise the one, on a grid of the period, where
   the lower of the two far-field heights is largest (both halves in flight).
3. **Settle.**  ``periods`` periods of :func:`~tps_solver.simulate`, which removes the
   fast transients of the start.
4. **Solve.**  :func:`~tps_solver.find_periodic_orbit` (Newton--Krylov shooting) from
   the settled state: the periodic orbit with whatever contact pattern the
   dynamics chose, its residual and its Floquet multipliers.

The result is the :class:`~tps_solver.solvers.shooting.periodic.ShootingOrbit` of step 4 (its
``residual_history[0]`` is the periodicity defect after step 3).  If the settling
run fails (an event bound, chatter), the start state itself goes to Newton and the
message says so.

:func:`front_width` measures the 10--90 % width of a kink's front, and
:func:`interface_position` where a profile crosses a level (the radius of an
oscillon's core).
"""
import time

import numpy as np

from tps_solver.core.orbit import STATUS, far_field
from tps_solver.core.checks import check_choice, check_int, check_nonnegative, check_positive, check_real
from tps_solver.core.orbit import STATUS
from tps_solver.core.costs import check_cost, period_map_seconds, shooting_maps
from tps_solver.solvers.fda import kink_state, oscillon_state, simulate
from tps_solver.model.flat import FlatLayer
from tps_solver.model.soft_flat import SoftFlatOrbit
from tps_solver.operators.lattice import Lattice
from tps_solver.solvers.shooting.periodic import find_periodic_orbit
from tps_solver.solvers.shooting.symmetric import mirror_symmetric, solve_mirrored

#: Default Newton steps of the shooting of :func:`lattice_kink` and :func:`lattice_oscillon` (the
#: front's near-neutral multiplier makes Newton--Krylov converge linearly: 33 steps at
#: Gamma = 4.1, e = 0, dx = 1).
MAX_ITER = 80

__all__ = ["lattice_kink", "lattice_oscillon", "front_width", "interface_position", "core_radius"]


class _SoftFarField:
    """``velocity(t)``/``height(t)`` of the soft flat orbit (flight times only)."""

    def __init__(self, orbit):
        self.orbit = orbit
        self.period, self.Gamma, self.e = orbit.period, orbit.Gamma, orbit.e

    def in_flight(self, t):
        return (t - self.orbit.t_exit) % self.period <= self.orbit.flight

    def velocity(self, t):
        return self.orbit.state(t)[0]

    def height(self, t):
        return self.orbit.state(t)[1]


def _far_field(Gamma, M, e, cutoff, pattern):
    if cutoff is None:
        return FlatLayer(Gamma, M, e=e, pattern=pattern)
    if pattern != "auto":
        raise ValueError(f"pattern applies to point impacts only (cutoff=None), got pattern={pattern!r} "
                         f"with cutoff={cutoff!r}")
    return _SoftFarField(SoftFlatOrbit(Gamma, M, e, cutoff))


def _start_time(flat, n_grid=256):
    """Default start: a quarter period after the lift-off of a sticking far field; otherwise the
    time in one period where min(height(t), height(t + T/2)) is largest (both halves in flight)."""
    T = flat.period
    if getattr(flat, "pattern", None) == "stick":
        return float(flat.t0 + 0.25 * T)
    ts = T * np.arange(n_grid) / n_grid
    best, t_best = -np.inf, 0.0
    for t in ts:
        if isinstance(flat, _SoftFarField) and not (flat.in_flight(t) and flat.in_flight(t + 0.5 * T)):
            continue
        h = min(float(flat.height(t)), float(flat.height(t + 0.5 * T)))
        if h > best:
            best, t_best = h, float(t)
    return t_best


def _check_common(lattice, Gamma, M, e, cutoff, periods, geometry):
    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    if lattice.geometry != geometry:
        raise ValueError(f"lattice must be {geometry} for this state, got a {lattice.geometry} lattice")
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=2)
    if M % 2:
        raise ValueError(f"M must be even (a half-period shift is then a flat phase), got {M}")
    if cutoff is not None:
        cutoff = check_positive(cutoff, "cutoff")
    periods = check_int(periods, "periods", minimum=0)
    return Gamma, M, cutoff, periods


def _settle_and_solve(lattice, flat, state, t_start, Gamma, M, e, cutoff, periods, method,
                      simulate_kw, shooting_kw, callback, symmetric=False):
    w0, z0 = state
    T = flat.period
    if method is None:
        method = "soft" if cutoff is not None else "exact"
    n = lattice.n_nodes
    maps = shooting_maps(n, shooting_kw.get("krylov_dim"), 1)
    check_cost("lattice_kink" if lattice.geometry == "planar" else "lattice_oscillon", "lattice.n_nodes", n,
               1e6 + 16.0 * (maps + 4 * n) * n,
               (periods + maps) * period_map_seconds(n, T, method, e if isinstance(e, (int, float)) else None),
               hint=f"{periods} settling periods and one Newton step of {maps} period maps, of separate "
                    "contacts at O(n_nodes**2) each; use a coarser lattice or the soft contact")
    sim_kw = dict(simulate_kw or {})
    if cutoff is not None:
        sim_kw["cutoff"] = cutoff
    note = ""
    guess, t_guess = (w0, z0), t_start
    if periods > 0:
        # the first forcing cycle is the probe of the cost: the run is refused when its
        # measured pace puts all of them beyond the time limit; the states go on to ``callback``
        clock, probed = time.perf_counter(), [False]

        def settle(state):
            if not probed[0] and 0.0 < state.fraction < 1.0:      # after the first forcing cycle
                probed[0] = True
                elapsed = time.perf_counter() - clock
                check_cost("lattice_kink", "periods", periods, 1e6, elapsed / state.fraction,
                           hint=f"the first {state.fraction * periods:.3g} settling periods took {elapsed:.3g} s "
                                f"on {lattice.n_nodes} nodes; settle fewer periods or use a coarser lattice")
            if callback is not None:
                callback(state)

        run = simulate(lattice, Gamma, e, w0, z0, t_start=t_start, t_end=t_start + periods * T,
                       method=method, callback=settle, **sim_kw)
        if run.status == 5:
            # interrupted while settling: the state so far, not a periodic orbit (no Newton step)
            orb = find_periodic_orbit(lattice, Gamma=Gamma, M=M, e=e, cutoff=cutoff, guess=run, method=method,
                                      max_iter=0, section="fixed", multipliers=False,
                                      **{k: v for k, v in (simulate_kw or {}).items()})
            orb.update(status=5, status_text="interrupted", converged=False, success=False, localized=False,
                       message=f"interrupted during the settling run ({run.message}); the state reached "
                               "is returned, not a periodic orbit (pass it as guess= to go on)")
            return orb
        if run.success:
            guess, t_guess = run, None
        else:
            note = f"settling run failed ({run.message}); Newton started from the initial state. "
    kw = dict(shooting_kw)
    kw.update({k: v for k, v in (simulate_kw or {}).items()})
    sym_nit, sym_periods = None, 0
    if symmetric:
        if t_guess is None:
            w_s, z_s, st_s, t_s = guess.w, guess.zeta, np.asarray(guess.stuck, bool), float(guess.t)
        else:
            w_s, z_s, st_s, t_s = guess[0], guess[1], np.zeros(lattice.n_nodes, bool), t_start
        if method == "soft":
            st_s = np.zeros(lattice.n_nodes, bool)
        try:
            found, why, half_periods = solve_mirrored(lattice, Gamma, e, flat.period, t_s, w_s, z_s, st_s, method,
                                                      sim_kw, tol=shooting_kw.get("tol"),
                                                      max_iter=shooting_kw["max_iter"], callback=callback)
        except KeyboardInterrupt:
            # interrupted: the settled state, not a periodic orbit (no Newton step)
            orb = find_periodic_orbit(lattice, Gamma=Gamma, M=M, e=e, cutoff=cutoff, guess=guess, t_start=t_guess,
                                      method=method, max_iter=0, section="fixed", multipliers=False,
                                      **{k: v for k, v in (simulate_kw or {}).items()})
            orb.update(status=5, status_text="interrupted", converged=False, success=False, localized=False,
                       symmetric_nit=None, symmetric_periods=0.0,
                       message="interrupted during the mirrored half-period Newton; the settled state is "
                               "returned, not a periodic orbit (pass it as guess= to go on)")
            return orb
        sym_periods = 0.5 * half_periods
        if found is not None:
            guess, t_guess = found[:3], t_s
            sym_nit = found[3]
        else:
            note += why + ("the period map's Newton went on from the settled state. " if why else "")
    orb = find_periodic_orbit(lattice, Gamma=Gamma, M=M, e=e, cutoff=cutoff, guess=guess, t_start=t_guess,
                              method=method, callback=callback, **kw)
    orb.symmetric_nit = sym_nit
    orb.symmetric_periods = sym_periods
    if sym_nit is not None:
        orb.message = (f"mirrored half-period Newton: {sym_nit} steps ({sym_periods:g} periods of the FDA); "
                       "then the period map: " + orb.message)
        mu = orb.get("multipliers")
        if orb.converged and mu is not None and np.size(mu) and abs(complex(np.asarray(mu)[0])) > 1.0:
            here = "a node" if lattice.n_nodes % 2 else "midway between two nodes"
            other = "midway between two nodes" if lattice.n_nodes % 2 else "on a node"
            note += (f"the kink centred on the lattice's mirror point ({here}) is unstable (|mu1| = "
                     f"{abs(complex(np.asarray(mu)[0])):.6g}); a stable pinned kink, if any, is centred "
                     f"{other}: solve on a lattice with one node more or fewer (same spacing), or with "
                     "symmetric=False. ")
    orb.localized = bool(orb.converged) and _localized(orb)
    if orb.converged and not orb.localized:
        # not the orbit asked for: converged = False, status 9 (the fields hold the flat layer)
        note += ("the phase-shifted region did not survive: the converged orbit is uniform (the flat "
                 "layer), not a localized state; converged = False, status 9 (not the orbit asked for). ")
        orb.update(converged=False, success=False, status=9, status_text=STATUS[9])
    if hasattr(flat, "floquet_multipliers"):       # point impacts: the flat layer's own multipliers
        orb.far_field_stable, orb.far_field_multipliers, far_note = far_field(flat)
        note = far_note + note
    if note:
        orb.message = note + orb.message
    return orb


def _localized(orb, n_samples=64, rel=1e-3):
    """Whether the two ends of the lattice are on different phases over the period (a front survives)."""
    if orb.w0 is None or not np.all(np.isfinite(orb.w0)):
        return False
    ts = orb.t_start + orb.period * np.arange(n_samples) / n_samples
    Z = np.asarray(orb.height(ts))
    return bool(np.max(np.abs(Z[:, 0] - Z[:, -1])) > rel * max(float(np.max(np.abs(Z))), 1e-300))


def lattice_kink(lattice, Gamma=4.1, M=2, e=0.0, cutoff=None, *, pattern="auto", width=2.0, periods=10,
                 t_start=None, method=None, simulate_kw=None, callback=None, max_iter=MAX_ITER, symmetric=None,
                 **shooting_kw):
    r"""Periodic kink on a planar lattice by settling and shooting (see the module docstring).

    Parameters
    ----------
    lattice : Lattice
        Planar lattice with the front at :math:`x = 0` (e.g. ``Lattice.planar(n_nodes=41, length=40.0)``).
    Gamma : float
        Plate acceleration, > 0.  Default 4.1, where the completely inelastic kink exists.
    M : int
        Even period order, :math:`T = 2\pi M` (default 2, the f/2 kink).
    e : float
        Restitution in [0, 1) (point impacts) or (0, 1) (soft contact).  Default 0.
    cutoff : float, optional
        Soft-contact length :math:`\ell > 0`; None (default): point impacts.
    pattern : {"auto", "bounce", "stick", "touch"}
        The far field's flat orbit (point impacts), see :class:`~tps_solver.FlatLayer`.
    width : float
        Width of the linear transition of the start, >= 0.
    periods : int
        Settling periods of :func:`~tps_solver.simulate` before Newton, >= 0.
    t_start : float, optional
        Start time; default: a quarter period after the lift-off of a sticking far field,
        otherwise where the lower of the two far-field heights is largest.
    method : str, optional
        Integrator (a key of :data:`~tps_solver.METHODS` accepted by shooting); default
        ``"soft"`` with a cut-off, else ``"exact"``.
    simulate_kw : dict, optional
        Keywords of :func:`~tps_solver.simulate` used by both the settling run and the period map.
    callback : callable, optional
        ``callback(state)`` once per forcing cycle of the settling run (stage ``"simulate"``) and
        after every Newton step (stage ``"shooting"``, as :func:`~tps_solver.find_periodic_orbit`).
        The first forcing cycle is timed: settling whose measured pace exceeds the time limit
        of :func:`tps_solver.core.costs.set_limits` is refused (``ValueError`` naming ``periods``).
    max_iter : int
        Newton steps of the shooting, >= 0 (default 80, not the 30 of
        :func:`~tps_solver.find_periodic_orbit`: the front position is nearly neutral, its
        multiplier within 1e-3 of 1, so Newton--Krylov converges linearly there; at
        Gamma = 4.1, e = 0, dx = 1 it takes 33 steps).
    symmetric : bool or None
        Solve for the kink as a fixed point of the mirrored half-period map
        (:class:`~tps_solver.solvers.shooting.symmetric.MirroredHalfPeriodMap`: half a period of
        the FDA, then :math:`x \mapsto -x`), whose Newton does not creep along the front's
        near-neutral translation, then polish on the period map.  The multipliers of such a
        kink come from G as well (:math:`\mu = \lambda_G^2`, ``multipliers_map="mirrored"``;
        ``multiplier_map="period"`` computes them on the period map instead, see
        :func:`~tps_solver.find_periodic_orbit`).  It finds the kink centred on the lattice's mirror point: a node for an
        odd number of nodes, midway between two for an even number (the two pinned kinks).
        ``None`` (default): where the lattice is mirror symmetric
        (:func:`~tps_solver.solvers.shooting.symmetric.mirror_symmetric`).  If that Newton does
        not converge, the period map's Newton goes on from the settled state and the message
        says so.
    **shooting_kw
        Further keywords of :func:`~tps_solver.find_periodic_orbit` (``tol``,
        ``n_multipliers``, ``dense_max``, ...).

    Returns
    -------
    ShootingOrbit
        ``converged``, ``residual``, ``multipliers``, ``contacts_per_node``, ``sticking_intervals``,
        ``events`` ...; :func:`front_width` measures its front.  One more field, ``localized``
        (bool): whether the two ends of the lattice are still on different phases (False when
        the front has left the lattice and the orbit is the flat layer -- then ``converged`` is
        False and ``status`` 9, not the orbit asked for, and the message says so -- and whenever
        ``converged`` is False).

    Raises
    ------
    ValueError
        A lattice that is not planar, odd ``M``, parameters out of range, a far-field
        pattern that does not exist at ``(Gamma, e, M)`` (the message lists those that do).

    Notes
    -----
    On a lattice the front is pinned: there are kinks centred at different positions
    relative to the nodes, typically alternating stable and unstable (at Gamma = 4.1,
    e = 0, dx = 2: front widths 9.014 with :math:`|\mu_1| = 0.983` centred on a node, 9.305
    with :math:`|\mu_1| = 1.002` centred between two nodes).  With ``symmetric`` (the default
    on a mirror-symmetric lattice) the kink found is the one centred on the lattice's mirror
    point, so the parity of ``n_nodes`` selects it; without, the start (``t_start``,
    ``width``) does.  The multipliers say which kind was found.

    Examples
    --------
    The completely inelastic kink on a coarse lattice (dx = 8): two contacts per node and
    period (a touch-and-go and a landing to stick):

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    >>> orb = lattice_kink(lat, Gamma=4.1, e=0.0, periods=4)
    >>> orb.converged, orb.localized, orb.contacts_per_node.tolist()
    (True, True, [2, 2, 2, 2, 2, 2])
    >>> round(float(np.abs(orb.multipliers[0])), 3)          # stable: the nodes are far apart
    0.031
    """
    Gamma, M, cutoff, periods = _check_common(lattice, Gamma, M, e, cutoff, periods, "planar")
    pattern = check_choice(pattern, "pattern", ("auto", "bounce", "stick", "touch"))
    width = check_nonnegative(width, "width")
    flat = _far_field(Gamma, M, e, cutoff, pattern)
    t_start = _start_time(flat) if t_start is None else check_real(t_start, "t_start")
    state = kink_state(lattice, flat, t_start, width=width)
    shooting_kw["max_iter"] = check_int(max_iter, "max_iter", minimum=0)
    if symmetric is None:
        symmetric = mirror_symmetric(lattice)
    elif not isinstance(symmetric, (bool, np.bool_)):
        raise ValueError(f"symmetric must be True, False or None, got {symmetric!r}")
    elif symmetric and not mirror_symmetric(lattice):
        raise ValueError("symmetric=True needs a lattice symmetric under x -> -x (Lattice.planar with "
                         "center=0); use symmetric=False")
    return _settle_and_solve(lattice, flat, state, t_start, Gamma, M, e, cutoff, periods, method,
                             simulate_kw, shooting_kw, callback, symmetric=bool(symmetric))


def lattice_oscillon(lattice, Gamma=4.1, M=2, e=0.0, cutoff=None, *, core_radius=10.0, pattern="auto",
                     width=2.0, periods=10, t_start=None, method=None, simulate_kw=None, callback=None,
                     max_iter=MAX_ITER, **shooting_kw):
    r"""Periodic oscillon on an axisymmetric lattice by settling and shooting.

    The start is the flat orbit half a period later inside ``core_radius`` and the flat
    orbit outside (:func:`tps_solver.solvers.fda.oscillon_state`); the rest is as in
    :func:`lattice_kink`.  Whether the core keeps its radius is a physical question: if it
    shrinks or grows during the settling periods, Newton starts far from any periodic
    orbit and reports ``converged=False`` -- measure the radius with
    :func:`interface_position` on a time-stepped run instead.

    Parameters
    ----------
    lattice : Lattice
        Axisymmetric lattice (``Lattice.axisymmetric``).
    Gamma, M, e, cutoff, pattern, width, periods, t_start, method, simulate_kw, callback, max_iter, **shooting_kw
        As in :func:`lattice_kink`.
    core_radius : float
        Radius of the phase-shifted core of the start, > 0 and inside the lattice.

    Returns
    -------
    ShootingOrbit

    Examples
    --------
    On a very coarse lattice (dr = 8) the lattice pins a core of radius 12, and a periodic
    oscillon exists there.  On finer lattices (dr = 4, and dr = 1 or 0.5 in
    ``validation/sections/inelastic_kinks.md``) an e = 0 core shrinks and vanishes. The orbit found
    is then the flat layer, with ``localized`` False, ``converged`` False, ``status`` 9 and a
    message saying so.

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.axisymmetric(n_nodes=6, r_max=40.0, grid="uniform")
    >>> orb = lattice_oscillon(lat, Gamma=4.1, e=0.0, core_radius=12.0, periods=6, multipliers=False)
    >>> orb.converged, orb.localized, orb.contacts_per_node.tolist()
    (True, True, [2, 2, 2, 2, 2, 2])
    """
    Gamma, M, cutoff, periods = _check_common(lattice, Gamma, M, e, cutoff, periods, "axisymmetric")
    pattern = check_choice(pattern, "pattern", ("auto", "bounce", "stick", "touch"))
    width = check_nonnegative(width, "width")
    core_radius = check_positive(core_radius, "core_radius")
    r_max = float(lattice.nodes[-1])
    if core_radius >= r_max:
        raise ValueError(f"core_radius must lie inside the lattice, 0 < core_radius < {r_max:g}, "
                         f"got {core_radius!r}")
    flat = _far_field(Gamma, M, e, cutoff, pattern)
    t_start = _start_time(flat) if t_start is None else check_real(t_start, "t_start")
    state = oscillon_state(lattice, flat, t_start, r_core=core_radius, width=width)
    shooting_kw["max_iter"] = check_int(max_iter, "max_iter", minimum=0)
    return _settle_and_solve(lattice, flat, state, t_start, Gamma, M, e, cutoff, periods, method,
                             simulate_kw, shooting_kw, callback)


def interface_position(x, profile, level=0.5):
    r"""Where the normalised profile :math:`\theta = (p - p_0)/(p_{-1} - p_0)` first reaches ``level``.

    Linear interpolation between the two nodes that bracket the crossing.

    Parameters
    ----------
    x : array_like of float, shape (n,)
        Increasing node positions.
    profile : array_like of float, shape (n,)
        Values with different ends (a kink's height, an oscillon's height along r).
    level : float
        In (0, 1).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Shapes that differ, equal end values, or ``level`` outside (0, 1).

    Examples
    --------
    >>> interface_position([0.0, 1.0, 2.0, 3.0], [0.0, 0.0, 1.0, 1.0], 0.25)
    1.25
    """
    x = np.asarray(x, dtype=float)
    p = np.asarray(profile, dtype=float)
    if x.ndim != 1 or p.shape != x.shape or x.size < 2:
        raise ValueError(f"x and profile must be 1-D of the same length >= 2, got {x.shape} and {p.shape}")
    level = float(level)
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level!r}")
    if p[-1] == p[0]:
        raise ValueError("profile must have different end values (no interface)")
    th = (p - p[0]) / (p[-1] - p[0])
    i = int(np.flatnonzero(th >= level)[0])
    if i == 0:
        return float(x[0])
    return float(x[i - 1] + (level - th[i - 1]) * (x[i] - x[i - 1]) / (th[i] - th[i - 1]))


def core_radius(nodes, zeta, z_in, z_out, level=0.5):
    r"""Radius of an oscillon core: where :math:`\theta = (\zeta - z_{out})/(z_{in} - z_{out})` first falls below ``level``.

    Scanned outwards from the axis with linear interpolation between the bracketing nodes; the
    core and far-field heights ``z_in``, ``z_out`` are those of the two flat orbits at the same
    instant (unlike :func:`interface_position`, which normalises by the profile's own ends, so
    that a core that has shrunk to nothing has radius 0 instead of no interface).

    Parameters
    ----------
    nodes : array_like of float, shape (n,)
        Increasing radii.
    zeta : array_like of float, shape (n,)
    z_in, z_out : float
        Heights of the core's and the far field's flat orbits (``z_in != z_out``).
    level : float
        In (0, 1).

    Returns
    -------
    float
        0 if the axis is already below ``level``, ``nodes[-1]`` if :math:`\theta` never falls below it.

    Examples
    --------
    >>> r = np.arange(6.0)
    >>> core_radius(r, [2.0, 2.0, 2.0, 0.0, 0.0, 0.0], 2.0, 0.0)
    2.5
    >>> core_radius(r, np.zeros(6), 2.0, 0.0), core_radius(r, np.full(6, 2.0), 2.0, 0.0)
    (0.0, 5.0)
    """
    nodes = np.asarray(nodes, dtype=float)
    zeta = np.asarray(zeta, dtype=float)
    if nodes.ndim != 1 or zeta.shape != nodes.shape or nodes.size < 2:
        raise ValueError(f"nodes and zeta must be 1-D of the same length >= 2, got {nodes.shape} and {zeta.shape}")
    if not (np.isfinite(z_in) and np.isfinite(z_out)) or z_in == z_out:
        raise ValueError(f"z_in and z_out must be finite and differ, got {z_in!r} and {z_out!r}")
    level = float(level)
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level!r}")
    th = (zeta - z_out) / (z_in - z_out)
    if th[0] < level:
        return 0.0
    below = np.flatnonzero(th < level)
    if below.size == 0:
        return float(nodes[-1])
    i = int(below[0])
    return float(nodes[i - 1] + (th[i - 1] - level) * (nodes[i] - nodes[i - 1]) / (th[i - 1] - th[i]))


def front_width(orbit, n_samples=512, instant="far_field_tops", return_times=False):
    r"""10--90 % width of a kink's front, measured at a stated instant of the period.

    The package's one front width.  With :math:`\theta = (\zeta - \zeta_L)/(\zeta_R - \zeta_L)`
    (:math:`\zeta_{L,R}` the end nodes, oriented to increase), the width is the distance
    between :math:`\theta = 0.1` and :math:`0.9` (linear interpolation between nodes; the
    first node where :math:`\theta` reaches each level), measured on a grid of ``n_samples``
    instants of one period from ``orbit.t_start`` (0 if the orbit has none) at

    * ``instant="far_field_tops"`` (default): the instant where the left far field is highest
      and the one where the right is.  Why: the two far fields are half a period apart, so when
      one is at the top of its flight the other is low and the contrast
      :math:`|\zeta_R - \zeta_L|` that normalises :math:`\theta` is near its largest; the
      instant is a smooth maximum of an end node's height, defined for every kink.  On a
      symmetric kink the two widths agree.
    * ``instant="lower_far_field_top"``: the one instant where the lower far field is highest,
      :math:`\min(\zeta_L, \zeta_R)` largest: both far fields, and so the whole front, are as
      far from the plate as they get in the period, so no node is near a contact (the instant
      of the impact-and-stick kinks, whose far fields alternate a high and a low flight: the
      instant is the top of one far field's low flight, with the other in its high flight).
      Where the far fields cross at that instant (e.g. antiphase sinusoids) :math:`\theta` is
      0/0; such an orbit is refused (contrast below 5 % of its largest over the period).

    Parameters
    ----------
    orbit : PeriodicOrbit
        A kink on a planar lattice: ``orbit.height(t)`` -> shape (len(t), n_nodes),
        ``orbit.period`` and the node positions ``orbit.lattice.nodes`` or ``orbit.nodes``
        (e.g. from :func:`lattice_kink` or :func:`tps_solver.solve_stick_lattice`).
    n_samples : int
        Samples per period, >= 8.
    instant : {"far_field_tops", "lower_far_field_top"}
        Where in the period the width is measured (above).
    return_times : bool
        Also return the instants.

    Returns
    -------
    widths : tuple of float
        ``"far_field_tops"``: (width at the left far field's highest point, width at the
        right's); ``"lower_far_field_top"``: (width,).
    times : tuple of float
        The instants of ``widths`` (only with ``return_times``).

    Raises
    ------
    ValueError
        If ``orbit`` is not a lattice orbit (e.g. a FlatLayer), has no front (the far fields
        coincide at the measuring instant: a flat orbit), or ``instant`` / ``n_samples`` is
        out of range.

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    >>> orb = lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False)
    >>> wl, wr = front_width(orb, n_samples=64)
    >>> round(wl, 2), bool(abs(wl - wr) < 1e-9)          # the two halves are mirror images
    (12.76, True)
    >>> (w,), (t,) = front_width(orb, n_samples=64, instant="lower_far_field_top", return_times=True)
    >>> bool(8.0 < w < 16.0), bool(orb.t_start <= t < orb.t_start + orb.period)
    (True, True)
    """
    n_samples = check_int(n_samples, "n_samples", minimum=8)
    instant = check_choice(instant, "instant", ("far_field_tops", "lower_far_field_top"))
    lattice = getattr(orbit, "lattice", None)
    nodes = lattice.nodes if lattice is not None else getattr(orbit, "nodes", None)
    if nodes is None or not hasattr(orbit, "height") or not hasattr(orbit, "period"):
        raise ValueError(f"orbit must be a kink on a lattice (with lattice or nodes, height, period), "
                         f"got {type(orbit).__name__}: a flat layer has no front")
    x = np.asarray(nodes, dtype=float)
    # the heights at every sample and node (float64) and the sample times: 16 bytes and a few
    # tens of ns per value at least
    check_cost("front_width", "n_samples", n_samples, 16.0 * n_samples * (x.size + 1), 2e-8 * n_samples * x.size,
               hint=f"the heights of {x.size} nodes at every sample are held at once")
    t0 = float(getattr(orbit, "t_start", 0.0) or 0.0)
    ts = t0 + orbit.period * np.arange(n_samples) / n_samples
    Z = np.asarray(orbit.height(ts))
    if Z.shape != (n_samples, x.size) or x.size < 2:
        raise ValueError(f"orbit must be a kink on a lattice of >= 2 nodes: height(t) has shape {Z.shape}, "
                         f"nodes {x.shape}")
    scale = max(float(np.max(np.abs(Z))), np.finfo(float).tiny)
    if instant == "far_field_tops":
        rows = [int(np.argmax(Z[:, col])) for col in (0, -1)]
    else:
        rows = [int(np.argmax(np.minimum(Z[:, 0], Z[:, -1])))]
    out = []
    for k in rows:
        z = Z[k]
        if instant == "lower_far_field_top":
            contrast = np.max(np.abs(Z[:, -1] - Z[:, 0]))
            if contrast > 1e-9 * scale and abs(z[-1] - z[0]) < 0.05 * contrast:
                raise ValueError(f"instant='lower_far_field_top' is ill-conditioned for this orbit: its far fields "
                                 f"nearly cross there (|zeta_R - zeta_L| = {abs(z[-1] - z[0]):.3g}, below 5 % of its "
                                 f"largest {contrast:.3g}); use instant='far_field_tops'")
        if abs(z[-1] - z[0]) <= 1e-9 * scale:
            raise ValueError("orbit has no front: its far fields coincide (|zeta_R - zeta_L| = "
                             f"{abs(z[-1] - z[0]):.3g} at the measuring instant), e.g. a flat orbit")
        if z[-1] < z[0]:
            z = z[::-1]
            xx = -x[::-1]
        else:
            xx = x
        out.append(abs(interface_position(xx, z, 0.9) - interface_position(xx, z, 0.1)))
    widths = tuple(float(v) for v in out)
    return (widths, tuple(float(ts[k]) for k in rows)) if return_times else widths
