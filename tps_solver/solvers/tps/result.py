"""The TPS result, :class:`PeriodicSolution`; its file format is :mod:`tps_solver.core.archive`'s (:func:`load`)."""
import numpy as np

from tps_solver.core import archive as io
from tps_solver.model.harmonics import evaluate, sawtooth, sawtooth_hat
from tps_solver.core.orbit import PeriodicOrbit

__all__ = ["PeriodicSolution", "load"]


class PeriodicSolution(PeriodicOrbit):
    r"""A time-periodic kink or oscillon from the TPS.

    Attributes
    ----------
    converged, success : bool
        Whether the iteration met ``tol``.
    status : int
        A code of :data:`tps_solver.core.orbit.STATUS` (0 converged, 1 iteration limit,
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

    Examples
    --------
    A coarse kink: far from the front the layer bounces like the flat layer, launched
    at ``t0`` on one side and half a period later on the other:

    >>> from tps_solver import solve_kink
    >>> sol = solve_kink(n_harmonics=6, n_nodes=6)
    >>> sol.converged, sol.geometry, sol.w_hat.shape, sol.checks.all_pass
    (True, 'planar', (13, 12), True)
    >>> bool(np.allclose(sol.tc[[-1, 0]], [sol.flat.t0, sol.flat.t0 + sol.period / 2], atol=1e-6))
    True
    >>> t = np.linspace(0.0, sol.period, 5)
    >>> bool(np.allclose(sol.velocity(t)[:, -1], sol.flat.velocity(t), atol=1e-5))
    True
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
        :mod:`tps_solver.model.harmonics`), so the series carries no Gibbs error
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
        """Write the solution to ``path`` (``.npz`` appended if missing); returns the path written.

        The format is :mod:`tps_solver.core.archive`'s (versioned, validated on :func:`load`).
        """
        return io.save(self, path)


def load(path, kind=None):
    """Read a result file written by ``save`` (with or without its ``.npz`` ending).

    See :func:`tps_solver.core.archive.load`: any result type is read (``kind`` restricts it);
    what is derived -- the flat layer, the height harmonics (39)-(40), the physical
    checks -- is recomputed, and a damaged, foreign or inconsistent file raises
    ``ValueError`` saying what is wrong with it.

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver import solve_kink
    >>> sol = solve_kink(n_harmonics=6, n_nodes=6)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     path = sol.save(os.path.join(d, "kink"))
    ...     back = load(os.path.join(d, "kink"))
    ...     print(os.path.basename(path), type(back).__name__, np.array_equal(back.tc, sol.tc),
    ...           np.array_equal(back.zeta_hat, sol.zeta_hat), back.checks.all_pass)
    kink.npz PeriodicSolution True True True
    """
    return io.load(path, kind)
