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
HelmholtzSolver Green's function) is not implemented here.  Cost (one BLAS thread, from
the pattern of a shooting orbit, with the checks): 5.1 s for the 41-node kink (dx = 1; a
residual 0.9 s, the dense Jacobian O(n_nodes^3)); the solution is evaluated at all nodes
at once in the modal basis (:meth:`StickProblem.evaluate_nodes`).

The contact pattern (kinds, triggers) is fixed during the solve; it is taken from
a time-stepped FDA run (:func:`pattern_from_fda`) or given by the caller, and
checked afterwards on the solution (``checks``).
"""
import math
import time

import numpy as np
from numpy.polynomial.legendre import leggauss, legvander
from scipy.linalg import lstsq

from tps_solver.core import archive
from tps_solver.core.bunch import Bunch
from tps_solver.core.orbit import PeriodicOrbit
from tps_solver.core.pattern import ContactPattern
from tps_solver.core.checks import check_int, check_positive, check_real, check_restitution
from tps_solver.model.restitution import RestitutionLaw
from tps_solver.core.costs import check_cost, period_map_seconds, shooting_maps
from tps_solver.core.newton import newton
from tps_solver.solvers.shooting.periodic import ShootingOrbit, find_periodic_orbit
from tps_solver.solvers.tps.stick_pattern import (StickPattern, check_pattern, check_with_fda, kink_state,
                                                  make_pattern, pattern_from_fda, pattern_from_orbit,
                                                  same_lattice)
from tps_solver.operators.modal import ModalBasis
from tps_solver.solvers.tps.stick_problem import StickProblem, flat_stick_orbit

__all__ = ["StickSolution", "StickPattern", "flat_stick_orbit", "solve_stick_flat", "check_with_fda",
           "solve_stick_lattice", "pattern_from_fda", "pattern_from_orbit", "kink_state"]


class StickSolution(PeriodicOrbit):
    r"""A time-periodic orbit with impact-and-stick contacts (a :class:`~tps_solver.core.orbit.PeriodicOrbit`).

    ``contacts`` is the solved pattern in the package's one alphabet: a ``"bounce"`` of
    the solver is a ``"touch"`` (touch-and-go) when e = 0, a ``"stick"`` carries its
    lift-off, and a triggered lift-off names the neighbour whose landing ended it.

    Attributes
    ----------
    converged, success : bool
    status : int
        0 converged; 1 iteration limit; 2 line search failed (no decrease of the residual);
        8 singular Jacobian or non-finite residual (the codes of :data:`tps_solver.STATUS`).
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
        The solved pattern in the solver's own layout (flat arrays over contacts, with the
        impulses and the trigger as a contact index); ``contacts`` is the same pattern as a
        :class:`~tps_solver.core.pattern.ContactPattern`.
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
    >>> sol.contacts.sequence(0), [str(c) for c in sol.contacts.ended_by]
    ('TS', ['', 'smooth'])
    """

    @property
    def problem(self):
        """The :class:`~tps_solver.solvers.tps.stick_problem.StickProblem` solved (the problem
        protocol: :func:`~tps_solver.continue_branch` continues it in Gamma or e)."""
        return self["_problem"]

    @property
    def unknowns(self):
        """The solved unknowns ``x = [t, tau, J, coef]`` of :attr:`problem`, shape (n_unknowns,)."""
        return self["_x"]

    def save(self, path):
        """Write the solution to ``path`` (``.npz`` appended if missing; see :mod:`tps_solver.core.archive`); returns the path."""
        return archive.save(self, path)

    @property
    def contacts(self):
        """The solved pattern as a :class:`~tps_solver.core.pattern.ContactPattern`."""
        p = self.pattern
        kind = np.where(p.kind == "stick", "stick", "bounce" if self.e > 0 else "touch")
        trig = np.asarray(p.trigger, dtype=int)
        trigger = np.where(trig >= 0, np.asarray(p.node)[np.maximum(trig, 0)], -1)
        t = np.asarray(p.t, dtype=float)
        t_start = math.floor(float(np.min(t)) / p.period) * p.period if t.size else 0.0
        return ContactPattern.from_contacts(p.node, t, kind, p.n_nodes, p.period, t_start=t_start,
                                            liftoff=p.tau, trigger=trigger)

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
        return self._problem.evaluate_nodes(self._x, t, integral)


def _newton(problem, x, tol, max_iter, callback=None):
    """The one Newton engine (:func:`tps_solver.core.newton.newton`) with the dense Jacobian
    reused as a chord while it contracts by 10 per step, after a least-squares start of the
    linear unknowns."""
    first = problem.residual(x)
    F, st, v = first
    # the residual is affine in the impulses and reaction coefficients: start with their
    # least-squares values for the initial times (the initial reaction is unknown)
    # (only the cheap linear columns are needed for that; the time columns, the expensive part
    # of the Jacobian, are computed only if the times must move)
    if problem.n_unknowns > problem.n_theta:
        Jm = problem.jacobian_matrix(x, st, v, F, times=False)
        # (QR with column pivoting, gelsy: 4x faster than the SVD of numpy's lstsq on the 81-node kink)
        step = lstsq(Jm[:, problem.n_theta:], -F, lapack_driver="gelsy", check_finite=False)[0]
        x_lin = x.copy()
        x_lin[problem.n_theta:] += step
        first_lin = problem.residual(x_lin)
        if np.max(np.abs(first_lin[0])) < np.max(np.abs(F)):
            x, first = x_lin, first_lin
    # the residual at the start is known: the engine does not evaluate it again
    out = newton(problem, x, tol=tol, max_iter=max_iter, linear="dense", chord=0.1, min_step=1.0 / 256,
                 first=first, callback=callback)
    if out.status == 5:
        out.message += "; the fields hold the last accepted iterate"
    message = out.message
    if out.status == 2:
        message += "; try a better initial pattern (a longer FDA run) or more reaction terms (n_basis)"
    elif out.status == 1:
        message += f" with max|F| = {out.residual:.3e}; raise max_iter or improve the initial pattern"
    return out.x, out.status, message, out.nit, [float(r) for r in out.history]


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
    frac = np.linspace(0.02, 0.98, 9)
    if problem.G:                  # w at 9 points of every stick segment, in one evaluation
        t_all = (sa[:, None] + (sb - sa)[:, None] * frac[None, :]).ravel()
        wv = sol._eval_at(np.repeat(problem.seg_node, frac.size), t_all, False)
        stick_w = float(np.max(np.abs(wv)))
    for k in range(problem.G):
        a, b = sa[k], sb[k]
        ts = a + (b - a) * frac
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


def solve_pattern(modal, pattern, lattice_nodes, Gamma, M, e, n_basis, n_quad, tol, max_iter,
                   n_harmonics, callback=None, margins=None):
    start = time.perf_counter()
    problem = StickProblem(modal, pattern, Gamma, e, n_basis, n_quad, margins)
    _check_newton_cost(problem, len(lattice_nodes))
    x, status, message, nit, history = _newton(problem, problem.initial(), tol, max_iter, callback)
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


def _check_newton_cost(problem, n_nodes):
    """Refuse a pattern whose dense Newton step is out of reach: the Jacobian, its LU and the
    request matrices (about 4 float arrays of N x N for N unknowns), a residual of at least
    5e-7 N^2 s (measured: 0.23 s at N = 634, 3.0 s at N = 1633) and the LU, N^3/3 flops."""
    N = float(problem.n_unknowns)
    check_cost("the impact-and-stick TPS", "lattice.n_nodes", n_nodes, 4 * 8.0 * N * N + 1e6,
               2 * 5e-7 * N * N + N ** 3 / 3 / 5e9,
               hint=f"the contact pattern has {int(N)} unknowns and the Newton step is dense; use a coarser "
                    "lattice, or shooting (find_periodic_orbit) for this one")


def _check_harmonics_cost(N, n):
    """Refuse ``n_harmonics`` whose closed-form harmonics (one dense n x n solve and three complex
    arrays of shape (2N + 1, n)) exceed the cost limits."""
    check_cost("the impact-and-stick TPS", "n_harmonics", N, 3 * 16.0 * (2 * N + 1) * n + 1e6,
               (2 * N + 1) * (n ** 3 + 100.0 * n) / 5e9, hint="the harmonics are computed in closed form")


def _check_args(Gamma, M, e, n_basis, n_quad, tol, max_iter, n_harmonics):
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    if isinstance(e, RestitutionLaw):
        if not e.constant:
            raise ValueError(f"e must be a constant restitution for the impact-and-stick TPS, got {e!r}: its "
                             "impulses -(1 + e) w- are linear in the unknowns only for a constant e; use "
                             "tps.find_periodic_orbit (shooting) for a speed-dependent law")
        e = e.e
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
    _check_harmonics_cost(n_harmonics, check_int(n_nodes, "n_nodes", minimum=1))
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
    pat = make_pattern(node, np.tile(orb.kind, n_nodes), np.tile(orb.t + perturbation, n_nodes),
                        np.tile(-orb.w_minus + perturbation, n_nodes),
                        np.tile(orb.tau + perturbation, n_nodes), np.full(node.size, -1),
                        np.zeros(node.size, dtype=int), n_nodes, orb.period)
    sol = solve_pattern(ModalBasis(lat, period=orb.period), pat, lat.nodes, Gamma, M, e, n_basis, n_quad, tol, max_iter,
                         n_harmonics)
    sol.exact = orb
    w, z = orb.orbit.velocity, orb.orbit.height
    sol._flat_state = (w, z)
    if orb.own_M < M and sol.converged:
        # the orbit of period 2 pi M asked for does not exist: a shorter one repeated is not it
        sol.converged = sol.success = False
        sol.status = 9
        sol.message = (f"no e = 0 flat orbit of period 2 pi M = 2 pi {M} at Gamma = {Gamma:g}: the orbit solved is "
                       f"that of period 2 pi {orb.own_M} (M = {orb.own_M}) repeated {M // orb.own_M} times; pass "
                       f"M = {orb.own_M} for it; converged=False. " + sol.message)
    return sol




def solve_stick_lattice(lattice, Gamma=4.1, M=2, e=0.0, pattern=None, *, w0=None, zeta0=None,
                        t_start=None, periods=20, n_basis=8, n_quad=16, tol=1e-10, max_iter=15,
                        n_harmonics=32, refresh=1, shoot=True, callback=None):
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
    callback : callable, optional, keyword-only
        ``callback(state)`` after every Newton step of the TPS (a
        :class:`~tps_solver.core.progress.ProgressState` of stage ``"newton"`` with
        ``iteration``, ``residual`` and ``x``); also given to the shooting.
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
    _check_harmonics_cost(n_harmonics, lattice.n_nodes)
    T = 2 * math.pi * M
    run = orbit = None
    if pattern is None:
        periods = check_int(periods, "periods", minimum=2)
        n = lattice.n_nodes
        maps = shooting_maps(n) if shoot else 0
        check_cost("solve_stick_lattice", "lattice.n_nodes", n, 1e6 + 16.0 * (4 * n) ** 2,
                   (periods + maps) * period_map_seconds(n, T, "exact", e),
                   hint=f"{periods} settling periods" + (f" and one shooting Newton step of {maps} period maps"
                                                          if shoot else "")
                        + ", O(n_nodes**2) each; use a coarser lattice")
        if (w0 is None) != (zeta0 is None):
            raise ValueError(f"w0 and zeta0 must be given together (got only {'w0' if zeta0 is None else 'zeta0'}); "
                             "give both, or neither for the default kink start")
        if w0 is None:
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
                                        multipliers=False, callback=callback)
        if orbit is not None and orbit.converged:
            pattern = pattern_from_orbit(orbit)
            source += f", then shooting (residual {orbit.residual:.1e})"
        else:
            pattern = pattern_from_fda(run, lattice, T)
            if orbit is not None:
                source += f" (shooting did not converge: {orbit.message}; pattern of the FDA run)"
    elif isinstance(pattern, ShootingOrbit):
        if not same_lattice(lattice, pattern.lattice):
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
        check_pattern(pattern)
        source = "user pattern"
    modal = ModalBasis(lattice, period=T)
    sol = solve_pattern(modal, pattern, lattice.nodes, Gamma, M, e, n_basis, n_quad, tol,
                         max_iter, n_harmonics, callback)
    sol.fda = run
    sol.orbit = orbit
    sol.lattice = lattice
    refresh = check_int(refresh, "refresh", minimum=0)
    for k in range(refresh):
        if sol.converged or sol.status == 5:
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
        sol = solve_pattern(modal, pattern, lattice.nodes, Gamma, M, e, n_basis, n_quad, tol,
                             max_iter, n_harmonics, callback)
        sol.fda = run
        sol.orbit = orbit
        sol.lattice = lattice
    sol.pattern_source = source
    return sol




# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _validate_stick(f):
    f.int("status")
    f.bool("converged")
    n = f.array("nodes", "f", ndim=1, finite=True).size
    f.array("contact_times", "f", shape=(n, None))
    f.array("w_hat", "c", shape=(None, n), finite=True)


def _restore_stick(sol):
    if "exact" in sol:
        sol._flat_state = (sol.exact.orbit.velocity, sol.exact.orbit.height)


archive.register("StickSolution", StickSolution, transient=("_flat_state",), validate=_validate_stick,
                 restore=_restore_stick)
