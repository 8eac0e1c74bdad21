r"""Kinks as fixed points of the mirrored half-period map: :class:`MirroredHalfPeriodMap`.

An f/2 kink (period :math:`T = 2\pi M`, ``M`` even) is half a period out of phase across its
front, and on a lattice symmetric about :math:`x = 0` the kinks centred there have the symmetry

.. math::  \zeta(x, t + T/2) = \zeta(-x, t), \qquad w(x, t + T/2) = w(-x, t),

because the forcing :math:`g(t) = \sin t - 1/\Gamma` has period :math:`2\pi`, which divides
:math:`T/2`, and the lattice equations (53) commute with the mirror :math:`S: x \mapsto -x`.
Such a kink is a fixed point of :math:`G = S \circ P_{T/2}` (the FDA flow over half a period,
then the mirror), and :math:`G^2 = P_T` is the period map.  Solving :math:`G(x) = x` instead
of :math:`P_T(x) = x`

* costs half a period per map evaluation, and
* removes the near-neutral direction that makes Newton--Krylov on :math:`P_T` creep: the
  front's translation, whose multiplier :math:`\mu_1` of :math:`P_T` lies within
  :math:`10^{-3}` of 1, is reversed by the mirror, so along it :math:`G` has the multiplier
  :math:`-\sqrt{\mu_1} \approx -1` and :math:`G - I` the well-conditioned value
  :math:`\approx -2`.

On a lattice with an odd number of nodes the mirror point is a node, with an even number it
is midway between two: the two pinned kinks of a spacing (one of them is stable, the other a
saddle; their multipliers of :math:`P_T` say which).  :func:`tps_solver.lattice_kink` polishes
the fixed point of :math:`G` on :math:`P_T` (:func:`~tps_solver.find_periodic_orbit`, which
converges at once).

Multipliers from G
------------------
At a fixed point of :math:`G`, :math:`DP_T = DG^2` (chain rule, :math:`P_T = G\circ G`), so the
Floquet multipliers of the kink are the squares of the eigenvalues :math:`\lambda` of
:math:`DG`, with multiplicity and in the same order of modulus; the sign of :math:`\lambda` is
the mode's parity under the mirror and half-period shift (the translation: :math:`\lambda
\approx -1`, :math:`\mu \approx 1`).  :func:`mirrored_multipliers` computes them with
central-difference products of :math:`G` (two half periods, as much as a one-sided product of
:math:`P_T`, and about 100 times more accurate) and an Arnoldi factorisation stopped at
convergence; :func:`~tps_solver.find_periodic_orbit` uses it wherever the orbit is a fixed point
of :math:`G` (``multiplier_map``).  Measured on the e = 0 kink (Gamma 4.1, L 40): :math:`G`
alone is not differentiable within about :math:`10^{-6}` of the kink along some directions (a
landing order at the far end that the next sticking erases), while :math:`P_T = G\circ G`
is; the differentiability test is therefore made on :math:`P_T`, from the perturbed images of
:math:`G`.
"""
import numpy as np
from scipy.sparse.linalg import LinearOperator

from tps_solver.core.newton import newton
from tps_solver.core.progress import progress_state
from tps_solver.solvers.shooting.period_map import PeriodMap, PeriodMapError
from tps_solver.solvers.shooting.soft_monodromy import SoftMonodromy

__all__ = ["MirroredHalfPeriodMap", "central_action", "mirror_symmetric", "mirrored_multipliers", "solve_mirrored"]


def mirror_symmetric(lattice, rtol=1e-12):
    r"""Whether a lattice is planar and symmetric under :math:`x \mapsto -x` (nodes and operator).

    Parameters
    ----------
    lattice : Lattice
    rtol : float
        Relative tolerance of the node positions and the operator entries.

    Returns
    -------
    bool

    Examples
    --------
    >>> import tps_solver as tps
    >>> mirror_symmetric(tps.Lattice.planar(n_nodes=41, length=40.0))
    True
    >>> mirror_symmetric(tps.Lattice.planar(n_nodes=41, length=40.0, center=1.0))
    False
    """
    if lattice.geometry != "planar":
        return False
    x = np.asarray(lattice.nodes, dtype=float)
    scale = max(float(np.max(np.abs(x))), 1e-300)
    if np.max(np.abs(x[::-1] + x)) > rtol * scale:
        return False
    L = lattice.operator
    L = L.toarray() if hasattr(L, "toarray") else np.asarray(L, dtype=float)
    return bool(np.max(np.abs(L[::-1, ::-1] - L)) <= rtol * max(float(np.max(np.abs(L))), 1e-300))


