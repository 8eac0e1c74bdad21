r"""The spectral time-periodic solver (TPS) for kinks and oscillons.

Implements Sec. 4.1 of Goddard & Didwania: the Fourier series (38)-(39) in time
(convention in :mod:`tps_solver.harmonics`), one complex Helmholtz problem (45)
per harmonic solved by the Green's-function quadrature (48)-(50)
(:class:`~tps_solver.helmholtz.HelmholtzSolver`), the contact condition (46) and
the height reconstruction (40).

Formulation
-----------
The unknown is the contact time :math:`t_c(r_j)` at every node.  Given
:math:`t_c`, (45) with right-hand side
:math:`q_n(r) = -\Gamma^{-1} e^{-i n\alpha t_c(r)} - \hat g_n` fixes
:math:`\hat w_n(r)` for :math:`n = 1..N` (:math:`\hat w_0 = 0` by (39), and the
:math:`n = 0` balance (44) makes the impulse :math:`T/\Gamma` the same at every
node).  The contact condition (46) is imposed *at the node's own contact time*:

.. math:: F_j(t_c) = \sum_{|n| \le N} \hat w_n(r_j)\, e^{i n\alpha t_c(r_j)} + \cos t_0 = 0 .

Because the symmetric partial sum of a node's own sawtooth vanishes exactly at
its own jump, :math:`F` is a smooth function of :math:`t_c` with an O(1)
Jacobian (for the flat layer :math:`F = \cos t_0 - \cos t_c`), so no root of
the degree-2N contact polynomial has to be *selected* inside the iteration.
Whether the converged :math:`t_c(r_j)` really is the steep up-crossing of the
jump (the paper's root-selection problem, DESIGN hazard 1) is then checked
independently with :func:`~tps_solver.contact.contact_times` and reported.

Schemes
-------
``"newton"`` (default)
    Newton's method on :math:`F(t_c) = 0` with GMRES and an analytic
    Jacobian-vector product (one Helmholtz solve per product), backtracking
    line search on :math:`\|F\|`.
``"picard"``
    :math:`t_c^{k} = C(\hat w(t_c^{k-1}))`, where :math:`C` selects the steep
    up-crossing of (46) (the plain fixed point of DESIGN hazard 3).  For
    weakly coupled nodes it contracts linearly at
    :math:`\rho = (2N/\Gamma)/(2N/\Gamma + \sin t_0) = 1 - O(1/N)` (linearise
    :math:`J s_N(t - t_c) - \cos t = -\cos t_0`): the more harmonics, the
    slower -- the "steady drift" seen by the paper and the DESIGN prototype.
``"paper"``
    The paper's incremental scheme (47) with :math:`Q^k = \sigma Q^{k-1}`,
    ``paper_sign`` :math:`\sigma = \pm 1`, and :math:`t_c^k` from (46).  With
    :math:`\sigma = +1` it reproduces :math:`\hat w^k = \hat w(t_c^{k-1})`
    exactly, i.e. it is the Picard iteration lagged by one sweep.

Geometry
--------
*Kink* (planar): the symmetry :math:`w(t + T/2, -x) = w(t, x)` makes even
harmonics even in x (Neumann at 0) and odd harmonics odd (Dirichlet), so only
:math:`x \ge 0` is solved, with far field the flat layer of phase
:math:`t_0`; the other side has phase :math:`t_0 + T/2`.  Unknowns sit on the
staggered nodes :math:`x_j = (j + 1/2) h`; :math:`x = 0` is the symmetry point
where the layer bounces twice per period.  *Oscillon* (axisymmetric): nodes
:math:`r_j = j h`, regular at :math:`r = 0`, far field of phase :math:`t_0`.
Beyond the last node the contact time is the far-field :math:`t_0`.
"""
import math
import time

import numpy as np
from scipy.sparse.linalg import LinearOperator, gmres

from ._result import Bunch
from ._validation import (check_array, check_choice, check_int, check_positive, check_real,
                          check_restitution)
from .flat import FlatLayer
from .harmonics import evaluate, g_hat, sawtooth, sawtooth_hat

__all__ = ["solve_kink", "solve_oscillon", "solve_lattice", "PeriodicSolution", "load"]

_SCHEMES = ("newton", "picard", "paper")
_CORRECTOR_ITER = 12      # Newton corrector steps per continuation point (quadratic: ~4 suffice)


