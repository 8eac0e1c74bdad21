r"""Instantaneous impact rules with a cut-off length: the candidates that the cut-off study rejects.

With point impacts (54) on a lattice the only length that limits the
impact-order effect of hazard 7 of docs/design.md is the lattice spacing: the column that
rebounds first drags its neighbours through a velocity step of the size of the
impact jump across one spacing, a kick :math:`\propto \nu/\Delta x^2`, and the
flat layer's response to small perturbations grows without bound under
refinement (measured in ``validation/cutoff.py``).  The paper names a cut-off
length as necessary (remark after (11)) and regularises with the diffused
Stosslet (67).  This module makes the cut-off an explicit model parameter
``cutoff`` (a length in viscous units, :math:`\nu = 1`) and offers the
candidates evaluated in ``validation/sections/cutoff.md``:

Instantaneous rules (usable as ``simulate(..., impact=rule)``)
---------------------------------------------------------------
``"kernel"``
    Normalised impulse kernel.  A contact set :math:`\mathscr P` gives every free
    node the kick :math:`\Delta w_i = -(1+e)\sum_{c\in\mathscr P}K_{ic}\,w^-_c`
    with the row-normalised kernel :math:`K_{ij} = k(x_i - x_j)V_j/\sum_m
    k(x_i-x_m)V_m`, :math:`k(d) = e^{-|d|/\ell}`.  A flat layer impacting all at
    once gets :math:`w^+ = -e\,w^-` (rows sum to one, to round-off).
``"patch"``
    Coherent patches: the contact set is widened to every free node that is
    approaching the plate (:math:`w < 0`) within distance ``cutoff`` of a
    contact node, and the whole patch rebounds by (11).  A flat layer gets
    exactly :math:`w^+ = -e\,w^-`.
The paper's literal, unnormalised (67) is ``simulate(..., impact="diffused",
rho_c=...)`` of :mod:`.events`; it is evaluated for comparison.

**Status (measured in** ``validation/cutoff.py`` **).**  Both instantaneous rules
are *experimental and rejected*: the kernel rule responds at O(1) to a 1e-7
perturbation of a flat layer (the order of nearly simultaneous impacts enters
at O(1)); the patch rule's growth factor diverges under refinement like point
impacts.  They are kept for comparison.  The soft contact below is the model
that converges.

These rules live next to the study that evaluates and rejects them
(``validation/cutoff.py``); the soft contact (:mod:`tps_solver.model.soft_flat`,
``simulate(..., method="soft", cutoff=...)``) is the model that converges.
"""
import numpy as np

import math
import numbers

__all__ = ["RULES", "regularised_impact", "kernel_matrix", "kernel_impact", "patch_impact"]

RULES = ("kernel", "patch")


def _distances(lattice):
    x = lattice.nodes
    return np.abs(x[:, None] - x[None, :])


def kernel_matrix(lattice, cutoff):
    r"""Row-normalised exponential kernel :math:`K_{ij} = e^{-|x_i-x_j|/\ell}V_j/\sum_m e^{-|x_i-x_m|/\ell}V_m`.

    Parameters
    ----------
    lattice : Lattice
    cutoff : float
        Kernel length :math:`\ell > 0`.

    Returns
    -------
    K : ndarray of float, shape (n_nodes, n_nodes)
        Non-negative, rows summing to one.  On axisymmetric lattices the
        distance is :math:`|r_i - r_j|` and the weights are the annulus areas
        :math:`V_j` (a radial, not a two-dimensional, kernel).

    Examples
    --------
    >>> from tps_solver.solvers.fda import Lattice
    >>> K = kernel_matrix(Lattice.planar(n_nodes=5, length=4.0), 1.0)
    >>> bool(np.allclose(K.sum(axis=1), 1.0))
    True
    """
    K = np.exp(-_distances(lattice) / cutoff) * lattice.volumes[None, :]
    return K / K.sum(axis=1, keepdims=True)


