r"""Exact linearised period map of the soft-contact lattice: :class:`SoftMonodromy`.

The soft contact (:mod:`tps_solver.model.soft_flat`, :mod:`tps_solver.solvers.fda.soft`) makes the
lattice FDA (51)-(52) *piecewise linear*: with the contact configuration fixed
(node ``i`` free, in soft contact, or held by the sticking rule) the state
:math:`y = (\underline w, \underline\zeta)` obeys :math:`\dot y = A_C\,y + b_C(t)`,

.. math::
    A_C = \begin{pmatrix} D_r\underline L - 2\beta D_c & -\omega_0^2 D_c \\ D_r & 0\end{pmatrix},

(:math:`D_c` the diagonal of contact nodes, :math:`D_r` that of the nodes not held), and
the configuration changes only at switches.  So the linearised period map along an orbit
is exactly a product of matrix exponentials between switches and *saltation matrices* at
the switches,

.. math::
    J = e^{A_{C_K}\Delta t_K}\,S_K \cdots S_1\,e^{A_{C_0}\Delta t_0},\qquad
    S = D_P + \frac{\big(f^+ - D_P f^-\big)\,n^{\mathsf T}}{n\cdot f^-},

with :math:`n = e_{\zeta_i}` the normal of the switching surface :math:`\zeta_i = 0`,
:math:`f^\mp` the vector fields before and after and :math:`D_P` the derivative of the
jump map (the identity except at a capture).  Per kind of switch of node ``i`` at time
:math:`t` with velocity :math:`w_i` (:math:`E_i = e_{w_i}e_{\zeta_i}^{\mathsf T}`):

* **entry** (free -> contact, event ``"impact"``): the contact force
  :math:`-g - \omega_0^2\zeta_i - 2\beta w_i` switches on, a jump of
  :math:`-(g(t) + 2\beta w_i)` in :math:`\dot w_i` (the force is *not* continuous at
  :math:`\zeta = 0`), so :math:`S = I - \frac{g + 2\beta w_i}{w_i} E_i`;
* **exit** (contact -> free, ``"liftoff"``): :math:`S = I + \frac{g + 2\beta w_i}{w_i} E_i`;
* **capture** (``"stick"``, the sticking rule of docs/design.md, hazard 10): the jump
  :math:`w_i, \zeta_i \to 0` (:math:`D_P` zeroes both rows) and the neighbours stop seeing
  :math:`w_i`, so :math:`S = D_P - \sum_{j\ne i} L_{ji}\,e_{w_j}e_{\zeta_i}^{\mathsf T}`;
* **release** of a held node (``"liftoff"`` of a held node, when its free acceleration
  turns positive): the vector field is continuous there (:math:`w_i = \zeta_i = 0`,
  :math:`\dot w_i` goes from 0 to :math:`a_i = 0`), so :math:`S = I`.

Saltation matrices of different nodes commute (each adds a multiple of a
:math:`\zeta` row to a :math:`w` row), so simultaneous switches (a flat layer hits the
plate as one set) are applied in any order.  For a uniform state this is the 2x2 per-mode
monodromy :meth:`~tps_solver.model.soft_flat.SoftFlatOrbit.monodromy` (flight, entry saltation,
contact, exit saltation), which the tests use as the independent reference.

The switch times and velocities come from the time stepper's located events (switch times
to about 1e-12, :mod:`tps_solver.solvers.fda.soft`): the product is exact up to them and to
round-off, unlike finite differences of the period map, whose error is the stepper's
noise divided by the difference step.  The flow of an interval is a dense
``scipy.linalg.expm`` up to :data:`EXPM_MAX` unknowns and otherwise a Taylor series of the
banded generator with the heights scaled by :math:`\omega_0` (:func:`_expm_taylor`; it
agrees with ``scipy.sparse.linalg.expm_multiply`` to 7e-14 and is 9x faster (1.5 s against 13.7 s, measured on
a 201-node kink period)).  Up to ``dense_max`` unknowns the dense monodromy is built once
(the identity propagated as a block) and gives all eigenvalues; above it the product is
matrix-free and the leading eigenvalues come from ARPACK (``scipy.sparse.linalg.eigs``).
"""
import math

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from tps_solver.core.checks import check_array, check_int, check_positive, check_real
from tps_solver.solvers.fda import simulate
from tps_solver.model.soft_flat import soft_contact_parameters
from tps_solver.operators.lattice import Lattice

