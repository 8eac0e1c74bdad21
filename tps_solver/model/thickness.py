r"""The long-wave model of a layer whose thickness changes: its linear rates about the flat layer.

``docs/thickness.md`` derives, from the paper's equations (1)-(7) in the long-wave limit, the
reduced model with a thickness field :math:`h(t, x)` and a lateral velocity :math:`u(t, x)`:

.. math::
    \partial_t h + \partial_x(hu) = 0, \qquad
    h\,\partial_t u = \partial_x(4\nu h\,\partial_x u), \\
    h\,\partial_t w = \partial_x(\nu h\,\partial_x w) + h\,g(t), \qquad
    \partial_t\zeta = w,

with the impact's lateral push :math:`\Delta u = -\chi h^{-1}\partial_x(\Delta w\,h^2/2)`.  About
the flat layer its perturbations decay at the two rates of :func:`long_wave_rates`; the varicose
roots of (35) tend to them as :math:`kh \to 0` (``tests/test_thickness.py``).  The model is
integrated by :func:`tps_solver.solvers.thickness.simulate_thickness`.
"""
import numpy as np

from tps_solver.core.checks import check_positive

__all__ = ["long_wave_rates"]


def long_wave_rates(k, nu=1.0):
    r"""Decay rates of the reduced model's perturbations :math:`\propto e^{ikx + \sigma t}` about the flat layer.

    Parameters
    ----------
    k : float or array_like of float
        Wavenumber(s), >= 0.
    nu : float, optional
        Kinematic viscosity (1 in the package's units).

    Returns
    -------
    rates : dict of ndarray of float, shape of ``k``
        ``"stretching"``: :math:`-4\nu k^2` (the thin-sheet extensional mode, u and h);
        ``"antiplane"``: :math:`-\nu k^2` (w and zeta, the paper's antiplane damping).

    Examples
    --------
    >>> r = long_wave_rates(0.5)
    >>> float(r["stretching"]), float(r["antiplane"])
    (-1.0, -0.25)
    """
    nu = check_positive(nu, "nu")
    k = np.asarray(k, dtype=float)
    if not np.all(np.isfinite(k)) or np.any(k < 0.0):
        raise ValueError(f"k must be finite and >= 0, got {k!r}")
    return {"stretching": -4.0 * nu * k * k, "antiplane": -nu * k * k}