class MirroredHalfPeriodMap(PeriodMap):
    r""":math:`G = S\circ P_{T/2}`: the FDA over half the orbit's period, then the mirror (module docstring).

    Parameters
    ----------
    lattice : Lattice
        Planar and mirror symmetric (:func:`mirror_symmetric`).
    Gamma, e : float
    period : float
        The kink's period :math:`T = 2\pi M` with ``M`` even (the map runs :math:`T/2`).
    t_start : float
        The section.
    **kw
        As :class:`~tps_solver.solvers.shooting.period_map.PeriodMap` (``stuck``, ``method``, ...).

    Attributes
    ----------
    full_period : float
        :math:`T`; the inherited ``T`` is :math:`T/2`, and ``count`` counts half periods.

    Raises
    ------
    ValueError
        A lattice that is not mirror symmetric, or a period that is not an even multiple of
        :math:`2\pi`.

    Examples
    --------
    The flat layer is not a fixed point of G (its two halves are in phase), a kink is; the
    e = 0 kink on a coarse lattice (dx = 8):

    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=6, length=40.0)
    >>> orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False)
    >>> G = MirroredHalfPeriodMap(lat, 4.1, 0.0, orb.period, orb.t_start, stuck=orb.stuck0)
    >>> x = G.pack(orb.w0, orb.zeta0)
    >>> F, Px, extra = G.residual(x)
    >>> bool(G.error(F, (Px, extra)) < 1e-10), G.count
    (True, 1)
    """

    def __init__(self, lattice, Gamma, e, period, t_start, **kw):
        M = float(period) / (2.0 * np.pi)
        if abs(M - round(M)) > 1e-9 or round(M) % 2:
            raise ValueError(f"period must be 2 pi M with M even (an f/M kink), got period = {period!r}")
        if not mirror_symmetric(lattice):
            raise ValueError("lattice must be planar and symmetric under x -> -x (nodes and operator), e.g. "
                             "Lattice.planar(n_nodes=41, length=40.0) with the default center=0")
        super().__init__(lattice, Gamma, e, 0.5 * float(period), t_start, **kw)
        self.full_period = float(period)

    def at(self, **values):
        """The map at other parameter values (the count restarts at 0)."""
        pm = super().at(**values)
        return MirroredHalfPeriodMap(pm.lattice, pm.Gamma, pm.e, self.full_period, pm.t_s, stuck=pm.stuck,
                                     method=pm.method, max_events_per_period=pm.max_events, fd_step=pm.fd_step,
                                     require_free=pm.require_free, **pm.kw)

    def _mirror(self, y):
        """The mirror of packed unknowns (free nodes' w, then zeta) on a mirror-symmetric free set."""
        w, z = self.state(y)
        return self.pack(w[::-1], z[::-1])

    def _soft_half(self, x):
        """The exact half-period monodromy of the soft contact (no node is held there)."""
        if np.any(self.stuck):
            raise ValueError("the soft contact's mirrored monodromy needs no stuck node at the section")
        return SoftMonodromy.from_run(self.run(x), *self.state(x), self.t_s)

    def __call__(self, x):
        """``(G(x), extra)``: the mirrored image after half a period, and the largest |w|, zeta of a
        node stuck at the section in the mirrored image (1e-300 if such a node is free there)."""
        run = self.run(x)
        w, z, stuck = run.w[::-1], run.zeta[::-1], run.stuck[::-1]
        extra = 0.0
        if self.method != "soft" and np.any(self.stuck):
            extra = float(np.max(np.abs(np.concatenate((w[self.stuck], z[self.stuck])))))
            if np.any(~stuck[self.stuck]):
                extra = max(extra, 1e-300)
        return self.pack(w, z), extra

    def monodromy(self, x, data=None):
        """The action of dG/dx: mirrored half-period actions (exact for the soft contact)."""
        if self.method != "soft":
            return super().monodromy(x, data)          # its differences go through __call__ (mirrored)
        lin = self._soft_half(x)
        size = 2 * self.m
        return LinearOperator((size, size), matvec=lambda v: self._mirror(lin.jv(v)), dtype=float)

    def monodromy_matrix(self, x, step=1e-6):
        """The dense dG/dx: central differences for point impacts (and at a grazing soft switch),
        the mirrored exact half-period monodromy for the soft contact."""
        if self.method == "soft":
            try:
                half = self._soft_half(x).matrix()
            except ValueError as exc:
                if "grazing" not in str(exc):
                    raise
            else:
                n = self.m
                perm = np.concatenate((np.arange(n)[::-1], n + np.arange(n)[::-1]))
                return half[perm]
        return self.matrix(x, step, heights="free")