class PeriodicSolution(Bunch):
    r"""A time-periodic kink or oscillon from the TPS.

    Attributes
    ----------
    converged, success : bool
        Whether the iteration met ``tol``.
    status : int
        0 converged; 1 iteration limit; 2 stagnation / failed line search;
        3 failure of the contact-time computation.
    message : str
    nit : int
        Iterations (Newton steps or fixed-point sweeps).
    residual : float
        Final :math:`\max_j |F_j|` (contact condition (46) at the nodes).
    residual_history : ndarray of float, shape (nit + 1,)
    geometry : str
        ``"planar"`` (kink) or ``"axisymmetric"`` (oscillon).
    nodes : ndarray of float, shape (n_nodes,)
        Kink: the full line ``x`` (mirror of the solved half); oscillon: ``r``.
    tc : ndarray of float, shape (n_nodes,)
        Contact time in [0, T) at every node.
    w_hat : ndarray of complex, shape (2N+1, n_nodes)
        Velocity harmonics, centred (entry ``N + n`` holds :math:`\hat w_n`).
    zeta_hat : ndarray of complex, shape (2N+1, n_nodes)
        Height harmonics; :math:`\hat\zeta_0` from (40).
    Gamma, e, t0, period : float
    M, N : int
    flat : FlatLayer
        The far-field flat layer.
    checks : Bunch
        Physical checks (DESIGN hazard 3): ``min_zeta`` (over a fine time grid),
        ``zeta_nonnegative``, ``contacts_per_period`` (per node), ``single_contact``,
        ``tc_is_steep_crossing`` (per node), ``jump_ratio`` (measured jump of w at
        tc over the restitution jump T/Gamma, from the top harmonics, per node),
        ``restitution_residual`` (max |jump_ratio - 1|), ``all_pass``.
    min_shift : bool
        True if the paper's min-shift (64)-(65) was applied to zeta.  A solution
        that needs it is not a solution of the contact problem.
    """

    def _evaluate(self, coeffs, t, kind):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if not self.tail_correction:
            return evaluate(coeffs, t, self.M)
        J = self.period / self.Gamma
        own = J * sawtooth_hat(self.N, self.M, self.tc, kind)
        smooth = evaluate(coeffs - own, t, self.M)
        return smooth + J * sawtooth(t[:, None] - self.tc[None, :], self.M, kind)

    def velocity(self, t):
        """Velocity w(t, r) at the nodes; the post-impact value at t = tc.

        With ``tail_correction`` (default) each node's own jump of size
        T/Gamma at tc is evaluated in closed form (see
        :mod:`tps_solver.harmonics`), so the series carries no Gibbs error
        from it; otherwise the plain truncated series (38) is summed.

        Parameters
        ----------
        t : array_like of float, shape (n_times,)

        Returns
        -------
        w : ndarray of float, shape (n_times, n_nodes)
        """
        w = self._evaluate(self.w_hat, t, "velocity")
        if self.tail_correction:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            at_jump = np.mod(t[:, None] - self.tc[None, :], self.period) == 0.0
            w = w + np.where(at_jump, 0.5 * self.period / self.Gamma, 0.0)
        return w

    def height(self, t):
        """Height zeta(t, r) at the nodes (with the min-shift if it was requested).

        Parameters
        ----------
        t : array_like of float, shape (n_times,)

        Returns
        -------
        zeta : ndarray of float, shape (n_times, n_nodes)
        """
        return self._evaluate(self.zeta_hat, t, "height") + self.zeta_shift[None, :]

    def save(self, path):
        """Write the solution to a ``.npz`` file (see :func:`load`)."""
        np.savez_compressed(
            path, geometry=self.geometry, nodes=self.nodes, tc=self.tc, w_hat=self.w_hat,
            zeta_hat=self.zeta_hat, zeta_shift=self.zeta_shift, Gamma=self.Gamma, e=self.e,
            t0=self.t0, M=self.M, N=self.N, converged=self.converged, status=self.status,
            message=self.message, nit=self.nit, residual=self.residual,
            residual_history=self.residual_history, min_shift=self.min_shift, scheme=self.scheme,
            tail_correction=self.tail_correction, coupling=self.coupling,
            continuation_path=self.continuation_path,
            lattice=np.array([] if self.lattice is None else
                             [self.lattice.geometry, self.lattice.boundary, self.lattice.grid]))


def load(path):
    """Read a :class:`PeriodicSolution` written by :meth:`PeriodicSolution.save`.

    The physical checks are recomputed from the stored harmonics.
    """
    with np.load(path, allow_pickle=False) as d:
        data = {k: d[k] for k in d.files}
    M = int(data["M"])
    flat = FlatLayer(float(data["Gamma"]), M, t0=float(data["t0"]))
    sol = PeriodicSolution(
        converged=bool(data["converged"]), success=bool(data["converged"]),
        status=int(data["status"]), message=str(data["message"]), nit=int(data["nit"]),
        residual=float(data["residual"]), residual_history=data["residual_history"],
        geometry=str(data["geometry"]), nodes=data["nodes"], tc=data["tc"], w_hat=data["w_hat"],
        zeta_hat=data["zeta_hat"], zeta_shift=data["zeta_shift"], Gamma=float(data["Gamma"]),
        e=float(data["e"]), t0=float(data["t0"]), M=M, N=int(data["N"]), period=2 * math.pi * M,
        flat=flat, min_shift=bool(data["min_shift"]), scheme=str(data["scheme"]),
        tail_correction=bool(data["tail_correction"]), coupling=float(data["coupling"]),
        continuation_path=data["continuation_path"])
    sol.spacing = float(np.min(np.diff(sol.nodes)))
    sol.lattice = None
    if data["lattice"].size:
        from .fda import Lattice

        geometry, boundary, grid = (str(v) for v in data["lattice"])
        sol.lattice = Lattice(sol.nodes, geometry, boundary, grid=grid)
    sol.checks = _physical_checks(sol)
    return sol


