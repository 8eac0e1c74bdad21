r"""The flat layer of the soft-contact model: :class:`SoftFlatOrbit`.

The soft contact
----------------
The limiting dynamical process of Appendix A (A.1, (76)-(88)) made finite: the
Stosslet is replaced by a contact force acting while :math:`\zeta < 0`,

.. math::
    \partial_t w = \nu\underline L w + g(t)
        + H(-\zeta)\,\big[-g(t) - \omega_0^2\zeta - 2\beta w\big],
    \qquad \partial_t\zeta = w,

a linear spring-dashpot that also carries the layer's weight while in contact.
For a uniform state (:math:`\underline L w = 0`) a contact is the damped
oscillator :math:`\ddot\zeta + 2\beta\dot\zeta + \omega_0^2\zeta = 0`, which
leaves the plate after exactly :math:`\tau_c = \pi/\omega_d` with
:math:`w^+ = -e\,w^-` for every impact speed, if
:math:`\omega_d = \pi/\tau_c`, :math:`\beta = -\ln e/\tau_c`,
:math:`\omega_0^2 = \omega_d^2 + \beta^2`.  The cut-off length is the viscous
diffusion length of one contact, ``cutoff`` :math:`= \ell = \sqrt{\nu\tau_c}`.
The right-hand side is Lipschitz in the state and switches only where a node
crosses :math:`\zeta = 0` transversally, so -- unlike (54) -- the period map
is differentiable at a flat layer and the lattice is a consistent
method-of-lines discretisation of a well-posed semilinear parabolic system;
refinement at fixed ``cutoff`` converges (measured, second order; the
flat-layer growth factor tends to its continuum supremum, 1 approached from
below at scales shorter than ``cutoff``, see ``validation/sections/cutoff.md``).
:class:`SoftFlatOrbit` gives the flat orbit and its per-mode linearisation in
closed form.  The price:
each bounce lasts :math:`\tau_c = \ell^2/\nu`, so the flat orbit is the
bouncing ball with a contact delay (it tends to (17)-(19) as
:math:`\ell \to 0`).
"""
import math

import numpy as np
from scipy.optimize import brentq

from tps_solver.core import archive
from tps_solver.core.checks import check_in_range, check_positive, check_real
from tps_solver.model.flat import FlatLayer
from tps_solver.model.flight import expm_companion, flight_map

__all__ = ["soft_contact_parameters", "SoftFlatOrbit"]


def soft_contact_parameters(e, cutoff, nu=1.0):
    r"""Spring-dashpot constants of the soft contact with restitution ``e`` and length ``cutoff``.

    Parameters
    ----------
    e : float
        Restitution in (0, 1).
    cutoff : float
        :math:`\ell > 0`; the contact lasts :math:`\tau_c = \ell^2/\nu`.
    nu : float
        Viscosity (1 in the package's units).

    Returns
    -------
    tau_c, omega0_sq, beta : float
        Contact duration, spring constant :math:`\omega_0^2` and damping rate :math:`\beta`.

    Examples
    --------
    >>> tau, w2, b = soft_contact_parameters(0.45, 0.2)
    >>> round(tau, 12), round(math.exp(-b * tau), 12)
    (0.04, 0.45)
    """
    e = check_in_range(e, "e", 0.0, 1.0, low_closed=False, high_closed=False)
    cutoff = check_positive(cutoff, "cutoff")
    nu = check_positive(nu, "nu")
    tau_c = cutoff * cutoff / nu
    omega_d = math.pi / tau_c
    beta = -math.log(e) / tau_c
    return tau_c, omega_d * omega_d + beta * beta, beta