__all__ = ["SoftMonodromy", "soft_monodromy"]

_FREE, _CONTACT, _HELD = 0, 1, 2

#: Up to this many unknowns (2 n_nodes) each interval's flow is a dense ``scipy.linalg.expm``;
#: above it the banded Taylor series of :func:`_expm_taylor`.  Measured (one BLAS thread, loaded
#: machine): the 12-node kink's monodromy 0.32 s by expm, 0.04 s by Taylor (they agree to
#: 1.1e-12); one product on a 201-node kink period (572 intervals) 1.5 s by Taylor, 13.7 s by
#: ``scipy.sparse.linalg.expm_multiply`` (agreeing to 7e-14).
EXPM_MAX = 16

#: Up to this many unknowns :meth:`SoftMonodromy.jv` builds and uses the dense matrix (the
#: identity propagated as one block costs 2.6x one product on the 12-node kink, 2-3.5x on a
#: 49-node kink period, 52x on a 201-node one, measured), above it each product is matrix-free.
JV_DENSE_MAX = 200


class SoftMonodromy:
    r"""Linearised period map of the soft-contact lattice along one orbit segment (module docstring).

    Build it with :func:`soft_monodromy` (from a state, which time-steps the segment),
    :meth:`from_run` (from a :func:`~tps_solver.simulate` run) or :meth:`from_orbit`
    (from a :class:`~tps_solver.ShootingOrbit` of the soft model).

    Parameters
    ----------
    lattice : Lattice
        Tridiagonal operator (as ``method="soft"`` requires).
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in (0, 1).
    cutoff : float
        Soft-contact length :math:`\ell > 0`.
    t_start, t_end : float
        The segment, ``t_end > t_start``.
    zeta0 : array_like of float, shape (n_nodes,)
        Heights at ``t_start``: nodes with ``zeta0 < 0`` start in soft contact (as in
        :func:`~tps_solver.simulate`); held nodes at ``t_start`` are not supported.
    events : numpy.recarray
        The segment's events (fields ``t, node, kind, w_before``, time-ordered), as
        :func:`~tps_solver.simulate` returns them.
    dense_max : int
        Up to this many unknowns (``2 n_nodes``, default 400) :meth:`multipliers` builds the
        dense matrix and returns all eigenvalues; above it, ARPACK with the matrix-free product.  Measured on a 201-node kink period
        (572 intervals, one BLAS thread): one matrix-free product 0.5 s (the period map: 1.1 s),
        the dense matrix 26 s, ARPACK's 6 leading multipliers 28 s.

    Attributes
    ----------
    n : int
        Number of nodes; the map acts on vectors ``(dw, dzeta)`` of shape (2 n,).
    intervals : list of (ndarray of int, float)
        Contact configuration (0 free, 1 soft contact, 2 held; shape (n,)) and duration of
        each interval between switches, in time order.
    switches : list of (float, int, str, float)
        ``(t, node, kind, w)`` with kind ``"entry"``, ``"exit"``, ``"capture"`` or
        ``"release"``, between the intervals.
    tau_c, omega0_sq, beta : float
        Soft-contact constants (:func:`~tps_solver.model.soft_flat.soft_contact_parameters`).

    Examples
    --------
    The uniform flat orbit on 3 nodes: the uniform mode of the product equals the closed-form
    2x2 soft monodromy.

    >>> import numpy as np
    >>> import tps_solver as tps
    >>> from tps_solver.model.soft_flat import SoftFlatOrbit
    >>> orb = SoftFlatOrbit(2.5, 2, 0.45, 0.3)
    >>> s = orb.t_exit + 0.5 * orb.flight
    >>> w, z = orb.state(s)
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> J = soft_monodromy(lat, 2.5, 0.45, 0.3, np.full(3, w), np.full(3, z), s, orb.period)
    >>> ref = np.sort_complex(np.linalg.eigvals(orb.monodromy(0.0, t_section=s)[0]))
    >>> mu = J.multipliers()
    >>> bool(np.min(np.abs(mu[:, None] - ref[None, :]), axis=0).max() < 1e-10)
    True
    """

    def __init__(self, lattice, Gamma, e, cutoff, t_start, t_end, zeta0, events, dense_max=400):
        if not isinstance(lattice, Lattice):
            raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
        self.lattice = lattice
        self.Gamma = check_positive(Gamma, "Gamma")
        e = check_real(e, "e")
        if not 0.0 < e < 1.0:
            raise ValueError(f"e must be in (0, 1) for the soft contact, got {e!r}")
        self.e = e
        self.cutoff = check_positive(cutoff, "cutoff")
        self.tau_c, self.omega0_sq, self.beta = soft_contact_parameters(e, self.cutoff)
        self.t_start = check_real(t_start, "t_start")
        self.t_end = check_real(t_end, "t_end")
        if not self.t_end > self.t_start:
            raise ValueError(f"t_end must be > t_start = {self.t_start!r}, got {t_end!r}")
        n = self.n = lattice.n_nodes
        z0 = check_array(zeta0, "zeta0", shape=(n,))
        self.dense_max = check_int(dense_max, "dense_max", minimum=0)
        L = np.asarray(lattice.operator, float)
        if np.any(np.triu(L, 2) != 0.0) or np.any(np.tril(L, -2) != 0.0):
            raise ValueError("lattice.operator must be tridiagonal for the soft contact")
        self._L = scipy.sparse.csr_matrix(L)
        self._L3 = (np.diag(L).copy(), np.diag(L, 1).copy(), np.diag(L, -1).copy())
        self._use_dense = 2 * n <= self.dense_max
        mode = np.where(z0 < 0.0, _CONTACT, _FREE).astype(np.int8)
        self.intervals, self.switches = [], []
        self._groups = [[]]           # _groups[k]: the switches just before interval k
        t = self.t_start
        for rec in events:
            te, j, kind, wb = float(rec.t), int(rec.node), str(rec.kind), float(rec.w_before)
            if not self.t_start <= te <= self.t_end:
                raise ValueError(f"events must lie in [t_start, t_end], got an event at t = {te!r}")
            if te < t:
                raise ValueError(f"events must be time-ordered, got t = {te!r} after t = {t!r}")
            if not 0 <= j < n:
                raise ValueError(f"event node must be in 0..{n - 1}, got {j}")
            if te > t:
                self.intervals.append((mode.copy(), te - t))
                self._groups.append([])
                t = te
            if kind == "impact":
                if mode[j] != _FREE:
                    raise ValueError(f"event {kind!r} of node {j} at t = {te!r}: the node is not free")
                mode[j] = _CONTACT
                sw = "entry"
            elif kind == "stick":
                if mode[j] == _HELD:
                    raise ValueError(f"event 'stick' of node {j} at t = {te!r}: the node is already held")
                mode[j] = _HELD
                sw = "capture"
            elif kind == "liftoff":
                sw = {_CONTACT: "exit", _HELD: "release"}.get(int(mode[j]))
                if sw is None:
                    raise ValueError(f"event 'liftoff' of node {j} at t = {te!r}: the node is free")
                mode[j] = _FREE
            else:
                raise ValueError(f"event kind must be 'impact', 'liftoff' or 'stick', got {kind!r}")
            if sw in ("entry", "exit") and wb == 0.0:
                raise ValueError(f"{sw} of node {j} at t = {te!r} with zero velocity: a grazing switch, "
                                 "where the period map is not differentiable")
            self.switches.append((te, j, sw, wb))
            self._groups[-1].append(self.switches[-1])
        self.intervals.append((mode.copy(), self.t_end - t))
        self._groups.append([])
        self.mode_end = mode
        self._dense = None

    # ------------------------------------------------------------------ builders
    @classmethod
    def from_run(cls, run, w0, zeta0, t_start, dense_max=400):
        """The linearisation along a :func:`~tps_solver.simulate` run of ``method="soft"``.

        Parameters
        ----------
        run : SimulationResult
            Run from ``(w0, zeta0)`` at ``t_start`` to ``run.t`` (its events are used).
        w0, zeta0 : array_like of float, shape (n_nodes,)
            The run's initial state (``w0`` is only checked for shape).
        t_start : float
        dense_max : int

        Returns
        -------
        SoftMonodromy

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=4, length=3.0)
        >>> w, z = np.zeros(4), np.full(4, 0.01)
        >>> run = tps.simulate(lat, 2.5, 0.45, w, z, 0.0, 0.4, method="soft", cutoff=0.3)
        >>> J = SoftMonodromy.from_run(run, w, z, 0.0)
        >>> [s[2] for s in J.switches][:1], J.matrix().shape
        (['entry'], (8, 8))
        """
        if run.get("method") != "soft" or not run.success:
            raise ValueError("run must be a successful simulate(..., method='soft') run, got method "
                             f"{run.get('method')!r}, success {run.get('success')!r}")
        check_array(w0, "w0", shape=(run.lattice.n_nodes,))
        return cls(run.lattice, run.Gamma, run.e, run.cutoff["length"], t_start, run.t, zeta0, run.events,
                   dense_max=dense_max)

    @classmethod
    def from_orbit(cls, orbit, dense_max=400):
        """The monodromy of a :class:`~tps_solver.ShootingOrbit` of the soft model (its one-period events).

        Parameters
        ----------
        orbit : ShootingOrbit
            With ``method == "soft"`` and its ``events`` recorded (any converged orbit).
        dense_max : int

        Returns
        -------
        SoftMonodromy

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> from tps_solver.model.soft_flat import SoftFlatOrbit
        >>> ref = SoftFlatOrbit(2.5, 2, 0.45, 0.3)
        >>> s = ref.t_exit + 0.5 * ref.flight
        >>> w, z = ref.state(s)
        >>> lat = tps.Lattice.planar(n_nodes=3, length=1.0)
        >>> orb = tps.find_periodic_orbit(lat, 2.5, 2, 0.45, cutoff=0.3, guess=(np.full(3, w), np.full(3, z)),
        ...                               t_start=s, section="fixed", multipliers=False)
        >>> J = SoftMonodromy.from_orbit(orb)
        >>> from tps_solver.operators.lattice import lattice_eigenvalues
        >>> rho = ref.growth(lattice_eigenvalues(lat)).max()       # closed form, every lattice mode
        >>> bool(abs(abs(J.multipliers()[0]) - rho) < 1e-10)
        True
        """
        if getattr(orbit, "method", None) != "soft" or getattr(orbit, "events", None) is None:
            raise ValueError("orbit must be a ShootingOrbit of method='soft' with its events recorded")
        return cls(orbit.lattice, orbit.Gamma, orbit.e, orbit.cutoff, orbit.t_start,
                   orbit.t_start + orbit.period, orbit.zeta0, orbit.events, dense_max=dense_max)

    # ------------------------------------------------------------------ pieces
    def generator(self, mode):
        r"""The matrix :math:`A_C` of one configuration, sparse, shape (2 n, 2 n).

        Parameters
        ----------
        mode : ndarray of int, shape (n,)
            0 free, 1 soft contact, 2 held.

        Returns
        -------
        scipy.sparse.csr_matrix of float, shape (2 n, 2 n)

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> J = SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.0, np.ones(3), events=[])
        >>> J.generator(np.array([0, 1, 2])).toarray()[3:, :3].tolist()      # dzeta/dt = dw, held rows 0
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]
        """
        mode = np.asarray(mode)
        c = (mode == _CONTACT).astype(float)
        r = (mode != _HELD).astype(float)
        Dr, Dc = scipy.sparse.diags(r), scipy.sparse.diags(c)
        Aww = Dr @ self._L - 2.0 * self.beta * Dc
        return scipy.sparse.bmat([[Aww, -self.omega0_sq * Dc], [Dr, None]], format="csr")

    def _salt(self, Y, sw):
        """Apply the saltation of switch ``sw`` to the rows of Y (shape (2 n, k)) in place."""
        t, j, kind, wj = sw
        n = self.n
        if kind in ("entry", "exit"):
            a = (math.sin(t) - 1.0 / self.Gamma + 2.0 * self.beta * wj) / wj
            Y[j] += (-a if kind == "entry" else a) * Y[n + j]
        elif kind == "capture":
            col = self._L[:, [j]].toarray().ravel()
            col[j] = 0.0
            nb = np.flatnonzero(col)
            Y[nb] -= np.outer(col[nb], Y[n + j])
            Y[j] = 0.0
            Y[n + j] = 0.0
        return Y

    def _propagate(self, Y, route=None):
        """Y (2 n, k) -> J Y, interval by interval.

        ``route``: ``"expm"`` (dense ``scipy.linalg.expm`` per interval), ``"taylor"`` (scaled
        Taylor series, :func:`_expm_taylor`) or ``"expm_multiply"`` (scipy); default ``"expm"``
        up to :data:`EXPM_MAX` unknowns, else ``"taylor"``.
        """
        if route is None:
            route = "expm" if 2 * self.n <= EXPM_MAX else "taylor"
        Y = np.array(Y, dtype=float)
        for k, (mode, dt) in enumerate(self.intervals):
            for sw in self._groups[k]:
                Y = self._salt(Y, sw)
            if dt > 0.0:
                A = self.generator(mode) if route != "taylor" else None
                if route == "expm":
                    Y = scipy.linalg.expm(A.toarray() * dt) @ Y
                elif route == "taylor":
                    Y = _expm_taylor(self._L3, mode, self.beta, math.sqrt(self.omega0_sq), Y, dt)
                else:
                    Y = scipy.sparse.linalg.expm_multiply(A * dt, Y)
        for sw in self._groups[-1]:
            Y = self._salt(Y, sw)
        return Y

    # ------------------------------------------------------------------ products
    def matrix(self):
        """The dense monodromy, shape (2 n, 2 n), acting on ``(dw, dzeta)``.

        Built once (one ``scipy.linalg.expm`` per interval between switches) and cached.

        Returns
        -------
        ndarray of float, shape (2 n, 2 n)

        Examples
        --------
        With no switch the product is ``expm(A T)`` of the free configuration:

        >>> import numpy as np, scipy.linalg
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> J = SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.0, np.full(3, 5.0), events=[])
        >>> A = J.generator(np.zeros(3, int)).toarray()
        >>> bool(np.allclose(J.matrix(), scipy.linalg.expm(A), rtol=0, atol=1e-13))
        True
        """
        if self._dense is None:
            self._dense = self._propagate(np.eye(2 * self.n))
        return self._dense

    def jv(self, v):
        """The product ``J v`` of the monodromy with ``v = (dw, dzeta)``.

        By the dense matrix when it is built (or up to :data:`JV_DENSE_MAX` unknowns, unless
        ``dense_max`` is smaller), otherwise matrix-free, interval by interval.

        Parameters
        ----------
        v : array_like of float, shape (2 n,) or (2 n, k)

        Returns
        -------
        ndarray of float, same shape as ``v``

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> J = SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.0, np.ones(3), events=[], dense_max=0)
        >>> v = np.arange(6.0)                      # matrix-free (expm_multiply) against dense
        >>> bool(np.allclose(J.jv(v), J.matrix() @ v, rtol=0, atol=1e-12))
        True
        """
        v = np.asarray(v, dtype=float)
        if v.shape[0] != 2 * self.n or v.ndim > 2:
            raise ValueError(f"v must have shape ({2 * self.n},) or ({2 * self.n}, k), got {v.shape}")
        if self._dense is not None or (self._use_dense and 2 * self.n <= JV_DENSE_MAX):
            return self.matrix() @ v
        return self._propagate(v.reshape(2 * self.n, -1)).reshape(v.shape)

    def linear_operator(self):
        """The monodromy as a ``scipy.sparse.linalg.LinearOperator`` of shape (2 n, 2 n).

        Returns
        -------
        scipy.sparse.linalg.LinearOperator

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.0, np.ones(3), events=[]).linear_operator().shape
        (6, 6)
        """
        N = 2 * self.n
        return scipy.sparse.linalg.LinearOperator((N, N), matvec=self.jv, matmat=self.jv, dtype=float)

    def uniform_block(self):
        r"""The monodromy restricted to uniform perturbations ``(dw 1, dzeta 1)``: a 2x2 matrix.

        Column ``b`` is the node mean of ``J u_b`` over the ``w`` and the ``zeta`` rows, with
        :math:`u_0 = (1, 0)`, :math:`u_1 = (0, 1)` (blocks of ones) -- exactly the restriction
        when uniform states are invariant (``L 1 = 0`` and a uniform orbit), the 2x2
        Jacobian that :func:`~tps_solver.check_stability` reports for a flat layer.

        Returns
        -------
        ndarray of float, shape (2, 2)

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> J = SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.5, np.ones(3), events=[])
        >>> np.round(J.uniform_block(), 12).tolist()     # free flight: dzeta(1.5) = dzeta + 1.5 dw
        [[1.0, 0.0], [1.5, 1.0]]
        """
        n = self.n
        U = np.zeros((2 * n, 2))
        U[:n, 0] = 1.0
        U[n:, 1] = 1.0
        Y = self.jv(U)
        return np.vstack((Y[:n].mean(axis=0), Y[n:].mean(axis=0)))

    def uniform_multipliers(self):
        """Eigenvalues of :meth:`uniform_block` by decreasing modulus, shape (2,), complex.

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> J = SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.0, np.ones(3), events=[])
        >>> J.uniform_multipliers().tolist()           # free flight of a uniform state
        [(1+0j), (1+0j)]
        """
        mu = np.linalg.eigvals(self.uniform_block()).astype(complex)
        return mu[np.argsort(-np.abs(mu), kind="stable")]

    def multipliers(self, k=None, tol=1e-12):
        """Floquet multipliers by decreasing modulus.

        Parameters
        ----------
        k : int, optional
            Number of leading multipliers.  None: all (dense eigenvalues; needs
            ``2 n <= dense_max``, otherwise the 6 leading ones).  With the matrix-free
            product (``2 n > dense_max``) and ``k < 2 n - 1``: ARPACK
            (``scipy.sparse.linalg.eigs``, largest modulus) to relative tolerance ``tol``; if
            it does not converge, the converged ones only (fewer than ``k``) and
            ``arpack_converged`` is set False (True when converged, None for the dense route).
        tol : float
            ARPACK tolerance.

        Returns
        -------
        ndarray of complex, shape (k,) or (2 n,)

        Examples
        --------
        >>> import numpy as np
        >>> import tps_solver as tps
        >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
        >>> mu = SoftMonodromy(lat, 2.5, 0.45, 0.3, 0.0, 1.0, np.ones(3), events=[]).multipliers()
        >>> np.round(np.abs(mu), 6).tolist()        # free flight: exp(-lam), lam = 0, 2, 4 (twice 1)
        [1.0, 1.0, 1.0, 1.0, 0.135335, 0.018316]
        """
        N = 2 * self.n
        if k is None:
            k = N if self._use_dense else min(6, N)
        k = check_int(k, "k", minimum=1, maximum=N)
        tol = check_positive(tol, "tol")
        self.arpack_converged = None
        if self._use_dense or k >= N - 1:
            mu = np.linalg.eigvals(self.matrix()).astype(complex)
        else:
            try:
                mu = scipy.sparse.linalg.eigs(self.linear_operator(), k=k, which="LM", tol=tol,
                                              v0=np.ones(N), return_eigenvectors=False)
                self.arpack_converged = True
            except scipy.sparse.linalg.ArpackNoConvergence as exc:
                mu = exc.eigenvalues            # the converged ones only
                self.arpack_converged = False
            mu = np.asarray(mu).astype(complex)
        mu = mu[np.argsort(-np.abs(mu), kind="stable")]
        return mu[:k]


