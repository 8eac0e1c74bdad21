r"""The spectral time-periodic solver (TPS) for kinks and oscillons.

Implements Sec. 4.1 of Goddard & Didwania: the Fourier series (38)-(39) in time
(convention in :mod:`tps_solver.model.harmonics`), one complex Helmholtz problem (45)
per harmonic solved by the Green's-function quadrature (48)-(50)
(:class:`~tps_solver.operators.helmholtz.HelmholtzSolver`), the contact condition (46) and
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
jump (the paper's root-selection problem, hazard 1 of docs/design.md) is then checked
independently with :func:`~tps_solver.operators.contact.contact_times` and reported.

Schemes
-------
``"newton"`` (default)
    Newton's method on :math:`F(t_c) = 0` with GMRES and an analytic
    Jacobian-vector product (one Helmholtz solve per product), backtracking
    line search on :math:`\|F\|`.
``"picard"``
    :math:`t_c^{k} = C(\hat w(t_c^{k-1}))`, where :math:`C` selects the steep
    up-crossing of (46) (the plain fixed point of hazard 3 of docs/design.md).  For
    weakly coupled nodes it contracts linearly at
    :math:`\rho = (2N/\Gamma)/(2N/\Gamma + \sin t_0) = 1 - O(1/N)` (linearise
    :math:`J s_N(t - t_c) - \cos t = -\cos t_0`): the more harmonics, the
    slower -- the "steady drift" seen by the paper and by the prototype of docs/design.md, hazard 3.
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

from tps_solver.core import defaults
from tps_solver.model.restitution import RestitutionLaw, as_restitution
from tps_solver.core.checks import check_array, check_choice, check_int, check_positive, check_real, check_restitution
from tps_solver.core.costs import check_cost, tps_cost
from tps_solver.core.orbit import far_field
from tps_solver.model.harmonics import centred, evaluate, height_from_velocity, mode_numbers, sawtooth, sawtooth_hat
from tps_solver.operators.lattice import Lattice
from tps_solver.solvers.tps.checks import physical_checks
from tps_solver.solvers.tps.engine import SCHEMES, continuation as run_continuation, fixed_point, newton
from tps_solver.solvers.tps.problems import ContinuumProblem, LatticeProblem, bouncing_far_field, decoupled_spacing, node_positions
from tps_solver.solvers.tps.result import PeriodicSolution

__all__ = ["solve_kink", "solve_oscillon", "solve_lattice", "lattice_initial_tc", "next_steps"]


def _wrap(tc, T):
    return np.mod(tc, T)


# ----------------------------------------------------------------- front ends
def _common_args(Gamma, M, e, t0, n_harmonics, tol, max_iter, scheme, paper_sign, callback=None):
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    if e is not None:
        law = as_restitution(e)
        # a speed-dependent law: every node of a single-contact orbit lands at the flat orbit's
        # impact speed (the impulse per period is T/Gamma at every node), so the far field's
        # level -cos t0 carries the law and the problem is that of e = e(v_flat)
        e = check_restitution(law.e, "e") if law.constant else law
    flat = bouncing_far_field(Gamma, M, **defaults.model(e, t0))
    N = check_int(n_harmonics, "n_harmonics", minimum=1)
    tol = check_positive(tol, "tol")
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    scheme = check_choice(scheme, "scheme", SCHEMES)
    if paper_sign not in (1, -1):
        raise ValueError(f"paper_sign must be +1 or -1, got {paper_sign!r}")
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable or None, got {type(callback).__name__}")
    return flat, N, tol, max_iter, scheme


def _check_cost(what, N, n_nodes, total_nodes=None):
    """Refuse before allocating when the grid or the truncation is out of reach (tps_solver.core.costs).

    ``total_nodes``: the nodes of the result (a kink mirrors its ``n_nodes`` half-line nodes).
    """
    total = n_nodes if total_nodes is None else total_nodes
    check_cost(what, "n_nodes", n_nodes, *tps_cost(1, total),
               hint=f"the default grid has {defaults.N_NODES} nodes")
    check_cost(what, "n_harmonics", N, *tps_cost(N, total),
               hint=f"the default is {defaults.N_HARMONICS}; the cost grows like N^2 n_nodes")


def _suggest_grid(geometry, size, n_nodes, lattice=None):
    """A grid with spacing >= defaults.SPACING, as a phrase for a message."""
    sp = defaults.SPACING
    if lattice is not None:
        n = defaults.COARSE_LATTICE["n_nodes"]
        if lattice.geometry == "planar":
            return (f"a lattice with spacing >= {sp:g}, e.g. Lattice.planar(n_nodes={n}, "
                    f"length={defaults.COARSE_LATTICE['length']:g})")
        return (f"a lattice with spacing >= {sp:g}, e.g. Lattice.axisymmetric(n_nodes={n}, "
                f"r_max={defaults.R_MAX:g}, grid='uniform')")
    name, offset = ("half_length", 0.5) if geometry == "planar" else ("r_max", 1.0)
    k = int(math.floor(size / sp + offset))
    if k >= 3:
        return f"a grid with node spacing >= {sp:g}, e.g. n_nodes={k} for {name}={size:g}"
    return f"a grid with node spacing >= {sp:g}, e.g. {name}={sp * (n_nodes - offset):g} for n_nodes={n_nodes}"


def next_steps(status, flat, geometry, size, n_nodes, lattice=None):
    """One sentence on what to do after a run that did not converge ('' for status 0 and 5).

    Parameters
    ----------
    status : int
        A code of :data:`tps_solver.core.orbit.STATUS`.
    flat : FlatLayer
        The far-field flat layer.
    geometry : {"planar", "axisymmetric"}
    size : float
        ``half_length`` (planar) or ``r_max`` (axisymmetric).
    n_nodes : int
    lattice : Lattice, optional
        For the lattice solvers (the fold spacing of the lattice, 13.6, applies).

    Returns
    -------
    str
        Starts with a space, so it can be appended to a message.

    Examples
    --------
    >>> from tps_solver import FlatLayer
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> next_steps(0, flat, "planar", 150.0, 8)
    ''
    >>> print(next_steps(4, flat, "planar", 5.0, 40))
     What to try: single-contact kinks exist only for node spacing above about 10.9 viscous
     lengths (README, 'Results'), so use a grid with node spacing >= 20, e.g. half_length=790
     for n_nodes=40, or integrate this grid with the FDA and a soft contact
     (tps.simulate(..., method='soft', cutoff=...)).
    >>> print(next_steps(2, FlatLayer(Gamma=2.5, M=2, t0=0.0), "planar", 150.0, 8))
     What to try: the far-field flat layer is marginal (Floquet multiplier 1 at t0 = 0: the fold
     of the flat orbit, where the paper's preset t0 = 0 sits), so no branch starts there; give an
     interior restitution such as e=0.45 (the default) instead.
    """
    grid = _suggest_grid(geometry, size, n_nodes, lattice)
    fold = defaults.FOLD_SPACING_LATTICE if lattice is not None else defaults.FOLD_SPACING_TPS
    what = "kinks" if geometry == "planar" else "oscillons"
    mu = np.abs(flat.floquet_multipliers()) if flat.pattern == "bounce" else np.zeros(1)
    if status in (0, 5):
        return ""
    if status in (1, 2, 3) and abs(float(np.max(mu)) - 1.0) < 1e-6:
        return (f" What to try: the far-field flat layer is marginal (Floquet multiplier "
                f"{float(np.max(mu)):.6g} at t0 = {flat.t0:.4g}: the fold of the flat orbit, where the "
                f"paper's preset t0 = 0 sits), so no branch starts there; give an interior restitution "
                f"such as e={defaults.E} (the default) instead.")
    if status == 4:
        return (f" What to try: single-contact {what} exist only for node spacing above about {fold:g} "
                f"viscous lengths (README, 'Results'), so use {grid}, or integrate this grid with the FDA "
                f"and a soft contact (tps.simulate(..., method='soft', cutoff=...)).")
    return (f" What to try: a larger max_iter, continuation=True, or {grid} (single-contact {what} exist "
            f"only for node spacing above about {fold:g}).")


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
            min_shift, elapsed, path=None, tail_correction=True, size=None):
    T, M = flat.period, flat.M
    tc = _wrap(tc, T)
    w_full = centred(w)
    lattice = getattr(problem, "lattice", None)
    if isinstance(problem, LatticeProblem):
        x = problem.x                                # coupling < 1 is reported, nodes unchanged
    else:
        x = problem.x / math.sqrt(problem.coupling)  # the nodes of the problem actually solved
    x_req = problem.x                                # the nodes the caller asked for
    if isinstance(problem, LatticeProblem):
        nodes, nodes_req = x.copy(), x_req.copy()
    elif geometry == "planar":
        # mirror.  kink: w_n(-x) = (-1)^n w_n(x), tc(-x) = tc(x) + T/2;  even: w_n(-x) = w_n(x)
        kink = problem.symmetry == "kink"
        sign = (-1.0) ** mode_numbers(N) if kink else np.ones(2 * N + 1)
        nodes = np.concatenate([-x[::-1], x])
        nodes_req = np.concatenate([-x_req[::-1], x_req])
        w_full = np.concatenate([(sign[:, None] * w_full)[:, ::-1], w_full], axis=1)
        tc = np.concatenate([_wrap(tc[::-1] + (T / 2 if kink else 0.0), T), tc])
    else:
        nodes, nodes_req = x.copy(), x_req.copy()
    if status != 0:
        message = message.rstrip()
        message += "" if message.endswith(".") else "."
        if problem.coupling < 1.0 and lattice is None:
            message += (f" The fields are on the stretched nodes sol.nodes (spacing "
                        f"{float(np.min(np.diff(x))):.4g}, coupling sol.coupling = {problem.coupling:.4g}); "
                        f"the grid you asked for is sol.nodes_requested (spacing "
                        f"{float(np.min(np.diff(x_req))):.4g}).")
        elif problem.coupling < 1.0:
            message += (f" The fields belong to the lattice operator scaled by sol.coupling = "
                        f"{problem.coupling:.4g} (nodes unchanged).")
        if size is None:
            size = float(x_req[-1])
        message += next_steps(status, flat, geometry, size, x_req.size, lattice)
    # zeta_hat by (39)-(40): zeta_n = w_n/(i n alpha), zeta_0 = -sum_{n != 0} zeta_n e^{i n alpha tc}
    n = mode_numbers(N)
    nz = n != 0
    zeta_hat = height_from_velocity(w_full, M)
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
        tail_correction=bool(tail_correction), nodes_requested=nodes_req,
        spacing=float(np.min(np.diff(x))), lattice=lattice,
        continuation_path=np.asarray(path if path is not None else [], dtype=float).reshape(-1, 3))
    if min_shift:
        # the paper's (64)-(65): shift zeta up where its minimum is negative -- a diagnostic, labelled
        t = np.linspace(0.0, T, max(64 * N, 2048), endpoint=False)
        zmin = np.min(sol.height(t), axis=0)
        sol.zeta_shift = np.where(zmin < 0.0, -zmin, 0.0)
        sol.min_shift = True
        sol.message += "; zeta min-shifted by (64)-(65) (NOT a solution of the contact problem where shifted)"
    sol.formulation = ("single-contact TPS (continuum, Green-function quadrature)" if lattice is None
                       else "single-contact TPS (FDA lattice)")
    sol.checks = physical_checks(sol)
    sol.far_field_stable, sol.far_field_multipliers, note = far_field(flat)
    sol.checks.far_field_stable = sol.far_field_stable
    if note:
        sol.message += "; " + note.rstrip()
    return sol


def _solve(geometry, Gamma, M, e, t0, n_harmonics, length, n_nodes, tc_initial, default_tc,
           tol, max_iter, scheme, paper_sign, min_shift, callback, continuation, tail_correction,
           symmetry="kink"):
    flat, N, tol, max_iter, scheme = _common_args(Gamma, M, e, t0, n_harmonics, tol, max_iter,
                                                  scheme, paper_sign, callback)
    if not isinstance(continuation, bool):
        raise ValueError(f"continuation must be True or False, got {continuation!r}")
    _check_cost("solve_kink" if geometry == "planar" else "solve_oscillon", N, n_nodes,
                2 * n_nodes if geometry == "planar" else n_nodes)
    h = length / (n_nodes - (0.5 if geometry == "planar" else 1.0))
    x = node_positions(geometry, h, n_nodes)
    tc = _initial_tc(tc_initial, x, default_tc(x, flat)).astype(float)
    make = lambda nu: ContinuumProblem(geometry, h, n_nodes, flat, N, coupling=nu, symmetry=symmetry)
    return _run(make, h, flat, N, tc, tol, max_iter, scheme, paper_sign, min_shift, callback,
                continuation, tail_correction, geometry, size=length)


def _run(make_problem, h, flat, N, tc, tol, max_iter, scheme, paper_sign, min_shift, callback,
         continuation, tail_correction, geometry, size=None):
    """Dispatch to continuation, Newton or a fixed-point scheme, and assemble the solution.

    ``make_problem(coupling)`` builds the discretised problem; under continuation the problem
    at full coupling is built only if the branch gets there.
    """
    if not isinstance(continuation, bool):
        raise ValueError(f"continuation must be True or False, got {continuation!r}")
    start = time.perf_counter()
    path = None
    nu_start = (h / decoupled_spacing(flat.M)) ** 2
    if scheme == "newton" and continuation and nu_start < 1.0:
        *out, path, problem = run_continuation(make_problem, tc, tol, max_iter, nu_start, callback)
    else:
        problem = make_problem(1.0)
        if scheme == "newton":
            out = newton(problem, tc, tol, max_iter, callback)
        else:
            out = fixed_point(problem, tc, tol, max_iter, scheme, paper_sign, callback)
    elapsed = time.perf_counter() - start
    return _finish(problem, flat, N, *out, scheme, geometry, min_shift, elapsed, path,
                   bool(tail_correction), size)


def lattice_initial_tc(lattice, flat, tc_initial, r_core):
    """Initial contact times on a lattice: the user's, or the kink step / oscillon core guess.

    Parameters
    ----------
    lattice : Lattice
    flat : FlatLayer
        The far-field flat layer (launch phase ``t0``, period ``T``).
    tc_initial : None, array_like of float (n_nodes,), or callable
        A callable receives the node coordinates.
    r_core : float
        Core radius of the axisymmetric guess.

    Returns
    -------
    ndarray of float, shape (n_nodes,)

    Examples
    --------
    The kink step: t0 = 0.3068 for x >= 0, t0 + T/2 = 0.3068 + 2 pi for x < 0; the oscillon
    core takes t0 + T/2 inside r_core:

    >>> from tps_solver import FlatLayer, Lattice
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> np.round(lattice_initial_tc(Lattice.planar(n_nodes=4, length=60.0), flat, None, 1.0), 4).tolist()
    [6.59, 6.59, 0.3068, 0.3068]
    >>> core = Lattice.axisymmetric(n_nodes=4, r_max=60.0, grid="uniform")
    >>> np.round(lattice_initial_tc(core, flat, None, 1.0), 4).tolist()
    [6.59, 0.3068, 0.3068, 0.3068]
    >>> lattice_initial_tc(core, FlatLayer(Gamma=2.5, M=1, e=0.45), None, 1.0)
    Traceback (most recent call last):
    ...
    ValueError: tc_initial must be given for odd M (got M = 1): t0 + T/2 is a flat-layer phase only for even M
    """
    x = np.asarray(lattice.nodes, dtype=float)
    if tc_initial is not None:
        return _initial_tc(tc_initial, x, None).astype(float)
    if flat.M % 2:
        raise ValueError(f"tc_initial must be given for odd M (got M = {flat.M}): t0 + T/2 is a "
                         "flat-layer phase only for even M")
    if lattice.geometry == "planar":
        return np.where(x >= 0.0, flat.t0, flat.t0 + flat.period / 2)
    return np.where(x < r_core, flat.t0 + flat.period / 2, flat.t0)


def _inelastic_keywords(what, solver, max_iter, tol, options):
    """Keywords for the e = 0 front door ``solver``; ValueError for a single-contact option given.

    ``options`` holds (name, value, default) of the single-contact options; ``max_iter`` and
    ``tol`` are passed on only when the caller changed them from the single-contact defaults.
    """
    given = [name for name, value, default in options if value != default]
    if given:
        raise ValueError(f"{given[0]} applies to the single-contact TPS (e > 0); the e = 0 {what} is "
                         f"solved by {solver} on a lattice (give lattice=, Gamma, M, tol, max_iter, callback)")
    kw = {} if max_iter == defaults.MAX_ITER else {"max_iter": max_iter}
    if tol != defaults.TOL:
        kw["tol"] = tol
    return kw


def solve_kink(Gamma=None, M=defaults.M, e=None, t0=None, n_harmonics=defaults.N_HARMONICS,
               tc_initial=None, *, half_length=None, n_nodes=defaults.N_NODES, tol=defaults.TOL,
               max_iter=defaults.MAX_ITER, scheme="newton",
               paper_sign=1, min_shift=False, continuation=True, tail_correction=True,
               symmetry="kink", callback=None, length=None, lattice=None, start=None):
    r"""Time-periodic kink: two flat layers bouncing half a period apart.

    Two formulations, named in the result's ``formulation``:

    * ``e > 0`` (or ``t0`` given): the single-contact TPS on the continuum, one impact with
      rebound per node and period (below);
    * ``e = 0``: the completely inelastic kink, where every node lands, sticks, lifts off and
      touches again each period.  The call is :func:`~tps_solver.solvers.tps.stick_kink.solve_stick_kink`
      on ``lattice`` (default: spacing 1 on [-20, 20]; the spacing is the model's cut-off and
      is named in ``spacing``); ``Gamma``, ``M``, ``tol``, ``max_iter`` (of the shooting) and
      ``callback`` apply, the single-contact options do not (giving one raises
      ``ValueError``).  The result is a :class:`~tps_solver.solvers.tps.stick.StickSolution`
      with its contact pattern, the FDA check and the Floquet multipliers.

    Solves (45)-(46) on :math:`x \ge 0` with the kink symmetry
    :math:`w(t + T/2, -x) = w(t, x)` (see the module docstring) and returns
    the full line.

    Parameters
    ----------
    Gamma : float, optional
        Plate acceleration.  Default: ``defaults.GAMMA = 2.5`` for e > 0, and
        ``defaults.GAMMA_STICK = 4.1`` for e = 0, where the sticking f/2 far field exists
        (3.857 <= Gamma <= 6.362; at 2.5 the e = 0 layer has no f/2 orbit).
    M : int
        Subharmonic order (M = 2 is f/2).
    e, t0 : float or None
        Restitution or far-field launch phase: give one of them, (19) gives the
        other (both only if they agree).  Default (neither): ``e = 0.45``, a flat
        layer inside its stability window (:mod:`tps_solver.core.defaults`).  The
        paper's preset ``t0 = 0`` (``**tps_solver.core.defaults.PAPER_PRESET``) sits on
        the fold of the flat orbit, where no branch starts.
    n_harmonics : int
        Truncation N of the Fourier series (38)-(39).  The cost is estimated
        first; a call out of reach raises ``ValueError`` (:mod:`tps_solver.core.costs`).
    tc_initial : None, array_like of float (n_nodes,), or callable
        Initial contact times on the solved nodes ``x > 0``.  ``None``: the
        step guess ``tc = t0`` (with the mirrored side at ``t0 + T/2``).
        A callable receives the node coordinates.
    half_length : float, keyword-only
        Half-width L of the computational domain (x in [-L, L]); beyond it tc = t0.
        Default 150 (with the default 8 nodes: spacing 20, above the spacing ~11
        below which single-contact kinks do not exist; :mod:`tps_solver.core.defaults`).
    length : float, keyword-only
        The former name of ``half_length`` (kept so existing calls work; give one of the two).
        Note that ``Lattice.planar(length=...)`` is a *total* length.
    n_nodes : int, keyword-only
        Nodes on the half-line (x_j = (j + 1/2) h), default 8.
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
        converged solution on stretched nodes ``nodes`` (``coupling < 1``); the grid
        asked for is ``nodes_requested``.
    tail_correction : bool
        Evaluate each node's own jump (size T/Gamma at tc) in closed form in
        ``velocity``/``height`` and in (40) (see :mod:`tps_solver.model.harmonics`).
    symmetry : {"kink", "even"}
        ``"kink"``: w(t + T/2, -x) = w(t, x) (the two far fields half a period
        apart); ``"even"``: w(t, -x) = w(t, x) (e.g. a flat layer or a stripe).
    callback : callable, optional
        ``callback(state)`` after each Newton step (each accepted point under
        continuation; each sweep of a fixed-point scheme), a
        :class:`~tps_solver.core.progress.ProgressState` with ``stage``, ``iteration``, ``residual`` and ``tc``.
        A ``KeyboardInterrupt`` returns ``status=5`` with the last accepted iterate (for
        ``e = 0``: from any stage, settle, shooting, multipliers, tps or checks, each announced
        to the callback; see :func:`~tps_solver.solvers.tps.stick_kink.solve_stick_kink`).
    lattice : tps_solver.Lattice, keyword-only
        For ``e = 0`` only: the planar Neumann lattice of the inelastic kink.
    start : {"shooting", "anticontinuum"}, keyword-only
        For ``e = 0`` only: where the contact pattern comes from -- the settled FDA and shooting
        (default), or the TPS itself from the uncoupled nodes (no time stepping;
        :func:`~tps_solver.solvers.tps.stick_discovery.discover_stick_kink`).

    Returns
    -------
    PeriodicOrbit
        For ``e > 0`` a :class:`PeriodicSolution`, for ``e = 0`` a
        :class:`~tps_solver.solvers.tps.stick.StickSolution`; both say which in ``formulation``.
        The rest of this section is the single-contact one.
        ``converged``, ``status`` (:data:`tps_solver.core.orbit.STATUS`), a ``message``
        that ends with what to try when it did not converge, ``nodes`` (the nodes
        solved) and ``nodes_requested`` (the grid asked for; they differ only when a
        continuation stopped at ``coupling < 1``).  ``checks.all_pass`` is False
        unless the run converged.  ``far_field_stable`` says whether the far-field flat layer is
        stable (its multipliers in ``far_field_multipliers``); when it is not, the message says
        so, and the orbit, though converged, cannot be observed.  For ``e = 0``, an orbit that
        converged to the uniform flat layer (no front left on the lattice) has ``converged``
        False and ``status = 9``.

    Examples
    --------
    >>> sol = solve_kink()                        # the defaults: converged, checked
    >>> sol.converged, sol.checks.all_pass, sol.nodes.shape
    (True, True, (16,))
    >>> fine = solve_kink(n_harmonics=8, n_nodes=40, half_length=5.0)
    >>> fine.status, fine.nodes_requested.shape, fine.checks.all_pass
    (4, (80,), False)
    >>> sol.formulation
    'single-contact TPS (continuum, Green-function quadrature)'

    The inelastic kink, on a coarse lattice (dx = 8) to keep the example short:

    >>> import tps_solver as tps
    >>> k = solve_kink(4.1, e=0.0, lattice=tps.Lattice.planar(n_nodes=6, length=40.0))
    >>> k.converged, k.checks.all_pass, k.spacing, k.formulation.split(" (")[0]
    (True, True, 8.0, 'impact-and-stick TPS')
    """
    if e is not None and t0 is None and not isinstance(e, RestitutionLaw) and check_real(e, "e") == 0.0:
        kw = _inelastic_keywords("kink", "solve_stick_kink", max_iter, tol, (
            ("tc_initial", tc_initial, None), ("half_length", half_length, None), ("length", length, None),
            ("n_harmonics", n_harmonics, defaults.N_HARMONICS), ("n_nodes", n_nodes, defaults.N_NODES),
            ("scheme", scheme, "newton"), ("paper_sign", paper_sign, 1), ("min_shift", min_shift, False),
            ("continuation", continuation, True), ("tail_correction", tail_correction, True),
            ("symmetry", symmetry, "kink")))
        from tps_solver.solvers.tps.stick_kink import solve_stick_kink
        if start is not None:
            kw["start"] = start
        Gamma = defaults.GAMMA_STICK if Gamma is None else Gamma
        return solve_stick_kink(Gamma, M, lattice=lattice, callback=callback, **kw)
    Gamma = defaults.GAMMA if Gamma is None else Gamma
    if start is not None:
        raise ValueError("start applies to the e = 0 kink only ('shooting' or 'anticontinuum', "
                         "see solve_stick_kink)")
    if lattice is not None:
        raise ValueError("lattice applies to the e = 0 kink only; for single-contact kinks on a lattice "
                         "use solve_lattice(lattice, ...)")
    if half_length is not None and length is not None:
        raise ValueError(f"give one of half_length and length (its former name), got half_length="
                         f"{half_length!r} and length={length!r}")
    name = "length" if length is not None else "half_length"
    half_length = length if length is not None else (defaults.HALF_LENGTH if half_length is None
                                                     else half_length)
    half_length, n_nodes = _grid(half_length, n_nodes, name)
    if symmetry == "kink" and check_int(M, "M", minimum=1) % 2:
        raise ValueError(f"M must be even for a kink (got M = {M}): the half-period shift t0 + T/2 "
                         "is a flat-layer phase only for even M")
    return _solve("planar", Gamma, M, e, t0, n_harmonics, half_length, n_nodes, tc_initial,
                  lambda x, fl: np.full(x.size, fl.t0), tol, max_iter, scheme, paper_sign,
                  min_shift, callback, continuation, tail_correction,
                  check_choice(symmetry, "symmetry", ("kink", "even")))


def solve_oscillon(Gamma=None, M=defaults.M, e=None, t0=None, n_harmonics=defaults.N_HARMONICS,
                   tc_initial=None, *, r_max=defaults.R_MAX, n_nodes=defaults.N_NODES,
                   r_core=defaults.R_CORE, tol=defaults.TOL, max_iter=defaults.MAX_ITER,
                   scheme="newton", paper_sign=1, min_shift=False, continuation=True,
                   tail_correction=True, callback=None, lattice=None):
    r"""Time-periodic axisymmetric oscillon in a flat layer of phase t0.

    For ``e = 0`` the call is :func:`~tps_solver.solvers.tps.stick_kink.solve_stick_oscillon`
    on ``lattice`` (default: uniform spacing 1 up to r = 40), with ``r_core`` as its core
    radius (default 10 there); it returns a
    :class:`~tps_solver.solvers.tps.stick.StickSolution` that says, in ``localized`` and its
    message, when no oscillon was found (as in :func:`solve_kink`).

    Parameters
    ----------
    Gamma, M, e, t0, n_harmonics, tol, max_iter, scheme, paper_sign, min_shift, continuation, tail_correction, callback
        As in :func:`solve_kink`.
    tc_initial : None, array_like of float (n_nodes,), or callable
        ``None``: the step guess ``tc = t0 + T/2`` for ``r < r_core`` and
        ``t0`` outside.
    r_max : float, keyword-only
        Radius of the computational domain; beyond it tc = t0.  Default 140
        (with the default 8 nodes: spacing 20; :mod:`tps_solver.core.defaults`).
    n_nodes : int, keyword-only
        Nodes ``r_j = j h``, ``h = r_max/(n_nodes - 1)``, default 8.
    r_core : float, keyword-only
        Core radius of the default initial guess.
    lattice : tps_solver.Lattice, keyword-only
        For ``e = 0`` only: the axisymmetric lattice.

    Returns
    -------
    PeriodicOrbit
        As in :func:`solve_kink`: a :class:`PeriodicSolution` for ``e > 0``, a
        :class:`~tps_solver.solvers.tps.stick.StickSolution` for ``e = 0``.

    Examples
    --------
    >>> sol = solve_oscillon()                    # the defaults: converged, checked
    >>> sol.converged, sol.checks.all_pass, float(sol.nodes[0]), sol.w_hat.shape
    (True, True, 0.0, (61, 8))
    """
    if e is not None and t0 is None and not isinstance(e, RestitutionLaw) and check_real(e, "e") == 0.0:
        kw = _inelastic_keywords("oscillon", "solve_stick_oscillon", max_iter, tol, (
            ("tc_initial", tc_initial, None), ("r_max", r_max, defaults.R_MAX),
            ("n_harmonics", n_harmonics, defaults.N_HARMONICS), ("n_nodes", n_nodes, defaults.N_NODES),
            ("scheme", scheme, "newton"), ("paper_sign", paper_sign, 1), ("min_shift", min_shift, False),
            ("continuation", continuation, True), ("tail_correction", tail_correction, True)))
        from tps_solver.solvers.tps.stick_kink import solve_stick_oscillon
        if r_core != defaults.R_CORE:
            kw["core_radius"] = r_core
        Gamma = defaults.GAMMA_STICK if Gamma is None else Gamma
        return solve_stick_oscillon(Gamma, M, lattice=lattice, callback=callback, **kw)
    Gamma = defaults.GAMMA if Gamma is None else Gamma
    if lattice is not None:
        raise ValueError("lattice applies to the e = 0 oscillon only; for single-contact oscillons on a "
                         "lattice use solve_lattice(lattice, ...)")
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


def solve_lattice(lattice, Gamma=defaults.GAMMA, M=defaults.M, e=None, t0=None,
                  n_harmonics=defaults.N_HARMONICS, tc_initial=None, *, r_core=defaults.R_CORE,
                  tol=defaults.TOL, max_iter=defaults.MAX_ITER, scheme="newton", paper_sign=1,
                  min_shift=False, continuation=True, tail_correction=True, callback=None):
    r"""The TPS on an FDA lattice: time-periodic orbits of the FDA's own discrete model.

    Replaces the continuum Laplacian in (45) by the lattice operator of (52)-(53)
    (:class:`~tps_solver.operators.helmholtz.lattice.LatticeHelmholtz`).  A converged
    solution is an exact periodic orbit of the lattice with one contact per node
    and period, so :func:`~tps_solver.check_stability` can integrate it on the
    same lattice with no discretisation mismatch (its defects measure only the
    truncation in N).

    Parameters
    ----------
    lattice : tps_solver.solvers.fda.Lattice
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
    >>> from tps_solver.solvers.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=8, length=140.0)
    >>> sol = solve_lattice(lat, Gamma=2.5, M=2, e=0.45, t0=None, n_harmonics=8)
    >>> sol.converged, sol.nodes.shape
    (True, (8,))
    """
    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    flat, N, tol, max_iter, scheme = _common_args(Gamma, M, e, t0, n_harmonics, tol, max_iter,
                                                  scheme, paper_sign, callback)
    _check_cost("solve_lattice", N, lattice.n_nodes)
    r_core = check_real(r_core, "r_core")
    tc = lattice_initial_tc(lattice, flat, tc_initial, r_core)
    return _run(lambda nu: LatticeProblem(lattice, flat, N, coupling=nu), float(lattice.spacing),
                flat, N, tc, tol, max_iter, scheme, paper_sign, min_shift, callback, continuation,
                tail_correction, lattice.geometry)