class SoftFlatOrbit:
    r"""The flat layer (bouncing ball) of the soft-contact model and its linearisation per mode.

    A uniform state in contact obeys the damped oscillator of the module
    docstring, so every contact lasts exactly :math:`\tau_c` and maps entry
    speed :math:`V` to exit velocity :math:`eV`.  The periodic orbit is the
    bouncing ball (17)-(19) with a flight time :math:`F = T - \tau_c`: with exit
    phase :math:`t_1`,

    .. math::
        (1+e)V = F/\Gamma - \cos t_1 + \cos(t_1+F), \qquad
        eV = F/(2\Gamma) - \cos t_1 + [\sin(t_1+F) - \sin t_1]/F .

    The branch continued from the hard flat layer ``FlatLayer(Gamma, M, e,
    branch)`` (``t_1 -> t_0`` as ``cutoff -> 0``) is taken.

    Because the base state is uniform, the linearised period map of the soft
    lattice decouples over the eigenvectors of :math:`-\underline L` (eigenvalue
    :math:`\lambda`, :math:`k^2` in the continuum): per mode it is the 2x2
    monodromy :meth:`monodromy` (flight, entry saltation, contact, exit
    saltation), with a transversal crossing at entry and exit.

    Parameters
    ----------
    Gamma : float
    M : int
    e : float
        Restitution in (0, 1).
    cutoff : float
        :math:`\ell = \sqrt{\nu\tau_c} > 0`, with :math:`\tau_c < T`.
    branch : {"stable", "unstable"}

    Attributes
    ----------
    t_exit : float
        Exit (launch) phase :math:`t_1`.
    V : float
        Entry speed; the exit velocity is :math:`eV`.
    tau_c, flight, period : float

    Examples
    --------
    >>> from tps_solver import FlatLayer
    >>> orb = SoftFlatOrbit(2.5, 2, 0.45, 1e-4)
    >>> bool(abs(orb.t_exit - FlatLayer(2.5, 2, e=0.45).t0) < 1e-6)
    True
    """

    def __init__(self, Gamma, M, e, cutoff, branch="stable"):
        hard = FlatLayer(Gamma, M, e=e, branch=branch, pattern="bounce")
        self.Gamma, self.M, self.e = hard.Gamma, hard.M, hard.e
        self.tau_c, self.omega0_sq, self.beta = soft_contact_parameters(self.e, cutoff)
        self.cutoff = float(cutoff)
        self.branch = branch
        T = hard.period
        if self.tau_c >= T:
            raise ValueError(f"cutoff must give a contact time cutoff**2 < T = {T:.6g}, got {cutoff!r}")
        self.period = T
        F = self.flight = T - self.tau_c
        G, ee = self.Gamma, self.e

        def resid(t1):
            vw = (F / G - math.cos(t1) + math.cos(t1 + F)) / (1.0 + ee)
            vz = (F / (2.0 * G) - math.cos(t1) + (math.sin(t1 + F) - math.sin(t1)) / F) / ee
            return vw - vz

        # the root of resid nearest the hard launch phase (the continued branch), bracketed on a scan
        ts = hard.t0 + np.linspace(-0.5 * math.pi, 0.5 * math.pi, 2001)
        r = np.array([resid(t) for t in ts])
        idx = np.flatnonzero(np.sign(r[:-1]) * np.sign(r[1:]) <= 0.0)
        if idx.size == 0:
            raise ValueError(f"no soft flat orbit continued from the {branch} branch for cutoff = {cutoff!r}")
        i = idx[np.argmin(np.abs(ts[idx] - hard.t0))]
        t1 = brentq(resid, ts[i], ts[i + 1], xtol=1e-15, rtol=4 * np.finfo(float).eps)
        self.t_exit = float(t1)
        self.V = float((F / G - math.cos(t1) + math.cos(t1 + F)) / (1.0 + ee))
        if not self.V > 0.0:
            raise ValueError(f"no soft flat orbit continued from the {branch} branch for cutoff = {cutoff!r}")

    def state(self, t):
        """Uniform state ``(w, zeta)`` at a flight time ``t`` (exit at ``t_exit``, entry ``flight`` later).

        Parameters
        ----------
        t : float
            Must satisfy ``0 <= (t - t_exit) mod T <= flight``.

        Returns
        -------
        w, zeta : float
        """
        tau = (t - self.t_exit) % self.period
        if tau > self.flight:
            raise ValueError(f"t must be a flight time of the soft flat orbit, got t = {t!r} (in contact)")
        t1 = t - tau
        G, v = self.Gamma, self.e * self.V
        w = v + math.cos(t1) - math.cos(t) - tau / G
        z = (v + math.cos(t1)) * tau + math.sin(t1) - math.sin(t) - tau * tau / (2.0 * G)
        return w, z

    def monodromy(self, lam, t_section=None):
        r"""Linearised period map of the mode with :math:`-\underline L`-eigenvalue ``lam``.

        Parameters
        ----------
        lam : float or array_like of float, shape (k,)
            Eigenvalues :math:`\lambda \ge 0` (:math:`k^2` for a Fourier mode).
        t_section : float, optional
            Flight time at which the map starts and ends; default the exit time
            ``t_exit``.

        Returns
        -------
        M : ndarray of float, shape (k, 2, 2)
            Acting on :math:`(\delta w, \delta\zeta)`: flight to the entry, entry
            saltation, contact, exit saltation, flight to the section.
        """
        lam = np.atleast_1d(np.asarray(lam, dtype=float))
        G, e, V = self.Gamma, self.e, self.V
        F, tc, om2, b = self.flight, self.tau_c, self.omega0_sq, self.beta
        a = 0.0 if t_section is None else (check_real(t_section, "t_section") - self.t_exit) % self.period
        if a > F:
            raise ValueError(f"t_section must be a flight time of the soft flat orbit, got {t_section!r}")
        t_in = self.t_exit + F
        t_out = t_in + tc
        g_in = math.sin(t_in) - 1.0 / G
        g_out = math.sin(t_out) - 1.0 / G
        S_in = np.array([[1.0, (g_in - 2.0 * b * V) / V], [0.0, 1.0]])
        S_out = np.array([[1.0, (2.0 * b * e * V + g_out) / (e * V)], [0.0, 1.0]])
        return (flight_map(lam, a) @ S_out @ expm_companion(-lam - 2.0 * b, -om2, tc) @ S_in
                @ flight_map(lam, F - a))

    def growth(self, lam):
        """Spectral radius of :meth:`monodromy` per mode: the growth factor per period.

        Parameters
        ----------
        lam : float or array_like of float, shape (k,)

        Returns
        -------
        rho : ndarray of float, shape (k,)
        """
        return np.max(np.abs(np.linalg.eigvals(self.monodromy(lam))), axis=-1)


# ------------------------------------------------------------------ file codec (tps_solver.core.archive)
def _encode_soft(orbit):
    return {"Gamma": orbit.Gamma, "M": orbit.M, "e": orbit.e, "cutoff": orbit.cutoff, "branch": orbit.branch}


def _decode_soft(data):
    return SoftFlatOrbit(data["Gamma"], data["M"], data["e"], data["cutoff"], data["branch"])


archive.register("SoftFlatOrbit", SoftFlatOrbit, encode=_encode_soft, decode=_decode_soft)