def solve_mirrored(lattice, Gamma, e, period, t_start, w, zeta, stuck, method="exact", simulate_kw=None, *,
                   tol=None, max_iter=80, callback=None):
    r"""Newton on :math:`G(x) = x` (:class:`MirroredHalfPeriodMap`) from the state ``(w, zeta, stuck)`` at ``t_start``.

    Parameters
    ----------
    lattice : Lattice
        Planar and mirror symmetric.
    Gamma, e : float
    period : float
        The kink's period :math:`T = 2\pi M`, ``M`` even.
    t_start : float
        The section (the time of the state).
    w, zeta : ndarray of float, shape (n_nodes,)
    stuck : ndarray of bool, shape (n_nodes,)
        Nodes stuck to the plate at the section (no unknowns).
    method : str
        FDA method of the map.
    simulate_kw : dict, optional
        Keywords of :func:`~tps_solver.simulate` (``cutoff`` for the soft contact).
    tol : float, optional
        On :math:`\max|G(x) - x|`; default 1e-11 (1e-10 for the soft contact).
    max_iter : int
    callback : callable, optional
        ``callback(state)`` after every Newton step (stage ``"shooting"``, ``symmetric=True``, ``x`` the
        iterate of :math:`G`'s unknowns).

    Returns
    -------
    found : tuple or None
        ``(w, zeta, stuck, nit)`` of the fixed point, None if Newton did not converge.
    why : str
        Why not ('' when found).
    half_periods : int
        Half periods of the FDA integrated.

    Raises
    ------
    KeyboardInterrupt
        If the Newton iteration was interrupted (status 5).

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=10, length=36.0)
    >>> orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False)
    >>> found, why, _ = solve_mirrored(lat, 4.1, 0.0, orb.period, orb.t_start, orb.w0, orb.zeta0, orb.stuck0)
    >>> found[3], why                          # already a fixed point of G: no Newton step
    (0, '')
    """
    pm = MirroredHalfPeriodMap(lattice, Gamma, e, period, t_start, stuck=stuck, method=method,
                               **dict(simulate_kw or {}))
    x0 = pm.pack(w, zeta)
    tol = tol or (1e-11 if method != "soft" else 1e-10)

    def progress(state):
        if callback is not None:
            callback(progress_state("shooting", state.iteration, residual=state.residual, x=state.x, symmetric=True))

    try:
        sol = newton(pm, x0, tol=tol, max_iter=max_iter, linear="gmres", line_search="quadratic", merit="2",
                     gmres_rtol=1e-4, gmres_restart=min(2 * pm.m, 100), gmres_maxiter=1, callback=progress)
    except PeriodMapError as exc:
        return None, f"the mirrored half-period Newton stopped ({exc.message}); ", pm.count
    if sol.status == 5:
        raise KeyboardInterrupt
    if not sol.converged:
        return None, (f"the mirrored half-period Newton did not converge ({sol.message}, max|G(x) - x| = "
                      f"{sol.residual:.2e} after {sol.nit} steps); "), pm.count
    wS, zS = pm.state(sol.x)
    return (wS, zS, np.asarray(stuck, bool).copy(), sol.nit), "", pm.count


