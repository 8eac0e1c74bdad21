"""A measured negative result: pattern discovery by a space-time complementarity Newton (e = 0).

The impact-and-stick TPS should *find* the kink's contact pattern from the far
field's flat orbit.  The formulation tried here is pattern-free: the whole period is one
discrete problem on the heights :math:`\\zeta_j^k` (node j, time level k = 0..N-1 of a
T-periodic grid, h = T/N), with the position-level (Paoli--Schatzman) impact law for e = 0:

.. math:: r_j^k = \\frac{\\zeta^{k+1} - 2\\zeta^k + \\zeta^{k-1}}{h} - h\\,\\underline L\\,
          \\frac{\\zeta^{k+1} - \\zeta^k}{h} - h\\,g(t_k), \\qquad
          0 \\le \\zeta_j^{k+1} \\perp r_j^k \\ge 0,

(implicit diffusion, :math:`g = \\sin t - 1/\\Gamma`), written as
:math:`\\min(\\zeta_j^{k+1}, c\\,r_j^k) = 0` and solved by a semismooth Newton with a sparse
generalised Jacobian (``scipy.sparse.linalg.splu``) and a backtracking line search on the
2-norm.  Contacts, sticks and triggered lift-offs are whatever the active set says.

What it measures (``python -m validation.spacetime_discovery``):

* :func:`flat_discrete` -- one node: the discrete flat orbit, from the sampled exact orbit
  (converges in a few steps; its distance to the exact orbit is the O(h) error of the scheme);
* :func:`step_start` -- the kink from the step start (flat orbit for x < 0, half a period
  later for x >= 0): the residual at which the semismooth Newton stagnates;
* :func:`anti_continuum` -- the same start continued in the coupling, :math:`\\lambda\\underline L`
  with :math:`\\lambda` from 0 (where the step start is exact) to 1: the largest
  :math:`\\lambda` reached.

On the 21-node lattice (dx = 2, L = 40, Gamma = 4.1, N = 512) Newton stagnates from the
step start and the coupling continuation stops near lambda = 0.004, at a lift-off whose
time level changes with lambda (the iterate oscillates in sign there).  So the method is
not in the package; the study keeps the measurement reproducible.
"""
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import tps_solver as tps
from tps_solver.solvers.tps.stick_problem import flat_stick_orbit


def discrete_problem(L, N, h, t0, Gamma, c=1.0):
    """Residual and generalised Jacobian of the periodic space-time complementarity system.

    Returns
    -------
    residual : callable
        ``residual(z) -> (F, active)``, ``z`` of shape (N * n,) (level-major), ``active`` True
        where the height branch of the min is taken.
    jacobian : callable
        ``jacobian(active) -> scipy.sparse.csc_matrix``.
    """
    L = np.asarray(L, float)
    n = L.shape[0]
    identity = sp.identity(n, format="csr")
    Ls = sp.csr_matrix(L)
    k = np.arange(N)
    up = sp.csr_matrix((np.ones(N), (k, (k + 1) % N)), (N, N))
    down = up.T.tocsr()
    Jr = c * (sp.kron(up, identity / h - Ls) + sp.kron(sp.identity(N), -2.0 * identity / h + Ls)
              + sp.kron(down, identity / h)).tocsr()
    Jq = sp.kron(up, identity).tocsr()
    g = np.sin(t0 + h * k) - 1.0 / Gamma

    def residual(z):
        Z = z.reshape(N, n)
        Zp, Zm = np.roll(Z, -1, 0), np.roll(Z, 1, 0)
        r = (Zp - 2.0 * Z + Zm) / h - (Zp - Z) @ L.T - h * g[:, None]
        active = Zp <= c * r
        return np.where(active, Zp, c * r).ravel(), active.ravel()

    def jacobian(active):
        a = active.astype(float)
        return (sp.diags(a) @ Jq + sp.diags(1.0 - a) @ Jr).tocsc()

    return residual, jacobian


def semismooth_newton(residual, jacobian, z, tol=1e-11, max_iter=60):
    """Semismooth Newton with backtracking on |F|_2; returns (z, converged, steps, max|F|)."""
    F, active = residual(z)
    for it in range(max_iter):
        norm = float(np.linalg.norm(F))
        if np.max(np.abs(F)) <= tol:
            return z, True, it, float(np.max(np.abs(F)))
        dz = -splu(jacobian(active)).solve(F)
        lam = 1.0
        while lam >= 1.0 / 1024:
            Ft, at = residual(z + lam * dz)
            if np.linalg.norm(Ft) < (1.0 - 1e-4 * lam) * norm:
                break
            lam *= 0.5
        else:
            return z, False, it, float(np.max(np.abs(F)))
        z, F, active = z + lam * dz, Ft, at
    return z, bool(np.max(np.abs(F)) <= tol), max_iter, float(np.max(np.abs(F)))


