r"""Lattices of the finite-difference approximation (FDA), eqs. (51)-(52), (63), (66).

A :class:`Lattice` holds the nodes of a one-dimensional grid (planar ``x`` for
kinks, radial ``r`` for oscillons) and the discrete Laplacian :math:`\underline L`
of (52) in *conservative* (finite-volume) form

.. math::  (\underline L u)_i = \frac{1}{V_i}\sum_j S_{ij} u_j ,

with cell volumes :math:`V_i > 0` and a symmetric flux matrix :math:`S`
(:math:`S\underline\sigma = 0`).  Hence :math:`\underline L = V^{-1}S` is
self-adjoint and non-positive in the inner product :math:`\langle u, v\rangle =
\sum_i V_i u_i v_i`, and :math:`V^{1/2}\underline L V^{-1/2}` is a symmetric
matrix: the exact integrator diagonalises it with ``scipy.linalg.eigh``.

* planar, uniform grid: the interior rows are exactly (63); Neumann ends use
  half cells (the ghost-node reflection), which is second order;
* axisymmetric: faces at :math:`r_{i\pm1/2}`, fluxes :math:`r_{i+1/2}(u_{i+1}-u_i)/(r_{i+1}-r_i)`,
  volumes :math:`(r_{i+1/2}^2 - r_{i-1/2}^2)/2`.  This is the conservative form
  of :math:`r^{-1}\partial_r(r\partial_r)`; it is regular at :math:`r = 0` (no
  flux through the axis) and, on the quasi-logarithmic grid
  :math:`r = e^{\xi} - 1` of (66) with uniform :math:`\xi`, it is a consistent
  discretisation of the transformed operator of (66) (faces at the
  :math:`\xi`-midpoints).  The outer end is a Neumann (no-flux) end.

``boundary="pinned"`` (planar only) makes the two end nodes *autonomous*:
their rows of :math:`\underline L` are zero, so each end evolves as a free
bouncing ball (flat layer) with restitution, following the flat-layer state it
is given; the interior sees them as moving Dirichlet data.  This is the
paper's kink set-up ("pinning of the end points to flat-layer states").
"""
import numpy as np
import scipy.linalg

from tps_solver.core import archive
from tps_solver.core.checks import check_array, check_choice, check_int, check_positive
from tps_solver.core.costs import check_cost, lattice_cost

__all__ = ["Lattice", "lattice_eigenvalues"]

_GEOMETRIES = ("planar", "axisymmetric")
_BOUNDARIES = ("neumann", "pinned")
_GRIDS = ("uniform", "quasilog")


def _check_size(n_nodes):
    """Refuse a lattice whose dense n x n matrices are out of reach (tps_solver.core.costs)."""
    check_cost("Lattice", "n_nodes", n_nodes, *lattice_cost(n_nodes),
               hint="the Laplacian and the flux matrix are dense n_nodes x n_nodes arrays")


def _check_nodes(nodes):
    nodes = check_array(nodes, "nodes", ndim=1)
    _check_size(nodes.size)
    if nodes.size < 3:
        raise ValueError(f"nodes must hold at least 3 points (n_nodes >= 3), got {nodes.size}")
    if np.any(np.diff(nodes) <= 0):
        raise ValueError("nodes must be strictly increasing (a monotone grid)")
    return nodes