# --------------------------------------------------------------------- problem
class _Problem:
    """The discretised TPS problem on the solved half-domain."""

    def __init__(self, geometry, h, n_nodes, flat, N, coupling=1.0, symmetry="kink"):
        from .helmholtz import HelmholtzSolver

        self._setup_forcing(geometry, flat, N, coupling)
        self.x = _node_positions(geometry, h, n_nodes)
        if geometry == "planar":
            # unknowns on staggered nodes (j + 1/2) h; node 0 at the symmetry point x = 0
            grid = np.concatenate([[0.0], self.x])
            self.parity = (np.where(self.n % 2 == 0, 1, -1) if symmetry == "kink"
                           else np.ones(N, dtype=int))
            self.symmetry = symmetry
            self.offset = 1
        else:
            grid = self.x
            self.parity = None
            self.offset = 0
            self.symmetry = None
        # coupling nu_c scales the Laplacian: nu_c Lap u - i n alpha u = q  <=>  Lap in x/sqrt(nu_c);
        # dual cells in both geometries: a node's own high harmonics see only its own value of q,
        # so the contact condition converges spectrally in N (piecewise-linear q: about N^-0.7)
        self.solver = HelmholtzSolver(grid / math.sqrt(coupling), geometry, self.M, N, interpolation="cells")

    def _setup_forcing(self, geometry, flat, N, coupling):
        """Far-field flat layer, harmonics and forcing (43) shared by every discretisation."""
        self.geometry = geometry
        self.flat = flat
        self.Gamma, self.M, self.t0, self.T = flat.Gamma, flat.M, flat.t0, flat.period
        self.N = N
        self.level = -math.cos(flat.t0)
        self.n = np.arange(1, N + 1)
        self.om = self.n / self.M                       # n alpha
        self.ghat = g_hat(N, self.M, self.Gamma)[N + 1:]
        self.q_inf = -np.exp(-1j * self.om * self.t0) / self.Gamma - self.ghat
        self.coupling = coupling

    def _extend(self, values):
        """Values on the solver grid (kink: the symmetry point copies the first node)."""
        if self.offset:
            return np.concatenate([values[..., :1], values], axis=-1)
        return values

    def w_hat_pos(self, tc):
        """Harmonics n = 1..N at the unknown nodes, shape (N, n_nodes)."""
        q = -np.exp(-1j * np.outer(self.om, self._extend(tc))) / self.Gamma - self.ghat[:, None]
        u = self.solver.solve(q, self.q_inf, self.parity)
        return u[:, self.offset:]

    def residual(self, tc, w=None):
        """F_j = S_j(tc_j) - level; returns (F, w_hat_pos, phase)."""
        if w is None:
            w = self.w_hat_pos(tc)
        phase = np.exp(1j * np.outer(self.om, tc))
        F = 2.0 * np.real(np.sum(w * phase, axis=0)) - self.level
        return F, w, phase

    def jacobian_operator(self, tc, w, phase):
        """The analytic Jacobian dF/dtc as a LinearOperator (one Helmholtz solve per product)."""
        slope = 2.0 * np.real(np.sum(1j * self.om[:, None] * w * phase, axis=0))
        dq_unit = (1j * self.om[:, None] / self.Gamma) / phase          # d q_n / d tc_k at node k
        zero = np.zeros_like(self.q_inf)

        def matvec(v):
            v = np.asarray(v, dtype=float).ravel()
            dq = self._extend(dq_unit * v[None, :])
            du = self.solver.solve(dq, zero, self.parity)[:, self.offset:]
            return slope * v + 2.0 * np.real(np.sum(du * phase, axis=0))

        n = tc.size
        return LinearOperator((n, n), matvec=matvec, dtype=float), slope


class _LatticeProblem(_Problem):
    """The TPS on an FDA lattice: the continuum Laplacian replaced by the lattice operator."""

    def __init__(self, lattice, flat, N, coupling=1.0):
        from .discrete_helmholtz import LatticeHelmholtz

        self._setup_forcing(lattice.geometry, flat, N, coupling)
        self.x = np.asarray(lattice.nodes, dtype=float)
        self.parity = None
        self.offset = 0
        self.symmetry = None
        self.lattice = lattice
        self.solver = LatticeHelmholtz(lattice, self.M, N, coupling=coupling)


def _node_positions(geometry, h, n_nodes):
    """Unknown nodes on the solved half-domain: staggered (j + 1/2) h for kinks, j h for oscillons."""
    return (np.arange(n_nodes) + 0.5) * h if geometry == "planar" else np.arange(n_nodes) * h


def _wrap(tc, T):
    return np.mod(tc, T)


