r"""Time stepping of the long-wave model with a thickness field (``docs/thickness.md``).

State on a :class:`~tps_solver.Lattice` (planar or axisymmetric, Neumann ends): at the nodes the
vertical velocity ``w``, the height ``zeta`` and the thickness ``h``; at the interior cell faces
the lateral velocity ``u`` (zero on the end faces and on the axis).  The finite-volume forms of
(T1)-(T4) of ``docs/thickness.md`` (V_j the cell volumes, A_k and C_k the face areas and
conductances of the lattice, so that for uniform h and u = 0 the w-equation is exactly the
lattice's Laplacian (63)):

* mass: :math:`V_j\dot h_j = -\sum_k \pm A_k \bar h_k u_k` (face-averaged thickness): the
  total :math:`\sum_j V_j h_j` is conserved to rounding by every Runge-Kutta step;
* stretching: :math:`\bar h_k \dot u_k = \partial N_{rr} + (N_{rr} - N_{\theta\theta})/r` at the
  face, with :math:`N_{rr} = 2h(D + \partial_r u)`, :math:`N_{\theta\theta} = 2h(2D - \partial_r u)`
  at the nodes (:math:`D` the finite-volume divergence; planar: :math:`N = 4hD`);
* antiplane: :math:`V_j h_j \dot w_j = \sum_k C_k \bar h_k (w_{nb} - w_j) + V_j h_j\,g`;
  bottom: :math:`\dot\zeta_j = w_j`.  The advective terms :math:`u\,\partial(\cdot)` are of
  second order in the slopes and dropped with them (assumption A3 of ``docs/thickness.md``).

Impacts (a free node reaching :math:`\zeta = 0` with :math:`w < 0`): :math:`w^+ = -e\,w^-`
(``e`` a float or a :class:`~tps_solver.model.restitution.RestitutionLaw`), and the lateral
push (T5), :math:`\Delta u_k = -\chi\,(Q_{j+1} - Q_j)/(\bar h_k\,\Delta r_k)` with
:math:`Q = \Delta w\,h^2/2` on the landing nodes.  A landing slower than ``stick_velocity`` (or
any landing at e = 0) ends at rest; the node sticks while its free acceleration is <= 0 and
lifts off when it turns positive, as in the FDA.

The flight between events is integrated by scipy's ``solve_ivp`` (``DOP853``), with two event
functions: the smallest height of the free nodes and the largest free acceleration of the stuck
nodes.  This is a method-of-lines integrator at the ODE tolerance, not an exact one: with
``chi = 0`` and uniform h it reproduces :func:`tps_solver.simulate` to about the tolerance.

Examples
--------
A flat layer of uniform thickness stays uniform and bounces as the flat layer does:

>>> import numpy as np
>>> from tps_solver import FlatLayer, Lattice
>>> fl = FlatLayer(2.5, 2, e=0.45)
>>> lat = Lattice.planar(n_nodes=5, length=4.0)
>>> t0 = fl.t0 + 1.0
>>> run = simulate_thickness(lat, 2.5, 0.45, np.full(5, fl.velocity(t0)), np.full(5, fl.height(t0)),
...                          np.ones(5), chi=1.0, t_start=t0, t_end=t0 + fl.period)
>>> bool(np.allclose(run.zeta, fl.height(t0), atol=1e-8)), float(np.max(np.abs(run.u))), run.n_events
(True, 0.0, 5)
"""
import math

import numpy as np
from scipy.integrate import solve_ivp

from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import (check_array, check_int, check_nonnegative, check_positive, check_real,
                                    check_state_scale)
from tps_solver.core.costs import check_cost, thickness_cost
from tps_solver.core.progress import progress_state
from tps_solver.model.restitution import ThicknessRestitution, as_restitution
from tps_solver.operators.lattice import Lattice

__all__ = ["ThicknessLattice", "simulate_thickness", "ThicknessResult"]