class Lattice:
    r"""A one-dimensional FDA lattice with its conservative Laplacian.

    Use the factories :meth:`planar` and :meth:`axisymmetric`; the constructor
    accepts arbitrary strictly increasing nodes.

    Parameters
    ----------
    nodes : array_like of float, shape (n_nodes,)
        Strictly increasing node coordinates, ``n_nodes >= 3``; for
        ``geometry="axisymmetric"`` the first node must be ``r = 0``.
    geometry : {"planar", "axisymmetric"}
    boundary : {"neumann", "pinned"}
        ``"pinned"`` is available for planar lattices only.

    Attributes
    ----------
    nodes : ndarray of float, shape (n_nodes,)
    geometry, boundary, grid : str
    volumes : ndarray of float, shape (n_nodes,)
        Cell volumes :math:`V_i` (lengths for planar, :math:`r\,dr` areas for axisymmetric).
    flux : ndarray of float, shape (n_nodes, n_nodes)
        The symmetric flux matrix :math:`S`, zero row sums.
    operator : ndarray of float, shape (n_nodes, n_nodes)
        :math:`\underline L = V^{-1}S`, with zero rows at pinned (autonomous) ends.
    autonomous : ndarray of bool, shape (n_nodes,)
        True at pinned ends.
    spacing : float
        The smallest node spacing -- the grid's cut-off length (docs/design.md, hazard 8).

    Examples
    --------
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> lat.nodes
    array([-2., -1.,  0.,  1.,  2.])
    >>> lat.operator[2]
    array([ 0.,  1., -2.,  1.,  0.])
    """

    def __init__(self, nodes, geometry="planar", boundary="neumann", grid="custom"):
        self.geometry = check_choice(geometry, "geometry", _GEOMETRIES)
        self.boundary = check_choice(boundary, "boundary", _BOUNDARIES)
        nodes = _check_nodes(nodes)
        if self.geometry == "axisymmetric":
            if nodes[0] != 0.0:
                raise ValueError(f"nodes of an axisymmetric lattice must start at r = 0, got {nodes[0]!r}")
            if self.boundary == "pinned":
                raise ValueError("boundary must be 'neumann' for an axisymmetric lattice "
                                 "(the axis is regular and the outer end has no flux)")
        self.nodes = nodes
        self.grid = grid
        n = nodes.size
        h = np.diff(nodes)
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            self._build(nodes, h, grid)
        if not (np.all(np.isfinite(self.operator)) and np.all(np.isfinite(self.volumes))
                and np.all(self.volumes > 0.0)):
            raise ValueError(f"nodes must be spaced so that the Laplacian ~ 1/spacing**2 is finite: the smallest "
                             f"spacing {float(h.min())!r} (span {float(nodes[-1] - nodes[0])!r}) gives a "
                             "non-finite or degenerate operator; use spacings above about 1e-150")
        self.spacing = float(h.min())

    def _build(self, nodes, h, grid):
        """The cell volumes, the flux matrix and the operator of the nodes (spacings ``h``)."""
        n = nodes.size
        if self.geometry == "planar":
            faces = np.concatenate(([nodes[0]], 0.5 * (nodes[:-1] + nodes[1:]), [nodes[-1]]))
            self.volumes = np.diff(faces)
            conductance = 1.0 / h
        else:
            faces = self._radial_faces(nodes, grid)
            self.volumes = 0.5 * np.diff(faces ** 2)
            conductance = faces[1:-1] / h
        S = np.zeros((n, n))
        i = np.arange(n - 1)
        S[i, i + 1] = conductance
        S[i + 1, i] = conductance
        S[np.arange(n), np.arange(n)] = -S.sum(axis=1)
        self.flux = S
        L = S / self.volumes[:, None]
        self.autonomous = np.zeros(n, dtype=bool)
        if self.boundary == "pinned":
            self.autonomous[[0, -1]] = True
            L[self.autonomous] = 0.0
        self.operator = L

    @staticmethod
    def _radial_faces(nodes, grid):
        """Cell faces: xi-midpoints on the quasi-log grid, r-midpoints otherwise; 0 and r_max at the ends."""
        if grid == "quasilog":
            xi = np.log1p(nodes)
            mid = np.expm1(0.5 * (xi[:-1] + xi[1:]))
        else:
            mid = 0.5 * (nodes[:-1] + nodes[1:])
        return np.concatenate(([0.0], mid, [nodes[-1]]))

    # ------------------------------------------------------------ factories
    @classmethod
    def planar(cls, n_nodes=41, length=20.0, boundary="neumann", center=0.0):
        """Uniform planar lattice on ``[center - length/2, center + length/2]``, Laplacian (63).

        Parameters
        ----------
        n_nodes : int
            Number of nodes, >= 3 (spacing ``length / (n_nodes - 1)``).  The Laplacian is
            stored dense: a lattice whose n_nodes x n_nodes matrices do not fit in memory
            raises ``ValueError`` before anything is allocated (:mod:`tps_solver.core.costs`).
        length : float
            Total length > 0.  A kink lives on the full line ``x in [-length/2, length/2]``.
        boundary : {"neumann", "pinned"}
            ``"pinned"``: the two end nodes evolve as free flat layers (zero
            rows of the operator), e.g. the two flat phases ``t0`` and ``t0 + T/2``.
        center : float
            Midpoint of the lattice.

        Returns
        -------
        Lattice

        Examples
        --------
        >>> Lattice.planar(n_nodes=41, length=20.0, boundary="pinned").spacing
        0.5
        """
        n_nodes = check_int(n_nodes, "n_nodes", minimum=3)
        _check_size(n_nodes)
        length = check_positive(length, "length")
        boundary = check_choice(boundary, "boundary", _BOUNDARIES)
        nodes = center + length * (np.arange(n_nodes) / (n_nodes - 1) - 0.5)
        lat = cls(nodes, "planar", boundary, grid="uniform")
        lat.spacing = length / (n_nodes - 1)       # nominal spacing, free of node round-off
        return lat

    @classmethod
    def axisymmetric(cls, n_nodes=200, r_max=20.0, grid="quasilog"):
        r"""Radial lattice on ``[0, r_max]`` with a regular axis and a no-flux outer end.

        Parameters
        ----------
        n_nodes : int
            Number of nodes, >= 3.
        r_max : float
            Outer radius > 0.
        grid : {"quasilog", "uniform"}
            ``"quasilog"``: uniform in :math:`\xi` with :math:`r = e^{\xi} - 1`, eq. (66);
            ``"uniform"``: uniform in ``r``.

        Returns
        -------
        Lattice

        Examples
        --------
        >>> lat = Lattice.axisymmetric(n_nodes=4, r_max=7.0, grid="quasilog")
        >>> lat.nodes
        array([0., 1., 3., 7.])
        """
        n_nodes = check_int(n_nodes, "n_nodes", minimum=3)
        _check_size(n_nodes)
        r_max = check_positive(r_max, "r_max")
        grid = check_choice(grid, "grid", _GRIDS)
        if grid == "quasilog":
            xi = np.linspace(0.0, np.log1p(r_max), n_nodes)
            nodes = np.expm1(xi)
            nodes[-1] = r_max
        else:
            nodes = np.linspace(0.0, r_max, n_nodes)
        return cls(nodes, "axisymmetric", "neumann", grid=grid)

    # --------------------------------------------------------------- helpers
    @property
    def n_nodes(self):
        """Number of nodes."""
        return self.nodes.size

    def apply(self, u):
        """Return :math:`\\underline L u` for ``u`` of shape (n_nodes,) or (n_nodes, k)."""
        return self.operator @ u

    def __repr__(self):
        return (f"Lattice(geometry={self.geometry!r}, boundary={self.boundary!r}, grid={self.grid!r}, "
                f"n_nodes={self.n_nodes}, span=[{self.nodes[0]:g}, {self.nodes[-1]:g}], "
                f"spacing={self.spacing:.4g})")


