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
saddle; their multipliers of :math:`P_T` say which).  The Floquet multipliers of the kink are
those of :math:`P_T` (:func:`~tps_solver.find_periodic_orbit` started on the fixed point of
:math:`G` converges at once and computes them); :func:`tps_solver.lattice_kink` does both.
"""
import numpy as np
from scipy.sparse.linalg import LinearOperator

from tps_solver.core.newton import newton
from tps_solver.core.progress import progress_state
from tps_solver.solvers.shooting.period_map import PeriodMap, PeriodMapError
from tps_solver.solvers.shooting.soft_monodromy import SoftMonodromy

__all__ = ["MirroredHalfPeriodMap", "mirror_symmetric", "solve_mirrored"]


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