def _expm_taylor(L3, mode, beta, omega0, Y, dt, theta=2.0):
    r"""``expm(A_C dt) @ Y`` for one configuration by a truncated Taylor series on substeps.

    ``L3 = (diag, upper, lower)`` of the tridiagonal operator; ``Y`` of shape (2 n, k).  The
    heights of the contact nodes are scaled by :math:`\omega_0`, which balances their block
    (:math:`-\omega_0^2` becomes :math:`-\omega_0`, the identity :math:`\omega_0`) and lowers the
    1-norm from about :math:`\omega_0^2` to about :math:`4/\Delta x^2 + \omega_0`; the interval is cut into
    substeps with :math:`\|A' h\|_1 = \eta \le` ``theta``, and each series is truncated after the
    first ``m`` terms with :math:`e^{\eta}\,\eta^{m+1}/(m+1)! \le 2^{-53}` (an a-priori bound of the
    relative remainder, so short intervals cost few terms).  The product is banded, so each term
    costs O(n k) (no sparse-matrix construction per interval).
    """
    Ld, Lu, Ll = L3
    n = Ld.size
    c = (mode == _CONTACT).astype(float)
    r = (mode != _HELD).astype(float)
    dww = r * Ld - 2.0 * beta * c                 # diagonal of the w-w block
    up, lo = r[:-1] * Lu, r[1:] * Ll             # rows of held nodes are dropped
    sig = np.where(c > 0.0, omega0, 1.0)         # heights of contact nodes scaled by omega0
    wz = -omega0 * c                             # -omega0^2 c / sig
    zw = sig * r
    col_w = np.abs(dww) + zw
    col_w[1:] += np.abs(up)
    col_w[:-1] += np.abs(lo)
    nrm = max(float(col_w.max()), omega0 * float(c.max(initial=0.0))) * dt
    steps = max(1, int(math.ceil(nrm / theta)))
    h = dt / steps
    eta = nrm / steps
    m, bound = 1, eta * eta / 2.0
    while m < 60 and math.exp(eta) * bound > 2.0 ** -53:
        m += 1
        bound *= eta / (m + 1)
    W, Z = Y[:n].copy(), Y[n:] * sig[:, None]
    dww, up, lo, wz, zw = dww[:, None], up[:, None], lo[:, None], wz[:, None], zw[:, None]
    for _ in range(steps):
        tw, tz = W, Z
        for k in range(1, m + 1):
            f = h / k
            nw = dww * tw + wz * tz
            nw[:-1] += up * tw[1:]
            nw[1:] += lo * tw[:-1]
            tz = (zw * tw) * f
            tw = nw * f
            W = W + tw
            Z = Z + tz
    return np.vstack((W, Z / sig[:, None]))