def lattice_eigenvalues(lattice):
    r"""Eigenvalues :math:`\lambda \ge 0` of :math:`-\underline L` (symmetrised), ascending.

    Parameters
    ----------
    lattice : Lattice
        With Neumann ends (all nodes coupled).

    Returns
    -------
    lam : ndarray of float, shape (n_nodes,)

    Examples
    --------
    A uniform Neumann lattice of n nodes and spacing h (half cells at the ends) has the
    closed-form spectrum ``(4 / h**2) sin^2(k pi / (2 (n - 1)))``, k = 0, ..., n - 1:

    >>> lam = lattice_eigenvalues(Lattice.planar(n_nodes=5, length=4.0))
    >>> np.round(lam, 6).tolist()
    [0.0, 0.585786, 2.0, 3.414214, 4.0]
    >>> bool(np.allclose(lam, 4 * np.sin(np.arange(5) * np.pi / 8) ** 2))
    True
    """
    v = np.sqrt(lattice.volumes)
    S = -lattice.flux / v[:, None] / v[None, :]
    lam = scipy.linalg.eigvalsh(0.5 * (S + S.T))
    return np.maximum(lam, 0.0)


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _encode_lattice(lat):
    return {"nodes": lat.nodes, "geometry": lat.geometry, "boundary": lat.boundary, "grid": lat.grid,
            "spacing": lat.spacing}


def _decode_lattice(data):
    lat = Lattice(data["nodes"], data["geometry"], data["boundary"], grid=data["grid"])
    spacing = data["spacing"]
    if not isinstance(spacing, float) or not abs(spacing - lat.spacing) <= 1e-9 * lat.spacing:
        raise ValueError(f"inconsistent: the stored spacing {spacing!r} is not the node spacing {lat.spacing!r}")
    lat.spacing = spacing          # the nominal spacing of Lattice.planar, free of node round-off
    return lat


archive.register("Lattice", Lattice, encode=_encode_lattice, decode=_decode_lattice)
