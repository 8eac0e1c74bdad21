r"""The discretised TPS problems: the continuum (45)-(46) and its FDA-lattice twin.

Both implement the problem protocol of :mod:`tps_solver.solvers.tps.engine`.
"""
import math

import numpy as np
from scipy.sparse.linalg import LinearOperator

from tps_solver.operators.contact import contact_times
from tps_solver.model.harmonics import centred, g_hat, mode_numbers
from tps_solver.operators.helmholtz import HelmholtzSolver, LatticeHelmholtz
from tps_solver.solvers.tps.engine import TimePeriodicProblem

__all__ = ["ContinuumProblem", "LatticeProblem", "node_positions", "decoupled_spacing", "bouncing_far_field"]


# --------------------------------------------------------------------- problem
class ContinuumProblem(TimePeriodicProblem):
    """The discretised TPS problem on the solved half-domain.

    Parameters
    ----------
    geometry : {"planar", "axisymmetric"}
        Kink (staggered nodes on x > 0) or oscillon (nodes r_j = j h).
    h : float
        Node spacing.
    n_nodes : int
        Unknown nodes.
    flat : FlatLayer
        The far-field flat layer (Gamma, M, t0).
    N : int
        Harmonics n = 1..N.
    coupling : float
        The coupling nu_c scaling the Laplacian (1: the problem as posed).
    symmetry : {"kink", "even"}
        Planar only.

    Examples
    --------
    Every node at the flat phase t0 solves the contact condition (46) exactly; the kink
    step tc = t0 on x > 0 (the mirror at t0 + T/2) misses it only near x = 0:

    >>> import numpy as np
    >>> from tps_solver import FlatLayer
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> problem = ContinuumProblem("axisymmetric", 20.0, 4, flat, 8)
    >>> F, w, phase = problem.residual(np.full(4, flat.t0))
    >>> bool(np.max(np.abs(F)) < 1e-14), w.shape
    (True, (8, 4))
    >>> kink = ContinuumProblem("planar", 20.0, 8, flat, 8)
    >>> kink.x.tolist()[:3]
    [10.0, 30.0, 50.0]
    >>> F = kink.residual(np.full(8, flat.t0))[0]
    >>> round(float(F[0]), 4), bool(np.max(np.abs(F[3:])) < 1e-12)
    (-0.0103, True)
    """

    def __init__(self, geometry, h, n_nodes, flat, N, coupling=1.0, symmetry="kink"):
        self._setup_forcing(geometry, flat, N, coupling)
        self.x = node_positions(geometry, h, n_nodes)
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
        self.n = mode_numbers(N, positive=True)
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

    def paper_increment(self, tc, tc_prev, sign):
        """Harmonic increment of the paper's scheme (47): H[sigma (rhs(tc^{k-1}) - rhs(tc^{k-2}))]."""
        rhs = lambda t: -np.exp(-1j * np.outer(self.om, self._extend(t))) / self.Gamma
        dq = sign * (rhs(tc) - rhs(tc_prev))
        return self.solver.solve(dq, np.zeros_like(self.q_inf), self.parity)[:, self.offset:]

    def select_contact(self, w, tc_guess):
        """Contact times selected from the truncated series by the steep up-crossing rule."""
        return contact_times(centred(w), self.M, self.level, tc_guess=tc_guess)

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


class LatticeProblem(ContinuumProblem):
    """The TPS on an FDA lattice: the continuum Laplacian replaced by the lattice operator.

    Parameters
    ----------
    lattice : Lattice
    flat : FlatLayer
    N : int
    coupling : float
        Scales the lattice operator.

    Examples
    --------
    On a Neumann lattice a uniform shift of the contact times is a flat layer of another
    phase: F = cos t0 - cos tc at every node, and dF/dtc applied to ones is sin tc.

    >>> import math
    >>> import numpy as np
    >>> from tps_solver import FlatLayer, Lattice
    >>> flat = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> problem = LatticeProblem(Lattice.planar(n_nodes=8, length=140.0), flat, 8)
    >>> tc = np.full(8, flat.t0 + 0.05)
    >>> F, w, phase = problem.residual(tc)
    >>> bool(np.allclose(F, math.cos(flat.t0) - math.cos(flat.t0 + 0.05), atol=1e-12))
    True
    >>> J, slope = problem.jacobian_operator(tc, w, phase)
    >>> bool(np.allclose(J.matvec(np.ones(8)), math.sin(flat.t0 + 0.05), atol=1e-12))
    True
    """

    def __init__(self, lattice, flat, N, coupling=1.0):
        self._setup_forcing(lattice.geometry, flat, N, coupling)
        self.x = np.asarray(lattice.nodes, dtype=float)
        self.parity = None
        self.offset = 0
        self.symmetry = None
        self.lattice = lattice
        self.solver = LatticeHelmholtz(lattice, self.M, N, coupling=coupling)


def bouncing_far_field(Gamma, M, e=None, t0=None):
    """The single-bounce flat layer (17)-(19) that the single-contact TPS needs as its far field.

    Raises
    ------
    ValueError
        Naming ``e`` when the flat layer has no single-bounce orbit there (for instance
        ``e = 0``, where every period ends in sticking), with the solvers that handle it.

    Examples
    --------
    >>> round(bouncing_far_field(2.5, 2, e=0.45).t0, 6)
    0.30678
    >>> bouncing_far_field(4.1, 2, e=0.0)
    Traceback (most recent call last):
    ...
    ValueError: e = 0.0 gives no single-bounce flat layer at Gamma = 4.1, M = 2 (...); ...
    """
    from tps_solver.model.flat import FlatLayer

    try:
        return FlatLayer(Gamma, M, e=e, t0=t0, pattern="bounce")
    except ValueError as exc:
        if e is None:
            raise
        raise ValueError(
            f"e = {e} gives no single-bounce flat layer at Gamma = {Gamma:g}, M = {M} ({exc}); the "
            "single-contact TPS needs one impact with rebound per node and period. Where the layer "
            "sticks use tps.solve_kink(Gamma, e=0.0) for the e = 0 kink (shooting, then the impact-and-stick "
            "TPS, checked by the FDA), tps.lattice_kink / tps.lattice_oscillon (any contact pattern, by "
            "shooting; command line: tps-solver lattice-kink --gamma 4.1 --e 0), tps.solve_stick_lattice "
            "(the impact-and-stick TPS) or tps.find_periodic_orbit") from None


def decoupled_spacing(M):
    """Node spacing at which the slowest harmonic couples neighbours by < e^-30.

    Examples
    --------
    The slowest harmonic n = 1 decays like exp(-x sqrt(1 / (2M))), so the spacing is
    30 sqrt(2M):

    >>> decoupled_spacing(2)
    60.0
    >>> round(decoupled_spacing(1), 4)
    42.4264
    """
    return 30.0 / math.sqrt(0.5 / M)


def node_positions(geometry, h, n_nodes):
    """Unknown nodes on the solved half-domain: staggered (j + 1/2) h for kinks, j h for oscillons.

    Examples
    --------
    >>> node_positions("planar", 20.0, 3).tolist()
    [10.0, 30.0, 50.0]
    >>> node_positions("axisymmetric", 20.0, 3).tolist()
    [0.0, 20.0, 40.0]
    """
    return (np.arange(n_nodes) + 0.5) * h if geometry == "planar" else np.arange(n_nodes) * h