def central_action(pm, x, step):
    r"""The central-difference action :math:`v \mapsto [G(x + hv) - G(x - hv)]/(2h)` of a map, with its one-sided halves.

    Central differences have error :math:`O(h^2)` plus the map's round-off over :math:`h`: with
    the exact integrator's noise of about :math:`2\cdot 10^{-13}` a relative step of
    :math:`10^{-5}` leaves about :math:`10^{-8}`, where one-sided differences of step
    :math:`10^{-7}` leave :math:`h\,|D^2G|/2 \approx 10^{-6}`.  Heights stay admissible
    (:math:`\zeta \ge 0`): the step is at most half the distance to 0 along ``v``.

    Parameters
    ----------
    pm : PeriodMap
        The map (a :class:`MirroredHalfPeriodMap` or a :class:`PeriodMap`).
    x : ndarray of float, shape (2 m,)
    step : float
        Relative step: :math:`h\,\|v\|_\infty =` ``step`` :math:`\cdot\max(1, \|x\|_\infty)`.

    Returns
    -------
    matvec : callable
        ``v -> (G(x + hv) - G(x - hv)) / (2h)``, two maps per product.
    sides : list
        Filled by the first two products with ``(G(x + hv), G(x - hv), h)`` (the
        differentiability test of :func:`mirrored_multipliers` goes on from them).

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=4, length=60.0)
    >>> flat = tps.FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> pm = PeriodMap(lat, 2.5, 0.45, flat.period, 1.0)
    >>> x = pm.pack(np.full(4, flat.velocity(1.0)), np.full(4, flat.height(1.0)))
    >>> jv, sides = central_action(pm, x, 1e-5)
    >>> y = jv(np.concatenate((np.ones(4), np.zeros(4))))     # the uniform velocity mode
    >>> len(sides), pm.count, y.shape
    (1, 2, (8,))
    """
    m = pm.m
    scale = max(1.0, float(np.max(np.abs(x), initial=0.0)))
    sides = []

    def matvec(v):
        v = np.asarray(v, dtype=float).ravel()
        nv = float(np.max(np.abs(v), initial=0.0))
        if nv == 0.0:
            return np.zeros_like(v)
        h = step * scale / nv
        if pm.method != "soft":
            vz = np.abs(v[m:])
            mask = vz > 0.0
            if np.any(mask):
                h = min(h, 0.5 * float(np.min(x[m:][mask] / vz[mask])))
        if not h > 0.0:
            raise PeriodMapError(3, "a height is 0 at the section along the difference direction: central "
                                    "differences of the map are not admissible there")
        fp, fm = pm(x + h * v)[0], pm(x - h * v)[0]
        if len(sides) < 2:
            sides.append((fp, fm, h))
        return (fp - fm) / (2.0 * h)

    return matvec, sides