def _grid(Gamma, N):
    orb = flat_stick_orbit(Gamma, 2)
    T = orb.period
    h = T / N
    t0 = orb.t_liftoff + 0.5
    return orb, T, h, t0


def flat_discrete(Gamma=4.1, N=512):
    """The discrete flat orbit on one node: Newton steps and max distance to the exact orbit."""
    orb, T, h, t0 = _grid(Gamma, N)
    exact = orb.orbit.height(t0 + h * np.arange(N))
    res, jac = discrete_problem(np.zeros((1, 1)), N, h, t0, Gamma)
    z, ok, nit, err = semismooth_newton(res, jac, np.maximum(exact, 0.0))
    return dict(Gamma=Gamma, N=N, h=h, converged=ok, nit=nit, residual=err,
                distance_to_exact=float(np.max(np.abs(z - exact))), z=z)


def _step_start(lattice, Gamma, N):
    flat = flat_discrete(Gamma, N)
    if not flat["converged"]:
        raise RuntimeError("the discrete flat orbit did not converge")
    z1 = flat["z"]
    left = lattice.nodes < 0
    return np.where(left[None, :], z1[:, None], np.roll(z1, -N // 2)[:, None]).ravel()


def step_start(n_nodes=21, Gamma=4.1, N=512, c=1.0):
    """The kink from the step start: converged?, steps, final max|F| and seconds."""
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=40.0)
    _, T, h, t0 = _grid(Gamma, N)
    z = _step_start(lat, Gamma, N)
    res, jac = discrete_problem(lat.operator, N, h, t0, Gamma, c=c)
    start = time.perf_counter()
    _, ok, nit, err = semismooth_newton(res, jac, z)
    return dict(n_nodes=n_nodes, dx=float(lat.spacing), N=N, c=c, converged=ok, nit=nit,
                residual_start=float(np.max(np.abs(res(z)[0]))), residual=err,
                seconds=time.perf_counter() - start)


def anti_continuum(n_nodes=21, Gamma=4.1, N=512, first=0.05, smallest=1e-4):
    """Continue the step start in the coupling lambda (L -> lambda L, 0 -> 1): largest lambda reached."""
    lat = tps.Lattice.planar(n_nodes=n_nodes, length=40.0)
    _, T, h, t0 = _grid(Gamma, N)
    z = _step_start(lat, Gamma, N)
    lam, dlam, steps, failures = 0.0, first, 0, 0
    start = time.perf_counter()
    while lam < 1.0 and dlam >= smallest:
        trial = min(1.0, lam + dlam)
        res, jac = discrete_problem(trial * lat.operator, N, h, t0, Gamma)
        zt, ok, nit, _ = semismooth_newton(res, jac, z.copy(), max_iter=30)
        steps += nit
        if ok:
            lam, z, dlam = trial, zt, min(1.5 * dlam, 0.5)
        else:
            failures += 1
            dlam *= 0.5
    return dict(n_nodes=n_nodes, dx=float(lat.spacing), N=N, lambda_reached=lam, newton_steps=steps,
                failed_steps=failures, seconds=time.perf_counter() - start)


def main():
    flat = flat_discrete()
    print(f"flat, one node, N = {flat['N']}: converged {flat['converged']} in {flat['nit']} steps, "
          f"max|zeta - exact| = {flat['distance_to_exact']:.3g} (h = {flat['h']:.4g})")
    for c in (0.1, 1.0, 10.0):
        s = step_start(c=c)
        print(f"kink from the step start, dx = {s['dx']:g}, c = {c:g}: converged {s['converged']} after "
              f"{s['nit']} steps, max|F| {s['residual_start']:.2e} -> {s['residual']:.2e} ({s['seconds']:.2f} s)")
    a = anti_continuum()
    print(f"coupling continuation, dx = {a['dx']:g}: lambda reached {a['lambda_reached']:.4f} "
          f"({a['newton_steps']} Newton steps, {a['failed_steps']} failed trials, {a['seconds']:.1f} s)")


if __name__ == "__main__":
    main()