def _newton(problem, tc, tol, max_iter, callback=None):
    """Newton-GMRES with backtracking on max|F|."""
    F, w, phase = problem.residual(tc)
    history = [float(np.max(np.abs(F)))]
    status, message = 1, f"iteration limit ({max_iter}) reached"
    nit = 0
    n = tc.size
    for nit in range(1, max_iter + 1):
        if history[-1] <= tol:
            nit -= 1
            status, message = 0, f"converged: max|F| = {history[-1]:.3e} <= tol = {tol:.1e}"
            break
        J, slope = problem.jacobian_operator(tc, w, phase)
        # Jacobi preconditioner: the local part of the Jacobian
        diag = slope.copy()
        big = np.maximum(np.abs(diag), 1e-3)
        precond = LinearOperator((n, n), matvec=lambda v: np.asarray(v).ravel() / big, dtype=float)
        rtol = min(1e-2, 0.1 * history[-1])
        dx, info = gmres(J, -F, rtol=max(rtol, 1e-13), atol=0.0, restart=min(n, 50),
                         maxiter=4, M=precond)
        if not np.all(np.isfinite(dx)):
            status, message = 2, "GMRES returned a non-finite step"
            break
        # backtracking line search on max|F|
        lam, accepted = 1.0, False
        step_cap = problem.T / 4.0
        scale = np.max(np.abs(dx))
        if scale > step_cap:
            dx *= step_cap / scale
        while lam >= 1.0 / 64:
            trial = tc + lam * dx
            F_t, w_t, phase_t = problem.residual(trial)
            r_t = float(np.max(np.abs(F_t)))
            if r_t < (1.0 - 1e-4 * lam) * history[-1] or r_t <= tol:
                accepted = True
                break
            lam *= 0.5
        if not accepted:
            status = 2
            message = (f"Newton stagnated at iteration {nit}: no decrease of max|F| = "
                       f"{history[-1]:.3e} along the GMRES direction (GMRES info {info})")
            nit -= 1
            break
        tc, F, w, phase = trial, F_t, w_t, phase_t
        history.append(r_t)
        if callback is not None:
            callback(nit, tc, r_t)
    else:
        if history[-1] <= tol:
            status, message = 0, f"converged: max|F| = {history[-1]:.3e} <= tol = {tol:.1e}"
    return tc, w, status, message, nit, history


def _continuation(make_problem, tc, tol, max_iter, nu_start, callback=None, min_step=1e-2):
    r"""Natural-parameter continuation in the coupling :math:`\nu_c` from the decoupled limit.

    At :math:`\nu_c \to 0` the nodes decouple and every pattern of flat phases
    is an exact solution; the branch is followed in :math:`\ln\nu_c` up to 1
    with a secant predictor and Newton corrector.  A step that fails is
    halved; when the step falls below ``min_step`` the branch is declared to
    end (a fold: no solution on this branch beyond the last coupling reached).

    Returns (tc, w, status, message, nit, history, path, problem), where
    ``path`` lists (coupling, Newton iterations, residual) of accepted points.
    """
    s = math.log(nu_start)
    problem = make_problem(nu_start)
    tc, w, status, message, nit, history = _newton(problem, tc, tol, max_iter)
    total = nit
    path = [(nu_start, nit, history[-1])]
    if status != 0:
        return tc, w, status, f"continuation could not start at coupling {nu_start:.3g}: {message}", \
            total, history, path, problem
    step, s_prev, tc_prev = 0.5, None, None
    while s < 0.0:
        s_try = min(0.0, s + step)
        if tc_prev is not None:
            tc_pred = tc + (tc - tc_prev) * (s_try - s) / (s - s_prev)
        else:
            tc_pred = tc
        trial_problem = make_problem(math.exp(s_try))
        out = _newton(trial_problem, tc_pred, tol, min(max_iter, _CORRECTOR_ITER))
        total += out[4]
        if out[2] == 0:
            s_prev, tc_prev = s, tc
            s = s_try
            tc, w, _, _, nit, history = out
            problem = trial_problem
            path.append((math.exp(s), nit, history[-1]))
            if callback is not None:
                callback(len(path), tc, history[-1])
            step = min(2.0 * step, 1.0)
        else:
            step *= 0.5
            if step < min_step:
                nu = math.exp(s)
                return tc, w, 4, (
                    f"continuation from the decoupled limit stopped at coupling nu_c = {nu:.6g} < 1 "
                    f"(node spacing {1 / math.sqrt(nu):.4g} x the requested one): the branch of "
                    f"single-contact solutions ends there (Newton fails for every smaller step; a fold "
                    f"is the likely cause). The returned fields are the converged solution at that "
                    f"coupling, on the correspondingly stretched nodes."), total, history, path, problem
    return tc, w, 0, (f"converged by continuation in the coupling ({len(path)} points): max|F| = "
                      f"{history[-1]:.3e} <= tol = {tol:.1e}"), total, history, path, problem


def _select_contact(problem, w, tc_guess):
    """Contact times selected from the truncated series by the steep up-crossing rule."""
    from .contact import contact_times

    full = _centred(w)
    res = contact_times(full, problem.M, problem.level, tc_guess=tc_guess)
    return res


def _centred(w_pos):
    """(N, n) positive harmonics -> (2N+1, n) centred with w_0 = 0 and conjugate symmetry."""
    N, n = w_pos.shape
    full = np.zeros((2 * N + 1, n), dtype=complex)
    full[N + 1:] = w_pos
    full[:N] = np.conj(w_pos[::-1])
    return full