def kernel_impact(w_minus, contact, e, lattice, free, K):
    r"""Normalised-kernel impact: :math:`\Delta w = -(1+e)K_{:,\mathscr P}\,w^-_{\mathscr P}` on free nodes.

    A contact set holding every free node of a uniform state gets
    :math:`w^+ = -e\,w^-` to round-off (rows of ``K`` sum to one).

    Parameters
    ----------
    w_minus : ndarray of float, shape (n_nodes,)
    contact : ndarray of int
    e : float
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)
    K : ndarray of float, shape (n_nodes, n_nodes)
        From :func:`kernel_matrix`.

    Returns
    -------
    w_plus : ndarray of float, shape (n_nodes,)
    """
    w = w_minus.copy()
    kick = -(1.0 + e) * (K[:, contact] @ w_minus[contact])
    w[free] += kick[free]
    return w


def patch_impact(w_minus, contact, e, lattice, free, cutoff):
    r"""Coherent-patch impact: restitution (11) on every approaching free node within ``cutoff`` of the set.

    Parameters
    ----------
    w_minus : ndarray of float, shape (n_nodes,)
    contact : ndarray of int
    e : float
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)
    cutoff : float

    Returns
    -------
    w_plus : ndarray of float, shape (n_nodes,)

    Examples
    --------
    >>> from tps_solver.solvers.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> patch_impact(np.array([-1.0, -1.0, -1.0, -1.0, 2.0]), np.array([0]), 0.5, lat,
    ...              np.ones(5, bool), 1.5)
    array([ 0.5,  0.5, -1. , -1. ,  2. ])
    """
    x = lattice.nodes
    near = np.min(np.abs(x[:, None] - x[contact][None, :]), axis=1) <= cutoff
    patch = near & free & (w_minus < 0.0)
    patch[contact] = True
    w = w_minus.copy()
    w[patch] = -e * w_minus[patch]
    return w


class _Rule:
    """A picklable impact rule carrying its cut-off (``rule.cutoff``)."""

    def __init__(self, kind, cutoff):
        self.kind = kind
        self.cutoff = {"kind": f"{kind} impact", "length": cutoff}
        self._lattice, self._K = None, None

    def __call__(self, w_minus, contact, e, lattice, free):
        if self.kind == "patch":
            return patch_impact(w_minus, contact, e, lattice, free, self.cutoff["length"])
        if self._lattice is not lattice:             # cache for the lattice in use (held, so never stale)
            self._lattice, self._K = lattice, kernel_matrix(lattice, self.cutoff["length"])
        return kernel_impact(w_minus, contact, e, lattice, free, self._K)

    def __repr__(self):
        return f"regularised_impact({self.kind!r}, cutoff={self.cutoff['length']!r})"


def regularised_impact(kind, cutoff):
    """Impact rule with a physical cut-off length, for ``simulate(..., impact=rule)``.

    Parameters
    ----------
    kind : {"kernel", "patch"}
        See the module docstring.
    cutoff : float
        The cut-off length :math:`\\ell > 0` (viscous units).

    Returns
    -------
    rule : callable
        ``rule(w_minus, contact, e, lattice, free) -> w_plus``, with attribute
        ``rule.cutoff = {"kind": ..., "length": cutoff}``.

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver import FlatLayer
    >>> from tps_solver.solvers.fda import Lattice, simulate, flat_state
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> lat = Lattice.planar(n_nodes=9, length=8.0)
    >>> w, z = flat_state(lat, fl, fl.t0 + 1.0)
    >>> run = simulate(lat, 2.5, 0.45, w, z, t_start=fl.t0 + 1.0, t_end=fl.t0 + 1.0 + fl.period,
    ...                impact=regularised_impact("kernel", 0.5))
    >>> bool(np.allclose(run.zeta, z, atol=1e-12))
    True
    """
    if kind not in RULES:
        raise ValueError(f"kind must be one of {RULES}, got {kind!r}")
    if isinstance(cutoff, bool) or not isinstance(cutoff, numbers.Real) or not (
            math.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"cutoff must be a finite number > 0, got {cutoff!r}")
    cutoff = float(cutoff)
    return _Rule(kind, cutoff)
