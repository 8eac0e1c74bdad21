"""The TPS result, :class:`PeriodicSolution`, and its file format (:func:`load`)."""
import math

import numpy as np

from ..flat import FlatLayer
from ..harmonics import evaluate, sawtooth, sawtooth_hat
from ..lattice import Lattice
from ..orbit import PeriodicOrbit
from .checks import physical_checks

__all__ = ["PeriodicSolution", "load"]


class PeriodicSolution(PeriodicOrbit):
    r"""A time-periodic kink or oscillon from the TPS.

    Attributes
    ----------
    converged, success : bool
        Whether the iteration met ``tol``.
    status : int
        A code of :data:`tps_solver.orbit.STATUS` (0 converged, 1 iteration limit,
        2 stagnation, 3 contact-time failure, 4 the branch ended at a fold, 5 interrupted).
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
        Physical checks (docs/design.md, hazard 3): ``min_zeta`` (over a fine time grid),
        ``zeta_nonnegative``, ``contacts_per_period`` (per node), ``single_contact``,
        ``tc_is_steep_crossing`` (per node), ``jump_ratio`` (measured jump of w at
        tc over the restitution jump T/Gamma, from the top harmonics, per node),
        ``restitution_residual`` (max |jump_ratio - 1|), ``all_pass``.
    min_shift : bool
        True if the paper's min-shift (64)-(65) was applied to zeta.  A solution
        that needs it is not a solution of the contact problem.
    """

    def _evaluate(self, coeffs, t, kind):
        t = self.as_times(t)
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
            t = self.as_times(t)
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
        geometry, boundary, grid = (str(v) for v in data["lattice"])
        sol.lattice = Lattice(sol.nodes, geometry, boundary, grid=grid)
    sol.checks = physical_checks(sol)
    return sol