def _fixed_point(problem, tc, tol, max_iter, scheme, paper_sign):
    """The plain fixed point ("picard") or the paper's incremental scheme (47) ("paper").

    "paper": with w^0 = w(tc^0) and tc^{-1} = tc^0, each sweep adds
    u^k = H[-sigma Q^{k-1}], Q^{k-1} = Gamma^-1 (e^{-in alpha tc^{k-1}} - e^{-in alpha tc^{k-2}}),
    to the iterate and selects tc^k from it by the contact rule.  For sigma = +1 this gives
    w^k = w(tc^{k-1}) exactly, i.e. the scheme is the Picard iteration lagged by one sweep.
    Convergence is always judged on the consistent residual F(tc^k) (a fresh solve), so an
    iterate that drifted away from w(tc) is never reported as converged.
    """
    F, w, _ = problem.residual(tc)
    history = [float(np.max(np.abs(F)))]
    status, message, nit = 1, f"iteration limit ({max_iter}) reached", 0
    rhs = lambda t: -np.exp(-1j * np.outer(problem.om, problem._extend(t))) / problem.Gamma
    zero = np.zeros_like(problem.q_inf)
    tc_prev = tc.copy()
    w_iter = w
    for nit in range(1, max_iter + 1):
        if history[-1] <= tol:
            nit -= 1
            status, message = 0, f"converged: max|F| = {history[-1]:.3e} <= tol = {tol:.1e}"
            break
        if scheme == "paper":
            # -sigma Q^{k-1} = sigma (rhs(tc^{k-1}) - rhs(tc^{k-2}))
            dq = paper_sign * (rhs(tc) - rhs(tc_prev))
            w_iter = w_iter + problem.solver.solve(dq, zero, problem.parity)[:, problem.offset:]
        else:
            w_iter = w
        sel = _select_contact(problem, w_iter, tc)
        if not np.all(sel.ok):
            status = 3
            message = (f"contact-time selection failed at {int(np.sum(~sel.ok))} node(s) in iteration {nit}: "
                       "no jump-like up-crossing of (46)")
            nit -= 1
            break
        tc_prev, tc = tc, sel.tc
        F, w, _ = problem.residual(tc)
        history.append(float(np.max(np.abs(F))))
        if not np.isfinite(history[-1]):
            status, message = 2, "residual became non-finite"
            break
    else:
        if history[-1] <= tol:
            status, message = 0, f"converged: max|F| = {history[-1]:.3e} <= tol = {tol:.1e}"
    return tc, w, status, message, nit, history