def mirrored_multipliers(pm, x, k, step=1e-5, dense=False, tol=1e-9, max_dim=20, seed=12345, Gx=None,
                         drtol=None):
    r"""Multipliers of :math:`P_T = G^2` at a fixed point of :math:`G = S\circ P_{T/2}`, from :math:`G` alone.

    At a fixed point :math:`x^*` of :math:`G` the chain rule gives
    :math:`DP_T(x^*) = DG(x^*)^2`, so every multiplier of :math:`P_T` is the square of an
    eigenvalue :math:`\lambda` of :math:`DG`, with multiplicity, and the ordering by modulus
    is kept (:math:`|\lambda^2| = |\lambda|^2`).  The sign of :math:`\lambda` is the mode's
    parity under the half-period shift and mirror: the front's translation, reversed by the
    mirror, has :math:`\lambda \approx -1` and :math:`\mu = \lambda^2 \approx 1`
    (docs/design.md, hazard 12).  A product of :math:`DG` costs two half periods (central differences, see
    :func:`central_action`), as much as a one-sided product of :math:`DP_T`, and is about 100
    times more accurate; the Arnoldi factorisation stops as soon as the ``k`` leading Ritz pairs
    have converged, and the perturbed images of its first two products test the
    differentiability of :math:`P_T` (forward against backward differences,
    :math:`P(x \pm hv) = G(G(x \pm hv))`: five more half periods).

    Parameters
    ----------
    pm : MirroredHalfPeriodMap
    x : ndarray of float, shape (2 m,)
        A fixed point of ``pm``.
    k : int
        Leading multipliers wanted (all of them with ``dense``).
    step : float
        Relative central-difference step.
    dense : bool
        The dense :math:`DG` (2 m central columns, 2 m periods of the FDA) and all its eigenvalues.
    tol : float
        Arnoldi stops when the first-order error bound :math:`2|\lambda_i|\,r_i` of every
        leading :math:`\mu_i = \lambda_i^2` from the Ritz residual estimates :math:`r_i` is below
        ``tol`` :math:`\cdot|\mu_1|` (:func:`~tps_solver.solvers.shooting.floquet.ritz_multipliers`
        with ``power=2``).
    max_dim : int
        Largest Krylov dimension.
    seed : int
        Seed of the start vector.
    Gx : ndarray of float, shape (2 m,), optional
        :math:`G(x)` if known (saves a half period).
    drtol : float, optional
        Stop as soon as the differentiability test fails, i.e. the gap exceeds ``drtol`` times
        ``max(size, 1)`` (``mu`` and ``half`` are then None); default: never stop.

    Returns
    -------
    Bunch
        ``mu`` (complex, shape (k,) or (2 m,): the multipliers of :math:`P_T`, by decreasing
        modulus), ``half`` (the eigenvalues :math:`\lambda` of :math:`DG`, same order),
        ``residuals`` (Ritz residual estimates of :math:`\lambda`, None when dense), ``dim``
        (Krylov dimension, 0 when dense), ``gap`` and ``size`` (largest gap between forward and
        backward differences of :math:`P_T`, and the size of the differences, over two directions).

    Examples
    --------
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=10, length=36.0)
    >>> orb = tps.lattice_kink(lat, Gamma=4.1, e=0.0, periods=4, multipliers=False)
    >>> G = MirroredHalfPeriodMap(lat, 4.1, 0.0, orb.period, orb.t_start, stuck=orb.stuck0)
    >>> out = mirrored_multipliers(G, G.pack(orb.w0, orb.zeta0), k=2)
    >>> bool(np.allclose(out.mu, out.half ** 2)), bool(out.gap < 1e-3 * out.size)
    (True, True)
    """
    from tps_solver.core.bunch import Bunch
    from tps_solver.solvers.shooting.floquet import multipliers, ritz_multipliers

    n = 2 * pm.m
    rng = np.random.default_rng(seed)
    inner, sides = central_action(pm, x, step)
    test = {}

    def differentiability():
        # of P = G o G (not of G: G alone can have a kink within 1e-6 that the second half
        # period erases, e.g. a landing order at the far end that the next sticking forgets),
        # one-sided along the first two directions: P(x +- hv) = G(G(x +- hv)), P(x) = G(G(x))
        P0 = pm(pm(x)[0] if Gx is None else Gx)[0]
        gap = size = 0.0
        for Gp, Gm, h in sides:
            fp, fm = (pm(Gp)[0] - P0) / h, (P0 - pm(Gm)[0]) / h
            gap = max(gap, float(np.max(np.abs(fp - fm))))
            size = max(size, float(np.max(np.abs(fp) + np.abs(fm))))
        test.update(gap=gap, size=size)
        if drtol is not None and gap > drtol * max(size, 1.0):
            raise _NotDifferentiable

    def jv(v):
        y = inner(v)
        if len(sides) == 2 and not test:
            differentiability()
        return y

    residuals, dim, lam = None, 0, None
    try:
        if dense:
            J = np.empty((n, n))
            for j in range(n):
                e_j = np.zeros(n)
                e_j[j] = 1.0
                J[:, j] = jv(e_j)
            lam = multipliers(J)
        else:
            k = min(int(k), n - 1)
            lam, residuals, dim = ritz_multipliers(jv, n, k, min(n, int(max_dim)), rng.standard_normal(n),
                                                   tol=tol, power=2)
        while not test:             # fewer than two products so far: test along random directions
            jv(rng.standard_normal(n))
    except _NotDifferentiable:
        return Bunch(mu=None, half=None, residuals=None, dim=0, **test)
    lam = np.asarray(lam, dtype=complex)
    order = np.argsort(-np.abs(lam), kind="stable")
    lam = lam[order]
    if residuals is not None:
        residuals = np.asarray(residuals)[order]
    return Bunch(mu=lam ** 2, half=lam, residuals=residuals, dim=int(dim), **test)


class _NotDifferentiable(Exception):
    """The differentiability test of :func:`mirrored_multipliers` failed (stops the products)."""
