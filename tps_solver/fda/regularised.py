r"""Impact models with an explicit physical cut-off length (DESIGN hazards 7-8, issue 6).

With point impacts (54) on a lattice the only length that limits the
impact-order effect of hazard 7 is the lattice spacing: the column that
rebounds first drags its neighbours through a velocity step of the size of the
impact jump across one spacing, a kick :math:`\propto \nu/\Delta x^2`, and the
flat layer's response to small perturbations grows without bound under
refinement (measured in ``validation/cutoff.py``).  The paper names a cut-off
length as necessary (remark after (11)) and regularises with the diffused
Stosslet (67).  This module makes the cut-off an explicit model parameter
``cutoff`` (a length in viscous units, :math:`\nu = 1`) and offers the
candidates evaluated in ``validation/sections/cutoff.md``:

Instantaneous rules (usable as ``simulate(..., impact=rule)``)
---------------------------------------------------------------
``"kernel"``
    Normalised impulse kernel.  A contact set :math:`\mathscr P` gives every free
    node the kick :math:`\Delta w_i = -(1+e)\sum_{c\in\mathscr P}K_{ic}\,w^-_c`
    with the row-normalised kernel :math:`K_{ij} = k(x_i - x_j)V_j/\sum_m
    k(x_i-x_m)V_m`, :math:`k(d) = e^{-|d|/\ell}`.  A flat layer impacting all at
    once gets :math:`w^+ = -e\,w^-` (rows sum to one, to round-off).
``"patch"``
    Coherent patches: the contact set is widened to every free node that is
    approaching the plate (:math:`w < 0`) within distance ``cutoff`` of a
    contact node, and the whole patch rebounds by (11).  A flat layer gets
    exactly :math:`w^+ = -e\,w^-`.
The paper's literal, unnormalised (67) is ``simulate(..., impact="diffused",
rho_c=...)`` of :mod:`.events`; it is evaluated for comparison.

**Status (measured in** ``validation/cutoff.py`` **).**  Both instantaneous rules
are *experimental and rejected*: the kernel rule responds at O(1) to a 1e-7
perturbation of a flat layer (the order of nearly simultaneous impacts enters
at O(1)); the patch rule's growth factor diverges under refinement like point
impacts.  They are kept for comparison.  The soft contact below is the model
that converges.

Soft contact (:func:`simulate_soft`)
------------------------------------
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
import scipy.integrate
import scipy.linalg
import scipy.optimize
import scipy.sparse
from scipy.optimize import brentq

from .._validation import (check_array, check_choice, check_in_range, check_positive, check_real,
                           check_restitution)
from .driver import SimulationResult, check_time_window, stack_samples
from .events import EVENT_DTYPE
from .lattice import Lattice

__all__ = ["RULES", "regularised_impact", "kernel_matrix", "kernel_impact", "patch_impact",
           "soft_contact_parameters", "simulate_soft", "SoftFlatOrbit", "lattice_eigenvalues"]

RULES = ("kernel", "patch")


def _distances(lattice):
    x = lattice.nodes
    return np.abs(x[:, None] - x[None, :])


def kernel_matrix(lattice, cutoff):
    r"""Row-normalised exponential kernel :math:`K_{ij} = e^{-|x_i-x_j|/\ell}V_j/\sum_m e^{-|x_i-x_m|/\ell}V_m`.

    Parameters
    ----------
    lattice : Lattice
    cutoff : float
        Kernel length :math:`\ell > 0`.

    Returns
    -------
    K : ndarray of float, shape (n_nodes, n_nodes)
        Non-negative, rows summing to one.  On axisymmetric lattices the
        distance is :math:`|r_i - r_j|` and the weights are the annulus areas
        :math:`V_j` (a radial, not a two-dimensional, kernel).

    Examples
    --------
    >>> from tps_solver.fda import Lattice
    >>> K = kernel_matrix(Lattice.planar(n_nodes=5, length=4.0), 1.0)
    >>> bool(np.allclose(K.sum(axis=1), 1.0))
    True
    """
    K = np.exp(-_distances(lattice) / cutoff) * lattice.volumes[None, :]
    return K / K.sum(axis=1, keepdims=True)


def kernel_impact(w_minus, contact, e, lattice, free, K):
    r"""Normalised-kernel impact: :math:`\Delta w = -(1+e)K_{:,\mathscr P}\,w^-_{\mathscr P}` on free nodes.

    A contact set holding every free node of a uniform state gets
    :math:`w^+ = -e\,w^-` to round-off (rows of ``K`` sum to one).

    Parameters
    ----------
    w_minus : ndarray of float, shape (n_nodes,)
    contact : ndarray of int
    e : float
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)
    K : ndarray of float, shape (n_nodes, n_nodes)
        From :func:`kernel_matrix`.

    Returns
    -------
    w_plus : ndarray of float, shape (n_nodes,)
    """
    w = w_minus.copy()
    kick = -(1.0 + e) * (K[:, contact] @ w_minus[contact])
    w[free] += kick[free]
    return w


def patch_impact(w_minus, contact, e, lattice, free, cutoff):
    r"""Coherent-patch impact: restitution (11) on every approaching free node within ``cutoff`` of the set.

    Parameters
    ----------
    w_minus : ndarray of float, shape (n_nodes,)
    contact : ndarray of int
    e : float
    lattice : Lattice
    free : ndarray of bool, shape (n_nodes,)
    cutoff : float

    Returns
    -------
    w_plus : ndarray of float, shape (n_nodes,)

    Examples
    --------
    >>> from tps_solver.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> patch_impact(np.array([-1.0, -1.0, -1.0, -1.0, 2.0]), np.array([0]), 0.5, lat,
    ...              np.ones(5, bool), 1.5)
    array([ 0.5,  0.5, -1. , -1. ,  2. ])
    """
    x = lattice.nodes
    near = np.min(np.abs(x[:, None] - x[contact][None, :]), axis=1) <= cutoff
    patch = near & free & (w_minus < 0.0)
    patch[contact] = True
    w = w_minus.copy()
    w[patch] = -e * w_minus[patch]
    return w


class _Rule:
    """A picklable impact rule carrying its cut-off (``rule.cutoff``)."""

    def __init__(self, kind, cutoff):
        self.kind = kind
        self.cutoff = {"kind": f"{kind} impact", "length": cutoff}
        self._lattice, self._K = None, None

    def __call__(self, w_minus, contact, e, lattice, free):
        if self.kind == "patch":
            return patch_impact(w_minus, contact, e, lattice, free, self.cutoff["length"])
        if self._lattice is not lattice:             # cache for the lattice in use (held, so never stale)
            self._lattice, self._K = lattice, kernel_matrix(lattice, self.cutoff["length"])
        return kernel_impact(w_minus, contact, e, lattice, free, self._K)

    def __repr__(self):
        return f"regularised_impact({self.kind!r}, cutoff={self.cutoff['length']!r})"


def regularised_impact(kind, cutoff):
    """Impact rule with a physical cut-off length, for ``simulate(..., impact=rule)``.

    Parameters
    ----------
    kind : {"kernel", "patch"}
        See the module docstring.
    cutoff : float
        The cut-off length :math:`\\ell > 0` (viscous units).

    Returns
    -------
    rule : callable
        ``rule(w_minus, contact, e, lattice, free) -> w_plus``, with attribute
        ``rule.cutoff = {"kind": ..., "length": cutoff}``.

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver import FlatLayer
    >>> from tps_solver.fda import Lattice, simulate, flat_state
    >>> fl = FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> lat = Lattice.planar(n_nodes=9, length=8.0)
    >>> w, z = flat_state(lat, fl, fl.t0 + 1.0)
    >>> run = simulate(lat, 2.5, 0.45, w, z, t_start=fl.t0 + 1.0, t_end=fl.t0 + 1.0 + fl.period,
    ...                impact=regularised_impact("kernel", 0.5))
    >>> bool(np.allclose(run.zeta, z, atol=1e-12))
    True
    """
    kind = check_choice(kind, "kind", RULES)
    cutoff = check_positive(cutoff, "cutoff")
    return _Rule(kind, cutoff)


# ---------------------------------------------------------------- soft contact
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


def simulate_soft(lattice, Gamma, e, w0, zeta0, t_start=0.0, t_end=None, *, cutoff, t_eval=None,
                  rtol=1e-10, atol=1e-12, max_step=None):
    r"""Integrate the FDA with the soft contact of cut-off length ``cutoff`` (module docstring).

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in (0, 1).
    w0, zeta0 : array_like of float, shape (n_nodes,)
        Initial state (``zeta0`` may be negative: a node in contact).
    t_start, t_end : float
    cutoff : float
        :math:`\ell = \sqrt{\nu\tau_c} > 0`.
    t_eval : array_like of float, optional
        Output times in ``[t_start, t_end]``.
    rtol, atol : float
        Tolerances of the ``Radau`` solver (sparse analytic Jacobian).
    max_step : float, optional
        Largest step; default ``tau_c / 4`` so that no contact is stepped over.

    Notes
    -----
    Every contact entry is a discontinuity of the right-hand side that Radau
    resolves by step rejection.  Near a flat layer this costs 1-3 s per period
    for 9-17 nodes; states with repeated contacts are much slower (a 33-node
    kink: about 1900 steps per time unit once contacts repeat at the front).

    Returns
    -------
    SimulationResult
        As :func:`~tps_solver.fda.simulate`; ``events`` holds one ``"impact"``
        record per contact entry (:math:`\zeta` crossing 0 downwards, located by
        the dense output) with the entry velocity; ``stuck`` marks the nodes in
        contact at ``t``; ``cutoff = {"kind": "soft contact", "length": cutoff,
        "tau_c": ...}``; ``method = "soft"``.

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> run = simulate_soft(lat, 2.5, 0.45, np.full(5, -1.0), np.full(5, 0.01), t_end=0.2, cutoff=0.3)
    >>> bool(run.events.size == 5 and np.ptp(run.w) < 1e-12)
    True
    """
    if not isinstance(lattice, Lattice):
        raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
    Gamma = check_positive(Gamma, "Gamma")
    e = check_restitution(e, "e")
    tau_c, om2, beta = soft_contact_parameters(e, cutoff)
    n = lattice.n_nodes
    w = check_array(w0, "w0", shape=(n,))
    z = check_array(zeta0, "zeta0", shape=(n,))
    t_start, t_end, t_eval = check_time_window(t_start, t_end, t_eval)
    rtol = check_positive(rtol, "rtol")
    atol = check_positive(atol, "atol")
    max_step = 0.25 * tau_c if max_step is None else check_positive(max_step, "max_step")

    L = scipy.sparse.csr_matrix(lattice.operator)
    inv_G = 1.0 / Gamma
    eye = scipy.sparse.identity(n, format="csr")

    def fun(t, y):
        wv, zv = y[:n], y[n:]
        g = math.sin(t) - inv_G
        dw = L @ wv + g
        c = zv < 0.0
        dw[c] -= g + om2 * zv[c] + 2.0 * beta * wv[c]
        return np.concatenate((dw, wv))

    def jac(t, y):
        c = (y[n:] < 0.0).astype(float)
        C = scipy.sparse.diags(c)
        return scipy.sparse.bmat([[L - 2.0 * beta * C, -om2 * C], [eye, None]], format="csc")

    solver = scipy.integrate.Radau(fun, t_start, np.concatenate((w, z)), t_end, rtol=rtol, atol=atol,
                                   jac=jac, max_step=max_step)
    records = []
    samples = []
    k_eval = 0
    if t_eval.size and t_eval[0] == t_start:
        samples.append((t_start, w.copy(), z.copy()))
        k_eval = 1
    status, message = 0, "reached t_end"
    n_steps = 0
    while solver.status == "running":
        ta, ya = solver.t, solver.y.copy()
        solver.step()
        n_steps += 1
        if solver.status == "failed":
            status, message = 3, f"Radau failed at t = {solver.t:.15g}: {solver.message}"
            break
        tb, yb = solver.t, solver.y
        dense = solver.dense_output()
        entered = np.flatnonzero((ya[n:] >= 0.0) & (yb[n:] < 0.0))
        for j in entered:
            tc = scipy.optimize.brentq(lambda s, j=j: dense(s)[n + j], ta, tb, xtol=1e-14)
            records.append((tc, int(j), "impact", float(dense(tc)[j])))
        while k_eval < t_eval.size and t_eval[k_eval] <= tb:
            y = dense(t_eval[k_eval]) if t_eval[k_eval] < tb else yb
            samples.append((float(t_eval[k_eval]), y[:n].copy(), y[n:].copy()))
            k_eval += 1
    records.sort(key=lambda r: (r[0], r[1]))
    events = np.array(records, dtype=EVENT_DTYPE).view(np.recarray)
    y = solver.y
    te, we, ze = stack_samples(samples, n)
    return SimulationResult(
        t=float(solver.t), w=y[:n].copy(), zeta=y[n:].copy(), stuck=y[n:] < 0.0, events=events,
        n_events=int(events.size), success=status == 0, status=status, message=message, t_eval=te,
        w_eval=we, zeta_eval=ze, cutoff={"kind": "soft contact", "length": float(cutoff), "tau_c": tau_c},
        method="soft", n_steps=n_steps, lattice=lattice, Gamma=Gamma, e=e)


# ------------------------------------------------- soft contact: flat orbit and modes
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
        from ..flat import FlatLayer
        hard = FlatLayer(Gamma, M, e=e, branch=branch)
        self.Gamma, self.M, self.e = hard.Gamma, hard.M, hard.e
        self.tau_c, self.omega0_sq, self.beta = soft_contact_parameters(self.e, cutoff)
        self.cutoff = float(cutoff)
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
        return (_flight_map(lam, a) @ S_out @ _expm_companion(-lam - 2.0 * b, -om2, tc) @ S_in
                @ _flight_map(lam, F - a))

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


def _expm_companion(a, c, t):
    r"""Batched :math:`\exp(At)` for :math:`A = [[a, c], [1, 0]]`, ``a`` of shape (k,), in closed form.

    With the eigenvalues :math:`r_{1,2} = m \pm q` (:math:`m = a/2`,
    :math:`q = \sqrt{m^2 + c}`, complex if needed),
    :math:`e^{At} = \alpha I + \gamma A` with
    :math:`\gamma = (e^{r_1t} - e^{r_2t})/(r_1 - r_2)` and
    :math:`\alpha = e^{r_2t} - r_2\gamma` (entry (0, 0) is :math:`e^{r_1t} + r_2\gamma`).  The larger root is formed as
    :math:`m + \operatorname{sign}(m)q` and the smaller as :math:`-c/r_1`, so
    nothing cancels for :math:`|a| \gg |c|`; :math:`|qt| < 10^{-4}` uses the series.
    """
    a = np.asarray(a, dtype=float)
    m = 0.5 * a
    q = np.sqrt((m * m + c).astype(complex))
    sgn = np.where(m >= 0.0, 1.0, -1.0)
    r1 = m + sgn * q
    r1_safe = np.where(r1 == 0.0, 1.0, r1)
    r2 = np.where(r1 == 0.0, m - sgn * q, -c / r1_safe)
    e1, e2 = np.exp(r1 * t), np.exp(r2 * t)
    small = np.abs(q * t) < 1e-4
    d = np.where(small, 1.0, 2.0 * sgn * q)
    gamma = np.where(small, t * np.exp(m * t) * (1.0 + (q * t) ** 2 / 6.0), (e1 - e2) / d)
    alpha = np.where(small, np.exp(m * t) * (1.0 - m * t + (q * t) ** 2 * (0.5 - m * t / 6.0)), e2 - r2 * gamma)
    out = np.empty(a.shape + (2, 2))
    out[..., 0, 0] = np.where(small, alpha + gamma * a, e1 + r2 * gamma).real
    out[..., 0, 1] = (gamma * c).real
    out[..., 1, 0] = gamma.real
    out[..., 1, 1] = alpha.real
    return out


def _flight_map(lam, tau):
    """Batched flight propagator of (dw, dzeta) for a mode: dw' = -lam dw, dzeta' = dw, over ``tau``."""
    out = np.zeros((lam.size, 2, 2))
    out[:, 0, 0] = np.exp(-lam * tau)
    out[:, 1, 0] = tau * _phi1(-lam * tau)
    out[:, 1, 1] = 1.0
    return out


def _phi1(z):
    """(e^z - 1)/z with the value 1 at 0."""
    return np.divide(np.expm1(z), z, out=np.ones_like(np.asarray(z, dtype=float)), where=z != 0.0)


def lattice_eigenvalues(lattice):
    r"""Eigenvalues :math:`\lambda \ge 0` of :math:`-\underline L` (symmetrised), ascending.

    Parameters
    ----------
    lattice : Lattice
        With Neumann ends (all nodes coupled).

    Returns
    -------
    lam : ndarray of float, shape (n_nodes,)
    """
    v = np.sqrt(lattice.volumes)
    S = -lattice.flux / v[:, None] / v[None, :]
    lam = scipy.linalg.eigvalsh(0.5 * (S + S.T))
    return np.maximum(lam, 0.0)