class ThicknessResult(Bunch):
    """Result of :func:`simulate_thickness`.

    Attributes
    ----------
    success : bool
    status : int
        0 reached ``t_end``; 1 event budget exceeded; 2 the ODE solver failed; 3 the thickness
        fell to 1e-3 of its initial minimum somewhere (the long-wave model breaks down).
    message : str
    t : float
        Final time.
    w, zeta, h : ndarray of float, shape (n_nodes,)
    u : ndarray of float, shape (n_nodes - 1,)
        Lateral velocity on the interior faces.
    stuck : ndarray of bool, shape (n_nodes,)
    events : list of (float, int, str)
        ``(t, node, kind)``, kind in {"impact", "stick", "liftoff"}.
    n_events : int
    mass : ndarray of float, shape (n_samples,)
        :math:`\\sum_j V_j h_j` at the start and after every event (conservation check).
    t_eval, w_eval, zeta_eval, h_eval : ndarray
        The state at the requested output times (shape (k,) and (k, n_nodes)).

    Examples
    --------
    >>> ThicknessResult(success=True, status=0).status
    0
    """


class ThicknessLattice:
    """The finite-volume operators of the thickness model on a Neumann :class:`~tps_solver.Lattice`.

    Parameters
    ----------
    lattice : Lattice
        Planar or axisymmetric, Neumann ends.

    Examples
    --------
    For uniform thickness the antiplane operator is the lattice's Laplacian:

    >>> lat = Lattice.axisymmetric(n_nodes=6, r_max=5.0, grid="uniform")
    >>> op = ThicknessLattice(lat)
    >>> w = np.cos(lat.nodes)
    >>> bool(np.allclose(op.antiplane(w, np.ones(6)), lat.operator @ w, rtol=0, atol=1e-14))
    True
    """

    def __init__(self, lattice):
        if not isinstance(lattice, Lattice):
            raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
        if lattice.boundary != "neumann":
            raise ValueError(f"lattice.boundary must be 'neumann', got {lattice.boundary!r}")
        self.lattice = lattice
        x = np.asarray(lattice.nodes, dtype=float)
        self.x = x
        self.n = x.size
        self.V = np.asarray(lattice.volumes, dtype=float)
        self.dx = np.diff(x)                                   # node to node, per interior face
        self.C = np.diag(lattice.flux, 1).copy()                       # conductances A_k / dx_k
        self.A = self.C * self.dx                              # face areas (planar 1, axisym r_face)
        self.axisymmetric = lattice.geometry == "axisymmetric"
        if self.axisymmetric:
            faces = np.concatenate(([0.0], self.A, [x[-1]]))
        else:
            faces = np.concatenate(([x[0]], 0.5 * (x[:-1] + x[1:]), [x[-1]]))
        self.face_pos = faces                                  # all n + 1 faces
        self.r_face = self.A if self.axisymmetric else None

    def face_mean(self, h):
        """Face-averaged thickness, shape (n - 1,)."""
        return 0.5 * (h[:-1] + h[1:])

    def _pad(self, u):
        return np.concatenate(([0.0], u, [0.0]))

    def divergence(self, u):
        """Finite-volume divergence D_j of the face velocities (planar du/dx, axisym r^-1 d(r u)/dr)."""
        flux = self._pad(self.A * u)
        return (flux[1:] - flux[:-1]) / self.V

    def mass_rate(self, h, u):
        """dh/dt of (T1), shape (n,)."""
        flux = self._pad(self.A * self.face_mean(h) * u)
        return -(flux[1:] - flux[:-1]) / self.V

    def antiplane(self, w, h):
        """The shear term of (T3) divided by h: (V h)^-1 sum_k C_k h_k (w_nb - w_j), shape (n,)."""
        q = self.C * self.face_mean(h) * np.diff(w)
        out = np.zeros(self.n)
        out[:-1] += q
        out[1:] -= q
        return out / (self.V * h)

    def stretching(self, u, h):
        """du/dt of (T2) on the interior faces, shape (n - 1,)."""
        D = self.divergence(u)
        p = self._pad(u)
        du_dr = (p[1:] - p[:-1]) / np.diff(self.face_pos)
        if self.axisymmetric:
            Nrr = 2.0 * h * (D + du_dr)
            Ntt = 2.0 * h * (2.0 * D - du_dr)
            force = np.diff(Nrr) / self.dx + self.face_mean(Nrr - Ntt) / self.r_face
        else:
            force = np.diff(4.0 * h * D) / self.dx
        return force / self.face_mean(h)

    def push(self, dw, h, contact):
        """The lateral push (T5) on the faces from the jumps ``dw`` at the nodes ``contact`` (chi = 1)."""
        Q = np.zeros(self.n)
        Q[contact] = 0.5 * dw[contact] * h[contact] ** 2
        return -np.diff(Q) / (self.face_mean(h) * self.dx)