# ---------------------------------------------------------------- diagnostics
def _physical_checks(sol, n_times=None):
    """Checks of the single-contact assumption on the TPS output (DESIGN hazard 3)."""
    from .contact import contact_times

    T, N, M = sol.period, sol.N, sol.M
    n_times = n_times or max(64 * N, 2048)
    t = np.linspace(0.0, T, n_times, endpoint=False)
    zeta = sol.height(t)                                     # (n_times, n_nodes)
    scale = max(1.0, float(np.max(np.abs(zeta))))
    min_zeta = float(np.min(zeta))
    # contacts: local minima of zeta (periodic) that come within tol of the plate
    tol_contact = 1e-2 * scale
    zp, zm = np.roll(zeta, -1, axis=0), np.roll(zeta, 1, axis=0)
    is_min = (zeta <= zp) & (zeta < zm) & (zeta < tol_contact)
    contacts = np.sum(is_min, axis=0)
    # tc is the steep up-crossing selected by the independent rule?
    sel = contact_times(sol.w_hat, M, -math.cos(sol.t0))
    dt = np.abs(np.mod(sel.tc - sol.tc + T / 2, T) - T / 2)
    steep = sel.ok & (dt < 1e-6 * T)
    # measured jump from the top harmonics: 2 pi i n w_n e^{i n alpha tc} -> T/Gamma for a clean jump
    n = np.arange(1, N + 1)
    top = n >= max(1, N // 2)
    w_pos = sol.w_hat[N + 1:]
    est = np.real(2j * np.pi * n[:, None] * w_pos * np.exp(1j * np.outer(n / M, sol.tc)))
    jump_ratio = np.mean(est[top], axis=0) / (T / sol.Gamma)
    restitution_residual = float(np.max(np.abs(jump_ratio - 1.0)))
    zeta_ok = min_zeta >= -1e-6 * scale
    single = bool(np.all(contacts <= 1))
    return Bunch(
        min_zeta=min_zeta, zeta_nonnegative=bool(zeta_ok), contacts_per_period=contacts,
        single_contact=single, tc_is_steep_crossing=steep, selected_tc=sel.tc,
        jump_ratio=jump_ratio, restitution_residual=restitution_residual,
        all_pass=bool(zeta_ok and single and np.all(steep) and restitution_residual < 0.1))


# ----------------------------------------------------------------- front ends
def _common_args(Gamma, M, e, t0, n_harmonics, tol, max_iter, scheme, paper_sign):
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    if e is None and t0 is None:
        raise ValueError("e or t0 must be given (e in [0, 1), or t0 with e from (19))")
    if e is not None:
        e = check_restitution(e, "e")
    flat = FlatLayer(Gamma, M, e=e, t0=t0)
    N = check_int(n_harmonics, "n_harmonics", minimum=1)
    tol = check_positive(tol, "tol")
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    scheme = check_choice(scheme, "scheme", _SCHEMES)
    if paper_sign not in (1, -1):
        raise ValueError(f"paper_sign must be +1 or -1, got {paper_sign!r}")
    return flat, N, tol, max_iter, scheme


def _initial_tc(tc_initial, x, default):
    if tc_initial is None:
        return default
    if callable(tc_initial):
        values = tc_initial(x.copy())
        return check_array(values, "tc_initial", shape=(x.size,))
    return check_array(tc_initial, "tc_initial", shape=(x.size,))


def _grid(length, n_nodes, name_length):
    length = check_positive(length, name_length)
    n_nodes = check_int(n_nodes, "n_nodes", minimum=3)
    return length, n_nodes


def _finish(problem, flat, N, tc, w, status, message, nit, history, scheme, geometry,
            min_shift, elapsed, path=None, tail_correction=True):
    T, M = flat.period, flat.M
    tc = _wrap(tc, T)
    w_full = _centred(w)
    if isinstance(problem, _LatticeProblem):
        x = problem.x                                # coupling < 1 is reported, nodes unchanged
    else:
        x = problem.x / math.sqrt(problem.coupling)  # the nodes of the problem actually solved
    if isinstance(problem, _LatticeProblem):
        nodes = x.copy()
    elif geometry == "planar":
        # mirror.  kink: w_n(-x) = (-1)^n w_n(x), tc(-x) = tc(x) + T/2;  even: w_n(-x) = w_n(x)
        kink = problem.symmetry == "kink"
        sign = (-1.0) ** np.arange(-N, N + 1) if kink else np.ones(2 * N + 1)
        nodes = np.concatenate([-x[::-1], x])
        w_full = np.concatenate([(sign[:, None] * w_full)[:, ::-1], w_full], axis=1)
        tc = np.concatenate([_wrap(tc[::-1] + (T / 2 if kink else 0.0), T), tc])
    else:
        nodes = x.copy()
    # zeta_hat by (39)-(40): zeta_n = w_n/(i n alpha), zeta_0 = -sum_{n != 0} zeta_n e^{i n alpha tc}
    n = np.arange(-N, N + 1)
    zeta_hat = np.zeros_like(w_full)
    nz = n != 0
    zeta_hat[nz] = w_full[nz] / (1j * n[nz, None] / M)
    zeta_hat[N] = -np.real(np.sum(zeta_hat[nz] * np.exp(1j * np.outer(n[nz] / M, tc)), axis=0))
    if tail_correction:
        # (40) for the corrected series: zeta(tc) = 0 including the closed-form tail of the own jump
        J = T / flat.Gamma
        zeta_hat[N] -= J * float(sawtooth(0.0, M, "height") - evaluate(
            sawtooth_hat(N, M, [0.0], "height"), [0.0], M)[0, 0])
    sol = PeriodicSolution(
        converged=status == 0, success=status == 0, status=status, message=message, nit=nit,
        residual=history[-1], residual_history=np.asarray(history), geometry=geometry,
        nodes=nodes, tc=tc, w_hat=w_full, zeta_hat=zeta_hat, zeta_shift=np.zeros(nodes.size),
        Gamma=flat.Gamma, e=flat.e, t0=flat.t0, M=M, N=N, period=T, flat=flat,
        min_shift=False, scheme=scheme, time=elapsed, coupling=problem.coupling,
        tail_correction=bool(tail_correction),
        spacing=float(np.min(np.diff(x))), lattice=getattr(problem, "lattice", None),
        continuation_path=np.asarray(path if path is not None else [], dtype=float).reshape(-1, 3))
    if min_shift:
        # the paper's (64)-(65): shift zeta up where its minimum is negative -- a diagnostic, labelled
        t = np.linspace(0.0, T, max(64 * N, 2048), endpoint=False)
        zmin = np.min(sol.height(t), axis=0)
        sol.zeta_shift = np.where(zmin < 0.0, -zmin, 0.0)
        sol.min_shift = True
        sol.message += "; zeta min-shifted by (64)-(65) (NOT a solution of the contact problem where shifted)"
    sol.checks = _physical_checks(sol)
    return sol


def _decoupled_spacing(M):
    """Node spacing at which the slowest harmonic couples neighbours by < e^-30."""
    return 30.0 / math.sqrt(0.5 / M)


def _solve(geometry, Gamma, M, e, t0, n_harmonics, length, n_nodes, tc_initial, default_tc,
           tol, max_iter, scheme, paper_sign, min_shift, callback, continuation, tail_correction,
           symmetry="kink"):
    flat, N, tol, max_iter, scheme = _common_args(Gamma, M, e, t0, n_harmonics, tol, max_iter,
                                                  scheme, paper_sign)
    if not isinstance(continuation, bool):
        raise ValueError(f"continuation must be True or False, got {continuation!r}")
    h = length / (n_nodes - (0.5 if geometry == "planar" else 1.0))
    x = _node_positions(geometry, h, n_nodes)
    tc = _initial_tc(tc_initial, x, default_tc(x, flat)).astype(float)
    make = lambda nu: _Problem(geometry, h, n_nodes, flat, N, coupling=nu, symmetry=symmetry)
    return _run(make, h, flat, N, tc, tol, max_iter, scheme, paper_sign, min_shift, callback,
                continuation, tail_correction, geometry)


def _run(make_problem, h, flat, N, tc, tol, max_iter, scheme, paper_sign, min_shift, callback,
         continuation, tail_correction, geometry):
    """Dispatch to continuation, Newton or a fixed-point scheme, and assemble the solution.

    ``make_problem(coupling)`` builds the discretised problem; under continuation the problem
    at full coupling is built only if the branch gets there.
    """
    if not isinstance(continuation, bool):
        raise ValueError(f"continuation must be True or False, got {continuation!r}")
    start = time.perf_counter()
    path = None
    nu_start = (h / _decoupled_spacing(flat.M)) ** 2
    if scheme == "newton" and continuation and nu_start < 1.0:
        *out, path, problem = _continuation(make_problem, tc, tol, max_iter, nu_start, callback)
    else:
        problem = make_problem(1.0)
        if scheme == "newton":
            out = _newton(problem, tc, tol, max_iter, callback)
        else:
            out = _fixed_point(problem, tc, tol, max_iter, scheme, paper_sign)
    elapsed = time.perf_counter() - start
    return _finish(problem, flat, N, *out, scheme, geometry, min_shift, elapsed, path,
                   bool(tail_correction))


def _lattice_initial_tc(lattice, flat, tc_initial, r_core):
    """Initial contact times on a lattice: the user's, or the kink step / oscillon core guess."""
    x = np.asarray(lattice.nodes, dtype=float)
    if tc_initial is not None:
        return _initial_tc(tc_initial, x, None).astype(float)
    if flat.M % 2:
        raise ValueError(f"tc_initial must be given for odd M (got M = {flat.M}): t0 + T/2 is a "
                         "flat-layer phase only for even M")
    if lattice.geometry == "planar":
        return np.where(x >= 0.0, flat.t0, flat.t0 + flat.period / 2)
    return np.where(x < r_core, flat.t0 + flat.period / 2, flat.t0)


def solve_kink(Gamma=2.5, M=2, e=None, t0=0.0, n_harmonics=30, tc_initial=None, *,
               length=10.0, n_nodes=200, tol=1e-10, max_iter=50, scheme="newton",
               paper_sign=1, min_shift=False, continuation=True, tail_correction=True,
               symmetry="kink", callback=None):
    r"""Time-periodic kink: two flat layers bouncing half a period apart.

    Solves (45)-(46) on :math:`x \ge 0` with the kink symmetry
    :math:`w(t + T/2, -x) = w(t, x)` (see the module docstring) and returns
    the full line.

    Parameters
    ----------
    Gamma : float
        Plate acceleration.
    M : int
        Subharmonic order (M = 2 is f/2).
    e, t0 : float or None
        Restitution or far-field launch phase (one of them; (19) gives the
        other).  Default: the paper preset ``t0 = 0``.  Pass ``t0=None,
        e=0.45`` for the stable-interior preset.
    n_harmonics : int
        Truncation N of the Fourier series (38)-(39).
    tc_initial : None, array_like of float (n_nodes,), or callable
        Initial contact times on the solved nodes ``x > 0``.  ``None``: the
        step guess ``tc = t0`` (with the mirrored side at ``t0 + T/2``).
        A callable receives the node coordinates.
    length : float, keyword-only
        Half-width L of the computational domain; beyond it tc = t0.
    n_nodes : int, keyword-only
        Nodes on the half-line (x_j = (j + 1/2) h).
    tol : float
        Target for max_j |F_j| (contact condition (46)).
    max_iter : int
    scheme : {"newton", "picard", "paper"}
    paper_sign : {1, -1}
        Sign sigma in the paper's extrapolation Q^k = sigma Q^{k-1} (scheme "paper").
    min_shift : bool
        Apply the paper's min-shift (64)-(65) to zeta afterwards (diagnostic;
        labelled in ``message``).
    continuation : bool
        Follow the solution branch from the decoupled limit (coupling
        :math:`\nu_c \to 0`, where the initial step pattern is exact) to full
        coupling (used with scheme "newton"; ignored otherwise).  If the branch ends at a fold first,
        the result has ``converged=False``, ``status=4`` and holds the last
        converged solution on stretched nodes (``coupling < 1``).
    tail_correction : bool
        Evaluate each node's own jump (size T/Gamma at tc) in closed form in
        ``velocity``/``height`` and in (40) (see :mod:`tps_solver.harmonics`).
    symmetry : {"kink", "even"}
        ``"kink"``: w(t + T/2, -x) = w(t, x) (the two far fields half a period
        apart); ``"even"``: w(t, -x) = w(t, x) (e.g. a flat layer or a stripe).
    callback : callable, optional
        ``callback(iteration, tc, residual)`` after each Newton step.

    Returns
    -------
    PeriodicSolution

    Examples
    --------
    >>> sol = solve_kink(Gamma=2.5, e=0.45, t0=None, n_harmonics=8, n_nodes=40, length=5.0)
    >>> sol.nodes.shape, sol.w_hat.shape
    ((80,), (17, 80))
    """
    length, n_nodes = _grid(length, n_nodes, "length")
    if symmetry == "kink" and check_int(M, "M", minimum=1) % 2:
        raise ValueError(f"M must be even for a kink (got M = {M}): the half-period shift t0 + T/2 "
                         "is a flat-layer phase only for even M")
    return _solve("planar", Gamma, M, e, t0, n_harmonics, length, n_nodes, tc_initial,
                  lambda x, fl: np.full(x.size, fl.t0), tol, max_iter, scheme, paper_sign,
                  min_shift, callback, continuation, tail_correction,
                  check_choice(symmetry, "symmetry", ("kink", "even")))


def solve_oscillon(Gamma=2.5, M=2, e=None, t0=0.0, n_harmonics=30, tc_initial=None, *,
                   r_max=10.0, n_nodes=200, r_core=1.0, tol=1e-10, max_iter=50,
                   scheme="newton", paper_sign=1, min_shift=False, continuation=True,
                   tail_correction=True, callback=None):
    r"""Time-periodic axisymmetric oscillon in a flat layer of phase t0.

    Parameters
    ----------
    Gamma, M, e, t0, n_harmonics, tol, max_iter, scheme, paper_sign, min_shift, continuation, tail_correction, callback
        As in :func:`solve_kink`.
    tc_initial : None, array_like of float (n_nodes,), or callable
        ``None``: the step guess ``tc = t0 + T/2`` for ``r < r_core`` and
        ``t0`` outside.
    r_max : float, keyword-only
        Radius of the computational domain; beyond it tc = t0.
    n_nodes : int, keyword-only
        Nodes ``r_j = j h``, ``h = r_max/(n_nodes - 1)``.
    r_core : float, keyword-only
        Core radius of the default initial guess.

    Returns
    -------
    PeriodicSolution

    Examples
    --------
    >>> sol = solve_oscillon(Gamma=2.5, e=0.45, t0=None, n_harmonics=8, n_nodes=40, r_max=5.0)
    >>> float(sol.nodes[0]), sol.w_hat.shape
    (0.0, (17, 40))
    """
    r_max, n_nodes = _grid(r_max, n_nodes, "r_max")
    r_core = check_real(r_core, "r_core")
    if not 0.0 <= r_core < r_max:
        raise ValueError(f"r_core must be in [0, r_max) = [0, {r_max}), got {r_core}")
    if tc_initial is None and check_int(M, "M", minimum=1) % 2:
        raise ValueError(f"tc_initial must be given for odd M (got M = {M}): the core phase t0 + T/2 "
                         "is a flat-layer phase only for even M")
    return _solve("axisymmetric", Gamma, M, e, t0, n_harmonics, r_max, n_nodes, tc_initial,
                  lambda x, fl: np.where(x < r_core, fl.t0 + fl.period / 2, fl.t0), tol, max_iter,
                  scheme, paper_sign, min_shift, callback, continuation, tail_correction)


def solve_lattice(lattice, Gamma=2.5, M=2, e=None, t0=0.0, n_harmonics=30, tc_initial=None, *,
                  r_core=1.0, tol=1e-10, max_iter=50, scheme="newton", paper_sign=1,
                  min_shift=False, continuation=True, tail_correction=True, callback=None):
    r"""The TPS on an FDA lattice: time-periodic orbits of the FDA's own discrete model.

    Replaces the continuum Laplacian in (45) by the lattice operator of (52)-(53)
    (:class:`~tps_solver.discrete_helmholtz.LatticeHelmholtz`).  A converged
    solution is an exact periodic orbit of the lattice with one contact per node
    and period, so :func:`~tps_solver.check_stability` can integrate it on the
    same lattice with no discretisation mismatch (its defects measure only the
    truncation in N).

    Parameters
    ----------
    lattice : tps_solver.fda.Lattice
        The FDA lattice (planar: the full line, Neumann or pinned ends;
        axisymmetric: uniform or quasilog grid).
    Gamma, M, e, t0, n_harmonics, tol, max_iter, scheme, paper_sign, min_shift, continuation, tail_correction, callback
        As in :func:`solve_kink`.
    tc_initial : None, array_like of float (n_nodes,), or callable
        ``None``: planar -- the kink step ``t0`` for ``x >= 0`` and ``t0 + T/2``
        for ``x < 0``; axisymmetric -- ``t0 + T/2`` for ``r < r_core``, ``t0``
        outside.  Both need an even ``M`` (only then is ``t0 + T/2`` a flat-layer
        phase).
    r_core : float, keyword-only
        Core radius of the axisymmetric default guess.

    Returns
    -------
    PeriodicSolution
        With ``lattice`` set and ``nodes = lattice.nodes``.  Under continuation,
        a branch that ends first is reported with ``status=4`` and the coupling
        reached (the lattice operator scaled by ``coupling``).

    Examples
    --------
    >>> from tps_solver.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=8, length=140.0)
    >>> sol = solve_lattice(lat, Gamma=2.5, M=2, e=0.45, t0=None, n_harmonics=8)
    >>> sol.converged, sol.nodes.shape
    (True, (8,))
    """
    from .fda import Lattice

    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    flat, N, tol, max_iter, scheme = _common_args(Gamma, M, e, t0, n_harmonics, tol, max_iter,
                                                  scheme, paper_sign)
    r_core = check_real(r_core, "r_core")
    tc = _lattice_initial_tc(lattice, flat, tc_initial, r_core)
    return _run(lambda nu: _LatticeProblem(lattice, flat, N, coupling=nu), float(lattice.spacing),
                flat, N, tc, tol, max_iter, scheme, paper_sign, min_shift, callback, continuation,
                tail_correction, lattice.geometry)
