"""Initial states for FDA runs: flat layers and the paper's kink initial condition (Sec. 4.3.1)."""
import numpy as np

from tps_solver.core.checks import check_nonnegative, check_positive, check_real

__all__ = ["flat_state", "kink_state", "oscillon_state"]


def flat_state(lattice, flat, t):
    """Uniform state of the flat layer ``flat`` at time ``t`` on every node.

    Parameters
    ----------
    lattice : Lattice
    flat : FlatLayer
    t : float

    Returns
    -------
    w, zeta : ndarray of float, shape (n_nodes,)

    Examples
    --------
    >>> from tps_solver import FlatLayer, Lattice
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> w, z = flat_state(Lattice.planar(n_nodes=3, length=2.0), fl, fl.t0)
    >>> z.tolist(), bool(np.all(w == fl.velocity(fl.t0)) and w[0] > 0)      # launched from the plate
    ([0.0, 0.0, 0.0], True)
    """
    t = check_real(t, "t")
    n = lattice.n_nodes
    return np.full(n, float(flat.velocity(t))), np.full(n, float(flat.height(t)))


def kink_state(lattice, flat, t=None, width=2.0):
    r"""The kink initial condition at time ``t`` (Sec. 4.3.1): the package's one kink start.

    Two flat layers out of phase by half a period -- phase ``t`` for
    :math:`x < 0` and ``t + T/2`` for :math:`x > 0` -- joined by linear
    interpolation of height and velocity across ``|x| < width/2``.  ``flat`` is the far
    field of any pattern: a :class:`~tps_solver.FlatLayer` (bouncing, sticking, touch-and-go),
    the e = 0 :class:`~tps_solver.model.sticking.ContactOrbit` of
    :func:`~tps_solver.model.sticking.sticking_orbit`, or anything with ``velocity(t)``,
    ``height(t)`` and ``period``.  Used by :func:`~tps_solver.lattice_kink`, the impact-and-stick
    TPS (:func:`tps_solver.solvers.tps.stick.kink_state`) and the shooting guesses of validation.

    Parameters
    ----------
    lattice : Lattice
        Planar lattice (typically ``boundary="pinned"`` on ``[-L, L]``).
    flat : FlatLayer or ContactOrbit
    t : float, optional
        Time of the state (default: ``flat.t0 + 0.5``, half a time unit after the impact
        phase of a FlatLayer or the lift-off of a sticking orbit).
    width : float
        Width of the linear transition, >= 0; 0 is a step (a node at x = 0 takes the
        ``t + T/2`` state).

    Returns
    -------
    w, zeta : ndarray of float, shape (n_nodes,)

    Examples
    --------
    >>> from tps_solver import FlatLayer, Lattice
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> w, z = kink_state(Lattice.planar(n_nodes=5, length=8.0), fl, fl.t0 + 1.0)
    >>> bool(z[0] == fl.height(fl.t0 + 1.0) and z[-1] == fl.height(fl.t0 + 1.0 + fl.period / 2))
    True

    The e = 0 sticking far field, a step:

    >>> from tps_solver.model.sticking import sticking_orbit
    >>> orb, _ = sticking_orbit(4.1, 0.0, 2)
    >>> w, z = kink_state(Lattice.planar(n_nodes=5, length=8.0), orb, width=0.0)
    >>> bool(w[1] == orb.velocity(orb.t0 + 0.5) and w[2] == orb.velocity(orb.t0 + 0.5 + orb.period / 2))
    True
    """
    t = float(flat.t0) + 0.5 if t is None else check_real(t, "t")
    width = check_nonnegative(width, "width")
    x = lattice.nodes
    wl, zl = float(flat.velocity(t)), float(flat.height(t))
    wr, zr = float(flat.velocity(t + 0.5 * flat.period)), float(flat.height(t + 0.5 * flat.period))
    if width > 0.0:
        theta = np.clip(x / width + 0.5, 0.0, 1.0)
    else:
        theta = (x >= 0).astype(float)
    return wl + theta * (wr - wl), zl + theta * (zr - zl)


def oscillon_state(lattice, flat, t, r_core=1.0, width=0.5):
    r"""Oscillon initial condition at time ``t``: phase ``t + T/2`` inside ``r_core``, ``t`` outside.

    The radial analogue of :func:`kink_state`: the two flat states are joined by
    linear interpolation of height and velocity across ``|r - r_core| < width/2``.

    Parameters
    ----------
    lattice : Lattice
        Axisymmetric lattice.
    flat : FlatLayer
        Or anything with ``velocity(t)``, ``height(t)`` and ``period``.
    t : float
    r_core : float
        Core radius, > 0.
    width : float
        Width of the linear transition, >= 0.

    Returns
    -------
    w, zeta : ndarray of float, shape (n_nodes,)

    Examples
    --------
    >>> from tps_solver import FlatLayer, Lattice
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> lat = Lattice.axisymmetric(n_nodes=5, r_max=8.0, grid="uniform")
    >>> w, z = oscillon_state(lat, fl, fl.t0 + 1.0, r_core=4.0, width=0.0)
    >>> bool(z[0] == fl.height(fl.t0 + 1.0 + fl.period / 2) and z[-1] == fl.height(fl.t0 + 1.0))
    True
    """
    t = check_real(t, "t")
    width = check_nonnegative(width, "width")
    r_core = check_positive(r_core, "r_core")
    r = lattice.nodes
    if width > 0.0:
        theta = np.clip((r - r_core) / width + 0.5, 0.0, 1.0)          # 0 in the core, 1 outside
    else:
        theta = (r > r_core).astype(float)
    t_in = t + 0.5 * flat.period
    wo, zo = float(flat.velocity(t)), float(flat.height(t))
    wi, zi = float(flat.velocity(t_in)), float(flat.height(t_in))
    return wi + theta * (wo - wi), zi + theta * (zo - zi)