def simulate_thickness(lattice, Gamma, e, w0, zeta0, h0, u0=None, *, chi=1.0, t_start=0.0, t_end=None,
                       t_eval=None, stuck0=None, stick_velocity=1e-6, rtol=1e-10, atol=1e-12,
                       max_events=100000, callback=None):
    r"""Integrate the thickness model (module docstring) from ``t_start`` to ``t_end``.

    Parameters
    ----------
    lattice : Lattice
        Planar or axisymmetric, Neumann ends.
    Gamma : float
        > 0.
    e : float, RestitutionLaw or ThicknessRestitution
        A :class:`~tps_solver.model.restitution.ThicknessRestitution` is evaluated at each
        landing node's impact speed and thickness.
    w0, zeta0, h0 : array_like of float, shape (n_nodes,)
        Initial velocity, height (>= 0) and thickness (> 0, in plate amplitudes).
    u0 : array_like of float, shape (n_nodes - 1,), optional
        Initial lateral velocity on the interior faces (default 0).
    chi : float
        The push coefficient :math:`(A/\ell)^2` of (T5), >= 0 (0: no lateral push).
    t_start, t_end : float
    t_eval : array_like of float, optional
        Output times in [t_start, t_end].
    stuck0 : array_like of bool, optional
        Nodes at rest on the plate at ``t_start`` (w0 = zeta0 = 0 there).
    stick_velocity : float
        A landing at most this fast ends at rest.
    rtol, atol : float
        ``solve_ivp`` tolerances.
    max_events : int
        Bound on the events; status 1 beyond it.  A bound whose events alone would cost more than
        the time limit of :func:`tps_solver.core.costs.set_limits` is refused, as is an interval
        out of reach (:func:`tps_solver.core.costs.thickness_cost`).
    callback : callable, optional
        ``callback(state)`` after every event (stage ``"simulate_thickness"``, ``iteration`` the
        events so far, ``fraction`` of the interval, ``t``).  A ``KeyboardInterrupt`` (Ctrl-C, or
        raised by the callback) ends the run with status 5 and the state so far.

    Returns
    -------
    ThicknessResult
        ``status`` 0 (reached ``t_end``), 1 (event bound), 2 (the ODE solver failed, or a non-finite
        state), 3 (the layer thinned out), 5 (interrupted).

    Examples
    --------
    A thicker middle and an uneven launch: the impacts push liquid sideways, the total mass
    stays to rounding:

    >>> from tps_solver import Lattice
    >>> lat = Lattice.planar(n_nodes=7, length=6.0)
    >>> h0 = 1.0 + 0.3 * np.cos(np.pi * lat.nodes / 6.0)
    >>> run = simulate_thickness(lat, 2.5, 0.45, 1.0 + 0.1 * np.cos(lat.nodes), np.ones(7), h0, chi=1.0,
    ...                          t_end=12.0)
    >>> run.success, bool(abs(run.mass[-1] / run.mass[0] - 1) < 1e-14), bool(np.abs(run.u).max() > 0)
    (True, True, True)
    """
    op = ThicknessLattice(lattice)
    n = op.n
    Gamma = check_positive(Gamma, "Gamma")
    thick = isinstance(e, ThicknessRestitution)
    law = None if thick else as_restitution(e)
    w = check_array(w0, "w0", shape=(n,)).astype(float).copy()
    z = check_array(zeta0, "zeta0", shape=(n,)).astype(float).copy()
    h = check_array(h0, "h0", shape=(n,)).astype(float).copy()
    for arr, name in ((w, "w0"), (z, "zeta0"), (h, "h0")):
        check_state_scale(arr, name)
    if np.any(z < 0.0):
        raise ValueError("zeta0 must be >= 0 at every node")
    if np.any(h <= 0.0):
        raise ValueError("h0 must be > 0 at every node")
    u = np.zeros(n - 1) if u0 is None else check_array(u0, "u0", shape=(n - 1,)).astype(float).copy()
    chi = check_nonnegative(chi, "chi")
    t = check_real(t_start, "t_start")
    if t_end is None:
        raise ValueError("t_end must be given")
    t_end = check_real(t_end, "t_end")
    if not t_end > t:
        raise ValueError(f"t_end must be > t_start, got t_start = {t}, t_end = {t_end}")
    stuck = np.zeros(n, bool) if stuck0 is None else check_array(stuck0, "stuck0", shape=(n,), dtype=bool).copy()
    if np.any(w[stuck] != 0.0) or np.any(z[stuck] != 0.0):
        raise ValueError("stuck0 nodes must have w0 = zeta0 = 0")
    stick_velocity = check_nonnegative(stick_velocity, "stick_velocity")
    rtol, atol = check_positive(rtol, "rtol"), check_positive(atol, "atol")
    max_events = check_int(max_events, "max_events", minimum=1)
    t_eval = np.array([], float) if t_eval is None else np.sort(check_array(t_eval, "t_eval", ndim=1)
                                                                .astype(float))
    if t_eval.size and (t_eval[0] < t or t_eval[-1] > t_end):
        raise ValueError("t_eval must lie in [t_start, t_end]")
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable or None, got {type(callback).__name__}")
    n_cycles = (t_end - t) / (2.0 * math.pi)
    nbytes, seconds, bound = thickness_cost(n, n_cycles, max_events)
    check_cost("simulate_thickness", "t_end", t_end, nbytes, seconds,
               hint=f"{n_cycles:.3g} forcing cycles on {n} nodes; integrate fewer periods")
    check_cost("simulate_thickness", "max_events", max_events, nbytes, bound,
               hint="the bound on the events is also a bound on the run time (chattering reaches it); "
                    "lower max_events or raise stick_velocity")
    inv_G = 1.0 / Gamma
    sl = (slice(0, n), slice(n, 2 * n), slice(2 * n, 3 * n), slice(3 * n, 4 * n - 1))

    def accel(tt, w_, z_, h_, u_):
        return op.antiplane(w_, h_) + (math.sin(tt) - inv_G)

    events, mass = [], [float(op.V @ h)]
    grazes = 0
    h_floor = 1e-3 * float(np.min(h))
    out_w, out_z, out_h = [], [], []
    status, message = 0, "reached t_end"
    k_eval = 0
    t_first = t
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            while t < t_end:
                held = stuck.copy()

                def rhs(tt, y):
                    w_, z_, h_, u_ = y[sl[0]], y[sl[1]], y[sl[2]], y[sl[3]]
                    a = accel(tt, w_, z_, h_, u_)
                    dz = w_.copy()
                    a[held] = 0.0
                    dz[held] = 0.0
                    return np.concatenate((a, dz, op.mass_rate(h_, u_), op.stretching(u_, h_)))

                free_idx = np.flatnonzero(~held)
                stuck_idx = np.flatnonzero(held)
                # one event per node: a free node's height crosses 0 downwards (a node leaving the plate
                # starts at 0 and rises: no crossing), a stuck node's free acceleration turns positive
                evs = []
                for j in free_idx:
                    def land(tt, y, j=int(j)):
                        return y[n + j] + 1e-300      # a node resting at exactly 0 is not a crossing
                    land.terminal, land.direction = True, -1
                    evs.append(land)
                for j in stuck_idx:
                    def lift(tt, y, j=int(j)):
                        a = accel(tt, y[sl[0]], y[sl[1]], y[sl[2]], y[sl[3]])
                        return a[j]
                    lift.terminal, lift.direction = True, 1
                    evs.append(lift)
                def thin(tt, y):
                    return float(np.min(y[sl[2]])) - h_floor
                thin.terminal, thin.direction = True, -1
                evs.append(thin)
                y0 = np.concatenate((w, z, h, u))
                te = t_eval[k_eval:]
                sol = solve_ivp(rhs, (t, t_end), y0, method="DOP853", rtol=rtol, atol=atol, events=evs or None,
                                dense_output=True)
                if sol.status < 0:
                    status, message = 2, f"the ODE solver failed at t = {sol.t[-1]:.12g}: {sol.message}"
                    break
                t_new = float(sol.t[-1])
                for tv in te[te <= t_new]:
                    yv = sol.sol(tv)
                    out_w.append(yv[sl[0]]), out_z.append(yv[sl[1]]), out_h.append(yv[sl[2]])
                    k_eval += 1
                y = sol.y[:, -1]
                w, z, h, u = y[sl[0]].copy(), y[sl[1]].copy(), y[sl[2]].copy(), y[sl[3]].copy()
                t = t_new
                if not np.all(np.isfinite(y)):
                    status, message = 2, f"the state became non-finite by t = {t:.12g}"
                    break
                if np.min(h) <= h_floor * (1.0 + 1e-9):
                    status, message = 3, (f"the thickness fell to {np.min(h):.3g} (1e-3 of the initial minimum) at node "
                                          f"{int(np.argmin(h))}, t = {t:.12g}: the push has emptied the layer there and "
                                          "the long-wave model breaks down")
                    break
                if sol.status == 0:
                    break
                # ---------------------------------------------------------------- the event
                tol_z = 1e-10 * (1.0 + float(np.max(np.abs(z))))
                a_now = accel(t, w, z, h, u)
                landing = np.flatnonzero(~stuck & (z <= tol_z) & (w <= 0.0))
                lifting = np.flatnonzero(stuck & (a_now >= -1e-10))
                if landing.size:
                    w_minus = w[landing].copy()
                    if thick:
                        e_here = e(-w_minus, h[landing])
                    else:
                        e_here = law(-w_minus) if not law.constant else law.e
                    w_plus = -e_here * w_minus
                    dw = np.zeros(n)
                    dw[landing] = w_plus - w_minus
                    z[landing] = 0.0
                    slow = (np.abs(w_minus) <= stick_velocity) | (np.asarray(w_plus) <= 0.0)
                    w[landing] = w_plus
                    if chi > 0.0:
                        u += chi * op.push(dw, h, landing)
                    for j, s in zip(landing, np.broadcast_to(slow, landing.shape)):
                        if s:
                            w[j] = 0.0
                    a_after = accel(t, w, z, h, u)
                    for j, s in zip(landing, np.broadcast_to(slow, landing.shape)):
                        if s and a_after[j] <= 0.0:
                            stuck[j] = True
                            events.append((t, int(j), "stick"))
                        else:
                            events.append((t, int(j), "impact"))
                for j in lifting:
                    stuck[j] = False
                    events.append((t, int(j), "liftoff"))
                if landing.size:
                    # an impact changes its neighbours' accelerations at once: stuck nodes it pulls up lift
                    # off now (a triggered lift-off), resting free nodes it pushes down stick now
                    a_after = accel(t, w, z, h, u)
                    for j in np.flatnonzero(stuck & (a_after > 0.0)):
                        stuck[j] = False
                        events.append((t, int(j), "liftoff"))
                    for j in np.flatnonzero(~stuck & (z <= 0.0) & (w == 0.0) & (a_after <= 0.0)):
                        stuck[j] = True
                        events.append((t, int(j), "stick"))
                if not landing.size and not lifting.size:
                    # an event that no node's state confirms (a contact at a tolerance's distance): step on
                    grazes += 1
                    z = np.maximum(z, 0.0)
                    if grazes > 100:
                        status, message = 2, f"more than 100 unconfirmed events in a row by t = {t:.12g}"
                        break
                    continue
                if not (np.all(np.isfinite(u)) and np.all(np.isfinite(w))):
                    status, message = 2, (f"the state became non-finite at the impact at t = {t:.12g} (the "
                                          f"lateral push chi = {chi:g} times the impact's jumps overflowed)")
                    break
                grazes = 0
                mass.append(float(op.V @ h))
                if callback is not None:
                    callback(progress_state("simulate_thickness", len(events), t=float(t),
                                            fraction=float(min(1.0, (t - t_first) / (t_end - t_first)))))
                if len(events) > max_events:
                    status, message = 1, (f"more than max_events = {max_events} events by t = {t:.12g}; raise max_events "
                                          "or stick_velocity")
                    break
    except KeyboardInterrupt:
        status, message = 5, f"interrupted at t = {t:.12g} (KeyboardInterrupt); the state so far is returned"
    k = len(out_w)
    return ThicknessResult(
        success=status == 0, status=status, message=message, t=t, w=w, zeta=z, h=h, u=u, stuck=stuck,
        events=events, n_events=len(events), mass=np.array(mass), t_eval=t_eval[:k],
        w_eval=np.array(out_w).reshape(k, n), zeta_eval=np.array(out_z).reshape(k, n),
        h_eval=np.array(out_h).reshape(k, n), lattice=lattice, Gamma=Gamma, e=e, chi=chi)
