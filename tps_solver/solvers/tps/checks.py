"""Physical checks of the single-contact assumption on a TPS solution."""
import math

import numpy as np

from tps_solver.core.bunch import Bunch
from tps_solver.operators.contact import contact_times

__all__ = ["physical_checks"]


#: Bytes of the (times x harmonics) phase block of one evaluation of the series.
BLOCK_BYTES = 32e6


def _height_blocks(sol, t):
    """``sol.height(t)`` evaluated in blocks of times, so the phase matrix stays <= BLOCK_BYTES."""
    per_time = 16.0 * (2 * sol.N + 1)
    step = max(1, int(BLOCK_BYTES // per_time))
    if t.size <= step:
        return np.asarray(sol.height(t), dtype=float)
    return np.concatenate([np.asarray(sol.height(t[i:i + step]), dtype=float)
                           for i in range(0, t.size, step)], axis=0)


def physical_checks(sol, n_times=None):
    """Checks of the single-contact assumption on the TPS output (docs/design.md, hazard 3).

    ``all_pass`` also requires ``sol.converged``: the fields of a run that did not converge
    are not a solution, whatever they look like (``converged`` is repeated in the result).
    The series is evaluated at ``max(64 N, 2048)`` times in blocks of bounded memory.

    Parameters
    ----------
    sol : PeriodicSolution
        A TPS result (``period``, ``N``, ``M``, ``w_hat``, ``tc``, ``t0``, ``Gamma``, ``height``).
    n_times : int, optional
        Sample times per period.

    Returns
    -------
    Bunch
        ``min_zeta``, ``zeta_nonnegative``, ``contacts_per_period`` (int, shape (n_nodes,)),
        ``single_contact``, ``tc_is_steep_crossing`` (bool, shape (n_nodes,)), ``selected_tc``,
        ``jump_ratio`` (measured jump / (T/Gamma), shape (n_nodes,)), ``restitution_residual``,
        ``converged`` and ``all_pass``.

    Examples
    --------
    The default kink: one contact per node and period, a jump of T/Gamma at each:

    >>> from tps_solver import solve_kink
    >>> chk = physical_checks(solve_kink(n_harmonics=8))
    >>> chk.all_pass, chk.contacts_per_period.tolist() == [1] * 16, chk.restitution_residual < 1e-5
    (True, True, True)

    The step guess, not iterated (``max_iter=0``), looks single-contact but is no solution:

    >>> guess = solve_kink(n_harmonics=8, max_iter=0, continuation=False)
    >>> chk = physical_checks(guess)
    >>> chk.single_contact, chk.converged, chk.all_pass
    (True, False, False)
    """
    T, N, M = sol.period, sol.N, sol.M
    n_times = n_times or max(64 * N, 2048)
    t = np.linspace(0.0, T, n_times, endpoint=False)
    zeta = _height_blocks(sol, t)                            # (n_times, n_nodes)
    scale = max(1.0, float(np.max(np.abs(zeta))))
    min_zeta = float(np.min(zeta))
    # contacts: local minima of zeta (periodic) that come within tol of the plate
    tol_contact = 1e-2 * scale
    zp, zm = np.roll(zeta, -1, axis=0), np.roll(zeta, 1, axis=0)
    is_min = (zeta <= zp) & (zeta < zm) & (zeta < tol_contact)
    contacts = np.sum(is_min, axis=0)
    # tc is the steep up-crossing selected by the independent rule?
    sel = contact_times(sol.w_hat, M, -math.cos(sol.t0))
    dt = np.abs(np.mod(sel.tc - sol.tc + T / 2, T) - T / 2)
    steep = sel.ok & (dt < 1e-6 * T)
    # measured jump from the top harmonics: 2 pi i n w_n e^{i n alpha tc} -> T/Gamma for a clean jump
    n = np.arange(1, N + 1)
    top = n >= max(1, N // 2)
    w_pos = sol.w_hat[N + 1:]
    est = np.real(2j * np.pi * n[:, None] * w_pos * np.exp(1j * np.outer(n / M, sol.tc)))
    jump_ratio = np.mean(est[top], axis=0) / (T / sol.Gamma)
    restitution_residual = float(np.max(np.abs(jump_ratio - 1.0)))
    zeta_ok = min_zeta >= -1e-6 * scale
    single = bool(np.all(contacts <= 1))
    converged = bool(getattr(sol, "converged", True))
    return Bunch(
        min_zeta=min_zeta, zeta_nonnegative=bool(zeta_ok), contacts_per_period=contacts,
        single_contact=single, tc_is_steep_crossing=steep, selected_tc=sel.tc,
        jump_ratio=jump_ratio, restitution_residual=restitution_residual, converged=converged,
        all_pass=bool(converged and zeta_ok and single and np.all(steep) and restitution_residual < 0.1))