def soft_monodromy(lattice, Gamma, e, cutoff, w0, zeta0, t_start, period, *, dense_max=400, **options):
    r"""Exact monodromy of the soft-contact lattice from the state ``(w0, zeta0)`` at ``t_start``.

    Time-steps one segment of length ``period`` with ``simulate(..., method="soft")`` for the
    switch sequence and returns the product of matrix exponentials and saltation matrices
    (module docstring).  The state need not be periodic: the result is the derivative of the
    map :math:`y(t_s) \mapsto y(t_s + \text{period})` at that state.

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
    e : float
        In (0, 1).
    cutoff : float
        :math:`\ell > 0`.
    w0, zeta0 : array_like of float, shape (n_nodes,)
    t_start : float
    period : float
        Segment length, > 0 (:math:`2\pi M` for the period map).
    dense_max : int
        See :class:`SoftMonodromy`.
    **options
        Options of the soft integrator (``rtol``, ``atol``, ``stick_speed``, ``time_tol``, ...).

    Returns
    -------
    SoftMonodromy

    Raises
    ------
    ValueError
        Bad input (as :func:`~tps_solver.simulate`).
    RuntimeError
        The time stepper failed (its message is included).

    Examples
    --------
    >>> import numpy as np
    >>> import tps_solver as tps
    >>> lat = tps.Lattice.planar(n_nodes=3, length=2.0)
    >>> J = soft_monodromy(lat, 2.5, 0.45, 0.3, np.zeros(3), np.full(3, 0.01), 0.0, 0.5)
    >>> J.matrix().shape, [kind for _, _, kind, _ in J.switches]
    ((6, 6), ['entry', 'entry', 'entry', 'exit', 'exit', 'exit'])
    """
    period = check_positive(period, "period")
    t_start = check_real(t_start, "t_start")
    run = simulate(lattice, Gamma, e, w0, zeta0, t_start=t_start, t_end=t_start + period, method="soft",
                   cutoff=cutoff, **options)
    if not run.success:
        raise RuntimeError(f"the soft time stepper failed: {run.message}")
    return SoftMonodromy.from_run(run, w0, zeta0, t_start, dense_max=dense_max)
