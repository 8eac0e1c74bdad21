r"""Per-harmonic Helmholtz solves on an FDA lattice (the TPS of the FDA's own model).

The TPS equation (45) with the continuum Laplacian replaced by the FDA lattice
operator :math:`\underline L` of (52)-(53):

.. math:: (\nu_c \underline L - i n\alpha)\,\hat{\underline w}_n = \underline q_n ,
          \qquad n = 1, \dots, N.

A periodic solution of the TPS built on this operator is an exact periodic orbit
of the FDA lattice (with one contact per node and period), so the FDA can check
it without any discretisation mismatch: this is the cross-method test of
TPS against FDA on one and the same discrete model.  :math:`\underline L` is
tridiagonal (planar and axisymmetric lattices alike); each harmonic costs one
banded solve (``scipy.linalg.solve_banded``), O(n_nodes).

The lattice is closed (Neumann or pinned ends), so there is no far field:
``q_inf`` is accepted for interface compatibility with
:class:`~tps_solver.operators.helmholtz.HelmholtzSolver` and ignored.
"""
import numpy as np
from scipy.linalg import solve_banded

from tps_solver.core.checks import check_int, check_positive

__all__ = ["LatticeHelmholtz"]


class LatticeHelmholtz:
    r"""Solve :math:`(\nu_c L - i n\alpha) u_n = q_n` for ``n = 1..N`` on a lattice.

    Parameters
    ----------
    lattice : tps_solver.solvers.fda.Lattice
        Planar or axisymmetric lattice; its ``operator`` must be tridiagonal.
    M : int
        Subharmonic order, ``alpha = 1/M``.
    N : int
        Number of harmonics.
    coupling : float
        :math:`\nu_c > 0` scaling the lattice operator (1: the FDA's model).

    Examples
    --------
    >>> from tps_solver.solvers.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> solver = LatticeHelmholtz(lat, M=2, N=2)
    >>> u = solver.solve(np.ones((2, 5), dtype=complex), np.ones(2))
    >>> bool(np.allclose(u, (-1.0 / (1j * np.arange(1, 3) / 2))[:, None]))
    True
    """

    def __init__(self, lattice, M, N, coupling=1.0):
        self.M = check_int(M, "M", minimum=1)
        self.N = check_int(N, "N", minimum=1)
        coupling = check_positive(coupling, "coupling")
        L = np.asarray(lattice.operator, dtype=float)
        n = L.shape[0]
        if np.any(np.triu(L, 2)) or np.any(np.tril(L, -2)):
            raise ValueError("lattice.operator must be tridiagonal")
        self.nodes = np.asarray(lattice.nodes, dtype=float)
        self.coupling = coupling
        self._k = 1j * np.arange(1, self.N + 1) / self.M
        ab = np.zeros((3, n))
        ab[0, 1:] = np.diag(L, 1)
        ab[1] = np.diag(L)
        ab[2, :-1] = np.diag(L, -1)
        self._ab = coupling * ab

    def solve(self, q, q_inf=None, parity=None):
        """Solve for every harmonic.

        Parameters
        ----------
        q : ndarray of complex, shape (N, n_nodes)
        q_inf, parity
            Ignored (closed lattice); present for interface compatibility.

        Returns
        -------
        u : ndarray of complex, shape (N, n_nodes)
        """
        q = np.asarray(q, dtype=complex)
        if q.shape != (self.N, self.nodes.size):
            raise ValueError(f"q must have shape {(self.N, self.nodes.size)}, got {q.shape}")
        out = np.empty_like(q)
        ab = self._ab.astype(complex)
        diag = self._ab[1].copy()
        for i, k in enumerate(self._k):
            ab[1] = diag - k
            out[i] = solve_banded((1, 1), ab, q[i], check_finite=False)
        return out
