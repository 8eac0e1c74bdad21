"""The TPS result, :class:`PeriodicSolution`, and its file codec (:mod:`tps_solver.core.archive`)."""
import numpy as np

from tps_solver.core import archive as io
from tps_solver.core.orbit import STATUS, PeriodicOrbit
from tps_solver.model.flat import FlatLayer
from tps_solver.model.harmonics import evaluate, height_from_velocity, mode_numbers, sawtooth, sawtooth_hat
from tps_solver.operators.lattice import Lattice

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

    The kinds registered when it is called are read (this one, and those of the modules
    imported so far); :func:`tps_solver.load` reads every kind.  A damaged, foreign or
    inconsistent file raises ``ValueError`` saying what is wrong with it.

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


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _check_fields(f, fl, M, T, tail, version):
    """Shapes, finiteness and the height harmonics (39)-(40) of a stored solution."""
    N = f.int("N", minimum=1)
    geometry = f.str("geometry", ("planar", "axisymmetric"))
    nodes = f.array("nodes", "f", ndim=1, finite=True)
    n = nodes.size
    if n < 1 or np.any(np.diff(nodes) <= 0):
        f.fail("the field 'nodes' must be a non-empty, strictly increasing array")
    tc = f.array("tc", "f", shape=(n,), finite=True)
    if np.any(tc < 0) or np.any(tc >= T):
        f.fail(f"the field 'tc' must lie in [0, T) with T = 2 pi M = {T:.6g}")
    w_hat = f.array("w_hat", "fc", shape=(2 * N + 1, n), finite=True).astype(complex)
    zeta_hat = f.array("zeta_hat", "fc", shape=(2 * N + 1, n), finite=True).astype(complex)
    f.array("zeta_shift", "f", shape=(n,), finite=True)
    expect = height_from_velocity(w_hat, M)
    k = mode_numbers(N)
    nz = k != 0
    expect[N] = -np.real(np.sum(expect[nz] * np.exp(1j * np.outer(k[nz] / M, tc)), axis=0))
    if tail:
        J = T / fl.Gamma
        expect[N] -= J * float(sawtooth(0.0, M, "height") - evaluate(sawtooth_hat(N, M, [0.0], "height"),
                                                                       [0.0], M)[0, 0])
    scale = max(1.0, float(np.max(np.abs(expect))))
    gap = float(np.max(np.abs(zeta_hat - expect)))
    if not gap <= 1e-9 * scale:
        f.fail(f"inconsistent: zeta_hat does not follow from w_hat and tc by (39)-(40) "
               f"(max difference {gap:.3g})")
    f.status(STATUS)
    f.int("nit", minimum=0)
    f.array("residual_history", "f", ndim=1)
    coupling = f.float("coupling") if f.has("coupling") or version > 0 else 1.0
    if not 0.0 < coupling <= 1.0:
        f.fail(f"the field 'coupling' must be in (0, 1], got {coupling}")
    return geometry, nodes, N


def _validate(f):
    fl = f.instance("flat", FlatLayer)
    Gamma, M, e, t0, T = f.float("Gamma"), f.int("M", minimum=1), f.float("e"), f.float("t0"), f.float("period")
    if e != fl.e:
        f.fail(f"inconsistent: the stored e = {e!r} but the flat layer launched at the stored "
               f"t0 = {fl.t0!r} (Gamma = {fl.Gamma}, M = {fl.M}) has e = {fl.e:.15g} by (19)")
    if (Gamma, M, t0, T) != (fl.Gamma, fl.M, fl.t0, fl.period):
        f.fail(f"inconsistent: (Gamma, M, t0, period) = {(Gamma, M, t0, T)} are not those of the flat layer "
               f"{fl!r}")
    geometry, nodes, _ = _check_fields(f, fl, M, T, f.bool("tail_correction"), f.version)
    lattice = f.instance("lattice", Lattice, optional=True)
    if lattice is not None and (lattice.geometry != geometry or lattice.n_nodes != nodes.size
                                or not np.array_equal(lattice.nodes, nodes)):
        f.fail("inconsistent: the stored lattice does not have the solution's nodes and geometry")


def _legacy(f):
    """A file of format version 0 (unversioned) or 1: the flat layer from (Gamma, M, t0), checks recomputed."""
    Gamma, M, t0, e = f.float("Gamma"), f.int("M", minimum=1), f.float("t0"), f.float("e")
    try:
        fl = FlatLayer(Gamma, M, t0=t0)
    except ValueError as exc:
        f.fail(f"the stored flat layer (Gamma = {Gamma}, M = {M}, t0 = {t0}) is invalid: {exc}")
    if not abs(fl.e - e) <= 1e-9:
        f.fail(f"inconsistent: the stored e = {e!r} but the flat layer launched at the stored "
               f"t0 = {t0!r} (Gamma = {Gamma}, M = {M}) has e = {fl.e:.15g} by (19)")
    tail = f.bool("tail_correction") if f.has("tail_correction") else True
    geometry, nodes, N = _check_fields(f, fl, M, fl.period, tail, f.version)
    lattice = None
    if f.has("lattice.present") and f.bool("lattice.present"):
        lattice = Lattice(f.array("lattice.nodes", "f", ndim=1, finite=True), f.str("lattice.geometry"),
                          f.str("lattice.boundary"), grid=f.str("lattice.grid"))
    elif f.version == 0 and f.has("lattice") and f.get("lattice").size:
        geometry_l, boundary, grid = (str(v) for v in f.get("lattice"))
        lattice = Lattice(nodes, geometry_l, boundary, grid=grid)
    status = f.int("status")
    n = nodes.size
    sol = PeriodicSolution(
        converged=status == 0, success=status == 0, status=status, message=f.str("message"), nit=f.int("nit"),
        residual=f.float("residual", finite=False), residual_history=np.array(f.get("residual_history")),
        geometry=geometry, nodes=np.array(nodes), tc=np.array(f.get("tc")),
        w_hat=np.array(f.get("w_hat"), dtype=complex), zeta_hat=np.array(f.get("zeta_hat"), dtype=complex),
        zeta_shift=np.array(f.get("zeta_shift")), Gamma=fl.Gamma, e=e, t0=fl.t0, M=M, N=N, period=fl.period,
        flat=fl, min_shift=f.bool("min_shift"), scheme=f.str("scheme"), tail_correction=tail,
        coupling=f.float("coupling") if f.has("coupling") else 1.0,
        continuation_path=np.array(f.get("continuation_path")).reshape(-1, 3) if f.has("continuation_path")
        else np.empty((0, 3)),
        time=f.float("time", finite=False) if f.has("time") else float("nan"),
        spacing=float(np.min(np.diff(nodes))) if n > 1 else float("inf"), lattice=lattice)
    from tps_solver.solvers.tps.checks import physical_checks

    sol.formulation = ("single-contact TPS (continuum, Green-function quadrature)" if lattice is None
                       else "single-contact TPS (FDA lattice)")
    sol.checks = physical_checks(sol)
    return sol


io.register("PeriodicSolution", PeriodicSolution, validate=_validate, legacy=_legacy)
