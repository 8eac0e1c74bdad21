r"""Fast soft-contact integrator: Radau IIA collocation with tridiagonal stage solves.

The soft contact of :mod:`.regularised` (a spring-dashpot acting while
:math:`\zeta_i < 0`, Appendix A made finite) is *piecewise linear*: with the
contact set :math:`C` fixed, the state :math:`y = (w, \zeta)` obeys

.. math::
    \dot w = \underline L w - 2\beta\,c\circ w - \omega_0^2\,c\circ\zeta + g(t)\,(1 - c),
    \qquad \dot\zeta = w,

(:math:`c_i = 1` on :math:`C`, eqs. (51)-(52) with the contact force of
(A.1)), a linear system :math:`\dot y = A_C y + b_C(t)` with a *tridiagonal*
:math:`\underline L`.  :class:`SoftIntegrator` integrates it between switches
with the ``s``-stage Radau IIA collocation method (order :math:`2s-1`,
L-stable, default ``s = 6``: order 11).  Diagonalising the Butcher matrix turns
the stage system into :math:`\lceil s/2\rceil` decoupled systems
:math:`(I - \mu A_C)Z = R`; eliminating :math:`\zeta` leaves, for each, the
tridiagonal system

.. math::
    \big[I - \mu\underline L + c\circ(2\beta\mu + \omega_0^2\mu^2)\big] Z_w
    = R_w - \omega_0^2\mu\,c\circ R_\zeta, \qquad Z_\zeta = R_\zeta + \mu Z_w ,

which are stacked into one block-tridiagonal LAPACK ``zgtsv`` call: O(n) work
per step, whatever the contact set.  The step size is controlled by step
doubling (the difference of one step and two half steps estimates the local
error of the order-:math:`2s-1` method) against ``rtol``/``atol``.

Cost: on the numpy path (``compiled=False``, the reference) a step is ``zgtsv`` and a fixed, small
number of numpy calls (configuration constants cached per contact set, the state part of the stage
right-hand sides formed once per start state, stage values and scan grid from one real product); numpy
call overhead is most of it.  With numba (the default where installed) the step loop, the scan and the
switch search run as compiled kernels (:mod:`~tps_solver.solvers.fda.soft_kernels`) and agree with the
numpy path to rounding; ``benchmarks/soft_benchmark.py`` times both.

Switches
--------
A switch is a zero crossing of a *violation* function: :math:`-\zeta_i` for a
free node (entry), :math:`\zeta_i` for a node in soft contact (exit), and the
free acceleration :math:`a_i = (\underline L w)_i + g(t)` for a held node
(release, see below).  Every accepted step is scanned on a grid of the
collocation polynomials of both half steps (so a node that enters and leaves
within a step is still seen, unless it does so between two grid points); the
earliest crossing, guessed from the polynomial, is then located by a
bracketed Newton iteration in the step size :math:`h` whose every evaluation
is a *full* collocation step from the start of the step (order
:math:`2s-1`, not the polynomial's order ``s``).  Newton stops when its
correction is below 1e-10 and the state is moved by that correction along the
flow (an O(correction^2) error), so the switch is located to the precision of
:math:`h`, not of :math:`t` -- which matters: at :math:`t \approx 600` one ulp
of ``t`` is 1e-13, and a switch displaced by :math:`\delta t` changes the
velocity by :math:`(g + 2\beta w)\,\delta t \approx 60\,\delta t`.  The
returned ``Step.t`` is the float nearest the switch, and the returned state is
carried along the post-switch flow to that float.  Other nodes whose crossing
lies within ``time_tol`` of the located time switch in the same event (a flat
region enters as one set); a node found to have crossed more than
``time_tol`` *earlier* becomes the new target.  The other crossings that the
step predicted are kept, and the next :meth:`~SoftIntegrator.advance` call
locates them directly (no new trial step) when it starts from the returned
state -- a front entering node by node costs about two steps per switch.  A node
switched with others within the window may start the next step up to
``2 time_tol`` on the wrong side of its own switch, moving away; the scan does
not count that sliver as a crossing (a search inside it, where the violation is
positive throughout, used to stall when an output time fell a few ulps after
such a switch).  A
switch only changes :math:`c` -- the state is continuous -- so the method
carries no impact map.

Conditioning
------------
Slow contacts amplify perturbations by about (force jump)/(speed) per switch.
On the 17-node kink of ``benchmarks/soft_benchmark.py`` (``stick_speed=1e-8``)
a 1e-13 change of the initial velocity changes the state after one period by
3e-8 (6 stages) to 7e-7 (5 stages; the micro-chatter sequence differs),
measured: an amplification of 1e5-1e7, so no two integrators can agree to
1e-8 there unless their errors are below 1e-15; the sticking rule below removes
the slowest contacts.

Sticking rule (part of the model; docs/design.md, hazard 10)
------------------------------------------------------------
The linear contact can adhere and a node arriving with a tiny speed
micro-chatters (entry speed :math:`V`, exit speed close to :math:`eV` -- or
close to :math:`V` when the neighbours push it out after a contact much
shorter than :math:`\tau_c` -- then a flight of about :math:`2V/|a|`, and
again; measured on the 481-node kink: speeds 1.46e-5 to 1.28e-5 over 40
switches).  Therefore: a node that enters or leaves the soft contact with
speed :math:`|w_i| \le` ``stick_speed`` (default 1e-4) while its free
acceleration :math:`a_i = (\underline L w)_i + g(t) \le 0` is **held**: set
to :math:`w_i = \zeta_i = 0` (a jump of at most ``stick_speed`` in
:math:`w`; :math:`\zeta_i` is within :math:`V^2/|a|` of 0 then) and moved
with the plate (its row of :math:`\underline L` is dropped; its neighbours
see :math:`w_i = 0`).  A held node is **released** (becomes free at
:math:`\zeta_i = w_i = 0`) when :math:`a_i` turns positive, a switch located
like the others.  Held nodes are recognised from the state alone: in contact
with :math:`w_i = \zeta_i = 0` exactly.  A soft contact otherwise ends only
when :math:`\zeta_i` crosses zero upwards (a node driven into the plate by
its neighbours can stay in soft contact with :math:`a_i > 0`; that is the
linear model).  ``stick_speed = 0`` gives the pure soft model (then bounded
only by ``max_events``).  The rule is a model change, not a round-off: on the
17-node kink of ``benchmarks/soft_benchmark.py`` the default moves the state
after one and two periods by up to 6e-4 from the pure soft model (measured;
7 captures), because held nodes leave as soon as :math:`a_i > 0` where the
linear contact would adhere.

Restitution ``e = 0`` (docs/design.md, hazard 11)
-------------------------------------------------
The damping :math:`\beta = -\ln e/\tau_c` is infinite at ``e = 0``; the
constructor refuses ``e = 0`` with a ``ValueError`` (use a small positive
``e``, or the impulsive methods, which treat ``e = 0`` as sticking).

Event records are ``(t, node, kind, w_before)`` with kind ``"impact"`` (entry
into soft contact, ``w_before`` = entry velocity), ``"liftoff"`` (exit from
soft contact or release of a held node, ``w_before`` = velocity at exit) and
``"stick"`` (captured by the sticking rule, ``w_before`` = velocity before
the capture).
"""
import collections
import math

import numpy as np
from scipy.linalg import lapack

from tps_solver.core import jit
from tps_solver.core.checks import check_int, check_positive
from tps_solver.solvers.fda.base import Integrator, Step
from tps_solver.solvers.fda.radau_tableau import lagrange_matrix, radau_iia
from tps_solver.operators.lattice import Lattice
from tps_solver.model.soft_flat import soft_contact_parameters

__all__ = ["SoftIntegrator", "radau_iia"]

_FREE, _CONTACT, _HELD = 0, 1, 2


class _Config:
    """Constants of one contact configuration (attributes set by ``SoftIntegrator._config``)."""


class SoftIntegrator(Integrator):
    r"""Soft-contact time stepper (module docstring): exact switches, O(n) per step.

    Parameters
    ----------
    lattice : Lattice
        Any lattice (its operator is tridiagonal).
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in (0, 1); ``e = 0`` raises ``ValueError`` (module docstring).
    cutoff : float
        Cut-off length :math:`\ell > 0`; contact time :math:`\tau_c = \ell^2`.
    rtol, atol : float
        Local error tolerances of the step-doubling control (defaults 1e-12).
    stages : int
        Radau IIA stages ``s`` in 1..9 (order ``2s - 1``); default 6 (order 11).  Above 7 the
        eigenvector matrix of the Butcher matrix is ill-conditioned (condition 4e3 at s = 8) and
        round-off grows (flat-orbit contact times 1.5e-11 at s = 8, 1.2e-13 at s = 6, measured).
    stick_speed : float
        Capture speed of the sticking rule, >= 0 (default 1e-4; 0 disables capture).
    time_tol : float
        Simultaneity window of switches, > 0 (default 1e-12); switch times are
        located to ``time_tol / 100``.
    max_step : float, optional
        Largest step; default :math:`\tau_c` (a contact spans at least one step).
    max_events : int
        Bound on events per node within one forcing period :math:`2\pi`
        (default 200): beyond it :meth:`advance` raises ``RuntimeError``.
    compiled : bool or None, optional
        Run the step loop, the scan and the switch search as compiled kernels
        (:mod:`~tps_solver.solvers.fda.soft_kernels`, the ``fast`` extra); ``None`` (default):
        where numba is installed (:func:`tps_solver.core.jit.enabled`).  ``False`` is the numpy
        path, the reference; the two agree to rounding.

    Attributes
    ----------
    tau_c, omega0_sq, beta : float
        Contact constants (:func:`~tps_solver.solvers.fda.regularised.soft_contact_parameters`).
    n_steps : int
        Collocation steps taken (trial, half and Newton steps).
    n_rejected : int
        Steps rejected by the error control.

    Examples
    --------
    >>> import numpy as np
    >>> from tps_solver.solvers.fda import Lattice
    >>> lat = Lattice.planar(n_nodes=5, length=4.0)
    >>> integ = SoftIntegrator(lat, 2.5, 0.45, cutoff=0.3)
    >>> t, w, z, stuck = 0.0, np.full(5, -1.0), np.full(5, 0.01), np.zeros(5, bool)
    >>> s = integ.advance(t, w, z, stuck, 1.0)
    >>> s.events[0][2], bool(abs(s.t - 0.01) < 1e-3), int(s.stuck.sum())
    ('impact', True, 5)
    """

    name = "soft"
    impulsive = False
    OPTIONS = {"cutoff": None, "rtol": 1e-12, "atol": 1e-12, "stages": 6, "stick_speed": 1e-4,
               "time_tol": 1e-12, "max_step": None, "max_events": 200, "compiled": None}

    def __init__(self, lattice, Gamma, e, **options):
        super().__init__(lattice, Gamma, e, **options)
        if not isinstance(lattice, Lattice):
            raise ValueError(f"lattice must be a tps_solver.Lattice, got {type(lattice).__name__}")
        self.Gamma = check_positive(Gamma, "Gamma")
        if e == 0:
            raise ValueError("e must be in (0, 1) for the soft contact: at e = 0 its damping "
                             "beta = -ln(e)/tau_c is infinite (docs/design.md, hazard 11); use a small "
                             "e > 0, or an impulsive method (which treats e = 0 as sticking)")
        opt = self.options
        if opt["cutoff"] is None:
            raise ValueError("cutoff must be given for method='soft' (a length > 0, the contact lasts "
                             "tau_c = cutoff**2)")
        self.cutoff = check_positive(opt["cutoff"], "cutoff")
        self.tau_c, self.omega0_sq, self.beta = soft_contact_parameters(e, self.cutoff)
        self.e = float(e)
        self.rtol = check_positive(opt["rtol"], "rtol")
        self.atol = check_positive(opt["atol"], "atol")
        self.stages = check_int(opt["stages"], "stages", minimum=1, maximum=9)
        self.stick_speed = float(opt["stick_speed"])
        if not (math.isfinite(self.stick_speed) and self.stick_speed >= 0.0):
            raise ValueError(f"stick_speed must be a finite number >= 0, got {opt['stick_speed']!r}")
        self.time_tol = check_positive(opt["time_tol"], "time_tol")
        self.max_step = (self.tau_c if opt["max_step"] is None
                         else check_positive(opt["max_step"], "max_step"))
        self.max_events = check_int(opt["max_events"], "max_events", minimum=1)
        self.compiled = jit.compiled_option(opt["compiled"])
        self.n_rejected = 0

        L = np.asarray(lattice.operator, float)
        self.n = L.shape[0]
        off = L - np.diag(np.diag(L)) - np.diag(np.diag(L, 1), 1) - np.diag(np.diag(L, -1), -1)
        if np.any(off != 0.0):
            raise ValueError("lattice.operator must be tridiagonal for method='soft'")
        self._Ld, self._Lu, self._Ll = np.diag(L).copy(), np.diag(L, 1).copy(), np.diag(L, -1).copy()

        # Radau IIA tableau, diagonalised: A = T diag(lam) T^-1, one representative per conjugate pair
        s = self.stages
        c, A = radau_iia(s)
        lam, T = np.linalg.eig(A.astype(complex))
        order = np.argsort(-lam.imag)
        lam, T = lam[order], T[:, order]
        reps, used = [], set()
        for k in range(s):
            if k in used:
                continue
            if abs(lam[k].imag) < 1e-12:
                lam[k] = lam[k].real
                T[:, k] = T[:, k].real
                reps.append((k, False))
                used.add(k)
            else:
                j = min((m for m in range(s) if m not in used and m != k),
                        key=lambda m: abs(lam[m] - np.conj(lam[k])))
                lam[j], T[:, j] = np.conj(lam[k]), np.conj(T[:, k])
                reps.append((k, True))
                used.update((k, j))
        Tinv = np.linalg.inv(T)
        self._c = c
        self._lam = np.array([lam[k] for k, _ in reps])
        self._Trep = np.array([T[:, k] * (2.0 if pair else 1.0) for k, pair in reps]).T  # (s, m)
        self._Tinv_rep = Tinv[[k for k, _ in reps]]                                       # (m, s)
        self._q = self._Tinv_rep.sum(axis=1)                                              # T^-1 1
        self._q2 = np.tile(self._q, 2)
        self._nodes = np.concatenate(([0.0], c))
        G = s + 2
        self._theta = np.arange(1, G + 1) / G
        self._dense = lagrange_matrix(self._nodes, self._theta)                          # (G, s+1)
        self._vinv = np.linalg.inv(np.vander(self._nodes, increasing=True))              # monomials
        self._order = 2 * s - 1
        self._h = None
        self._event_times = collections.deque()
        self._event_counts = [0] * self.n
        self._forecast = None
        self._cfg_cache = {}
        self._lam2 = self._lam * self._lam
        self._mlam = -self._lam
        self._qG = self._q / self.Gamma
        self._Te2 = np.array((self._Trep[-1], self._Trep[-1]))
        self._cT = (self._Trep @ (self._lam * self._q)).real     # T diag(lam) T^-1 1 = A 1 = c
        self._c_list = self._c.tolist()
        self._eig_list = list(zip(self._lam.tolist(), self._q.tolist(), self._qG.tolist(),
                                  self._Tinv_rep.tolist()))
        m = self._lam.size
        self._Mt = np.zeros((2 * s + self._theta.size, 2 * m + 2))    # see _steps
        self._Mt[:s, :m], self._Mt[:s, m:2 * m] = self._Trep.real, -self._Trep.imag
        self._Mt[:s, 2 * m] = 1.0
        self._Mt[s:2 * s, 2 * m + 1] = 1.0
        self._rows_cache = {}
        self._is_contact = np.array([0.0, 1.0, 0.0])   # lookup tables indexed by mode
        self._is_free = np.array([1.0, 0.0, 0.0])
        self._sign = np.array([-1.0, 1.0, 1.0])
        if self.compiled:
            from tps_solver.solvers.fda import soft_kernels
            self._kernels = soft_kernels
            # the tableau as the kernels take it (C-contiguous)
            self._keig = tuple(np.ascontiguousarray(a) for a in (
                self._lam, self._q, self._Tinv_rep, self._Trep, self._c, self._cT, self._dense))
            self._kLl = np.concatenate(([0.0], self._Ll))        # full operator row j: L[j, j-1], L[j, j+1]
            self._kLu = np.concatenate((self._Lu, [0.0]))

    # ------------------------------------------------------------ linear algebra
    def _config(self, mode):
        """Per-configuration constants (mode: 0 free, 1 soft contact, 2 held), cached."""
        key = mode.tobytes()
        cfg = self._cfg_cache.get(key)
        if cfg is None:
            if len(self._cfg_cache) > 8:
                self._cfg_cache.clear()
            cfg = self._cfg_cache[key] = self._make_config(mode)
        return cfg

    def _make_config(self, mode):
        if self.compiled:                               # the attributes the compiled path reads, in one call
            cfg = _Config()
            F, cfg.held, H, HL = self._kernels.configure(mode, self._Ld, self._Ll, self._Lu, 2.0 * self.beta,
                                                         self.omega0_sq)
            cfg.dw, cfg.om2c, cfg.f, cfg.sgn, cfg.rows_ok = F[:5]
            cfg.Ll, cfg.Lu = F[5, :-1], F[6, :-1]
            cfg.hidx, cfg.him, cfg.hip = H
            cfg.hLd, cfg.hLl, cfg.hLu = HL
            cfg.dz = -cfg.om2c
            cfg.F, cfg.H, cfg.HL = F, H, HL
            return cfg
        held = mode == _HELD
        key = held.tobytes()
        rows = self._rows_cache.get(key)
        if rows is None:
            if len(self._rows_cache) > 64:
                self._rows_cache.clear()
            rows = self._rows_cache[key] = self._make_rows(held)
        cfg = _Config()
        cfg.__dict__.update(rows)
        c = cfg.c = self._is_contact[mode]
        cfg.f = self._is_free[mode]
        cfg.held = held
        cfg.sgn = self._sign[mode]                      # violation: -zeta (free), zeta (contact)
        cfg.om2c = self.omega0_sq * c
        cfg.dw = cfg.Ld - (2.0 * self.beta) * c         # diagonal of the w-row of A acting on w
        cfg.dz = -cfg.om2c                              # ... acting on zeta
        # stacked block-tridiagonal stage matrix 1 + h P1 + h^2 P2 (blocks separated by zeros)
        if not self.compiled:                           # (the kernels form it themselves)
            cfg.P1 = np.multiply.outer(self._mlam, cfg.dw).ravel()
            cfg.P2 = np.multiply.outer(self._lam2, cfg.om2c).ravel()
        return cfg

    def _make_rows(self, held):
        """Constants of a held set: rows of the operator (held rows dropped), stacked off-diagonals,
        and the data of the held nodes' free accelerations."""
        rows_ok = (~held).astype(float)
        Ld, Ll, Lu = self._Ld * rows_ok, self._Ll * rows_ok[1:], self._Lu * rows_ok[:-1]
        lam = self._lam[:, None]
        QL = np.zeros((lam.size, self.n), complex)
        QU = np.zeros((lam.size, self.n), complex)
        QL[:, :-1] = -lam * Ll[None, :]
        QU[:, :-1] = -lam * Lu[None, :]
        QL, QU = QL.ravel(), QU.ravel()                 # with the trailing separators
        n = self.n
        hidx = np.flatnonzero(held)
        him, hip = np.maximum(hidx - 1, 0), np.minimum(hidx + 1, n - 1)
        return dict(rows_ok=rows_ok, Ld=Ld, Ll=Ll, Lu=Lu, QLf=QL, QUf=QU, QL=QL[:-1], QU=QU[:-1],
                    hidx=hidx, him=him, hip=hip, hcols=np.concatenate((hidx, him, hip)),
                    hLd=self._Ld[hidx], hLl=np.concatenate(([0.0], self._Ll))[hidx],
                    hLu=np.concatenate((self._Lu, [0.0]))[hidx])

    def _rhs(self, t, w, z, cfg):
        if self.compiled:
            return self._kernels.rhs_packed(float(t), w, z, cfg.F, 1.0 / self.Gamma)
        dw = cfg.dw * w + cfg.dz * z + (math.sin(t) - 1.0 / self.Gamma) * cfg.f
        dw[1:] += cfg.Ll * w[:-1]
        dw[:-1] += cfg.Lu * w[1:]
        return dw, w * cfg.rows_ok

    def _step(self, t0, h, w0, z0, cfg):
        """One Radau IIA step; returns (w1, z1, Yw, Yz) with stage values of shape (s, n)."""
        return self._steps(t0, (h,), w0, z0, cfg)[0]

    def _start(self, w0, z0, cfg):
        """The state part of the stage right-hand sides, shape (3, n): :math:`A_C y_0` (w-rows), f, omega0^2 c w0."""
        R = np.empty((3, self.n))
        aw = R[0]
        np.multiply(cfg.dw, w0, out=aw)
        aw += cfg.dz * z0
        aw[1:] += cfg.Ll * w0[:-1]
        aw[:-1] += cfg.Lu * w0[1:]
        R[1] = cfg.f
        np.multiply(cfg.om2c, w0, out=R[2])
        return R

    def _steps(self, t0, hs, w0, z0, cfg, stages=None, R=None):
        """Radau IIA steps of sizes ``hs`` (1 or 2 of them) from the same start, in one ``zgtsv`` call.

        Returns a list of (w1, z1, Yw, Yz, Zg): stage values of shape (s, n) and zeta on the scan
        grid, shape (G, n); ``stages[i]`` False skips them for step i (then ``Yw = Yz = Zg = None``).
        ``R``: ``_start(w0, z0, cfg)`` if already known.
        """
        k = len(hs)
        self.n_steps += k
        n, m, s = self.n, self._lam.size, self.stages
        if R is None:
            R = self._start(w0, z0, cfg)
        # right-hand sides (k m, n) = K @ [aw; f; om2 c w0] in one product; K on Python scalars
        # (3 numbers per eigenvalue: mu T^-1 1, mu T^-1 g(t0 + c h), -mu^2 T^-1 1, with mu = h lam)
        rows, mus = [], []
        for h in hs:
            g = [math.sin(t0 + h * ci) for ci in self._c_list]
            for lam, q, qG, Ti in self._eig_list:
                mu_ = h * lam
                muq = mu_ * q
                rows.append((muq, mu_ * (sum([a * b for a, b in zip(Ti, g)]) - qG), -mu_ * muq))
                mus.append(mu_)
        mu = np.array(mus)
        rhs = np.array(rows) @ R
        if k == 1:
            h = hs[0]
            diag = cfg.P2 * (h * h)
            diag += cfg.P1 * h
            diag += 1.0
            dl, du = h * cfg.QL, h * cfg.QU
        else:
            diag = np.empty(k * m * n, complex)
            dl = np.empty(k * m * n - 1, complex)
            du = np.empty(k * m * n - 1, complex)
            for i, h in enumerate(hs):
                blk = slice(i * m * n, (i + 1) * m * n)
                d = diag[blk]
                np.multiply(cfg.P2, h * h, out=d)
                d += cfg.P1 * h
                d += 1.0
                if i + 1 < k:
                    np.multiply(cfg.QLf, h, out=dl[blk])
                    np.multiply(cfg.QUf, h, out=du[blk])
                else:
                    np.multiply(cfg.QL, h, out=dl[i * m * n:])
                    np.multiply(cfg.QU, h, out=du[i * m * n:])
        _, _, _, x, info = lapack.zgtsv(dl, diag, du, rhs.reshape(-1, 1), 1, 1, 1, 1)
        if info != 0:
            raise RuntimeError(f"soft integrator: singular stage system at t = {t0:.15g} (h = {hs})")
        Zw = x.reshape(-1, n)
        out = []
        Tr = self._Trep
        for i in range(k):
            mui, hi = mu[i * m:(i + 1) * m], hs[i]
            Zi = Zw[i * m:(i + 1) * m]
            if stages is not None and not stages[i]:                 # the end point only
                E = self._Te2.copy()
                E[1] *= mui
                Rr = (E @ Zi).real                                                # (2, n)
                z1 = Rr[1] + z0
                z1 += (hi * self._cT[-1]) * w0                    # (T diag(mu) T^-1 1)_s w0 = h c_s w0
                out.append((Rr[0] + w0, z1, None, None, None))
                continue
            # stage values and the zeta grid of the collocation polynomial in one real product
            # [Yw; Yz; Zgrid] = M @ [Re Z; Im Z; w0; z0]
            buf = np.empty((2 * m + 2, n))
            buf[:2 * m].reshape(2, m, n)[...] = x[i * m * n:(i + 1) * m * n, 0].view(float).reshape(
                m, n, 2).transpose(2, 0, 1)
            buf[2 * m] = w0
            buf[2 * m + 1] = z0
            M = self._Mt.copy()
            Tm = Tr * mui
            M[s:2 * s, :m] = Tm.real
            M[s:2 * s, m:2 * m] = -Tm.imag
            M[s:2 * s, 2 * m] = hi * self._cT
            M[2 * s:] = self._dense[:, 1:] @ M[s:2 * s]
            M[2 * s:, 2 * m + 1] += self._dense[:, 0]
            Y = M @ buf
            Yw, Yz, Zg = Y[:s], Y[s:2 * s], Y[2 * s:]
            Zg[-1] = Yz[-1]                                  # theta = 1 is the last stage, exactly
            out.append((Yw[-1].copy(), Yz[-1].copy(), Yw, Yz, Zg))
        return out

    # --------------------------------------------------------------- violations
    def _violation(self, t, w, z, mode, cfg, with_rate=True):
        """Violation v (crossing when v turns > 0) and its rate for every node."""
        if self.compiled:
            v, dv = self._kernels.violation_packed(float(t), w, z, cfg.F, cfg.H, cfg.HL, 1.0 / self.Gamma,
                                                   with_rate)
            return (v, dv) if with_rate else v
        v = z * cfg.sgn
        hi = cfg.hidx
        if hi.size:
            v[hi] = self._held_accel(w, cfg) + (math.sin(t) - 1.0 / self.Gamma)
        if not with_rate:
            return v
        dv = w * cfg.sgn
        if hi.size:
            dw, _ = self._rhs(t, w, z, cfg)
            dv[hi] = self._held_accel(dw, cfg) + math.cos(t)
        return v, dv

    def _violation_at(self, j, t, w, z, cfg):
        """Violation and its rate of node j alone (floats), as :meth:`_violation`."""
        if cfg.sgn[j] < 0.0:
            return -float(z[j]), -float(w[j])
        if cfg.rows_ok[j] != 0.0:
            return float(z[j]), float(w[j])
        v, dv = self._violation(t, w, z, None, cfg)
        return float(v[j]), float(dv[j])

    def _held_accel(self, u, cfg):
        """Rows ``cfg.hidx`` of the full :math:`\\underline L u`, u of shape (..., n)."""
        return cfg.hLd * u[..., cfg.hidx] + cfg.hLl * u[..., cfg.him] + cfg.hLu * u[..., cfg.hip]

    def _grid_violation(self, t0, h, w0, Yw, Zg, cfg):
        """Violation on the dense grid of one step: times (G,), values (G, n).

        ``Zg``: zeta on the grid (from :meth:`_steps`); the last grid point is the step end.
        """
        P = self._dense
        Zg = Zg * cfg.sgn
        tg = t0 + self._theta * h
        if cfg.hidx.size:
            cols = cfg.hcols
            Wg = P[:, 1:] @ Yw[:, cols] + np.multiply.outer(P[:, 0], w0[cols])
            k = cfg.hidx.size
            a = cfg.hLd * Wg[:, :k] + cfg.hLl * Wg[:, k:2 * k] + cfg.hLu * Wg[:, 2 * k:]
            Zg[:, cfg.hidx] = a + (np.sin(tg) - 1.0 / self.Gamma)[:, None]
        return tg, Zg

    # ------------------------------------------------------------------ driver API
    def _initial_mode(self, w, z, stuck):
        stuck = np.zeros(self.n, bool) if stuck is None else np.asarray(stuck, bool)
        if self.compiled:
            return self._kernels.initial_mode(stuck, w, z)
        mode = np.where(stuck, _CONTACT, _FREE)
        mode[stuck & (w == 0.0) & (z == 0.0)] = _HELD
        return mode

    def _consistency(self, t, w, z, mode, events):
        """Switch nodes whose configuration contradicts the state at t (e.g. an initial state)."""
        held = mode == _HELD
        # nodes switched within the simultaneity window sit up to time_tol * |w| on the wrong side
        cand = np.flatnonzero(z * self._sign[mode] > 0.0)       # free below the plate, contact above
        if cand.size:
            tt = 2.0 * self.time_tol
            enter, leave = [], []
            for i, wi, zi, mi in zip(cand.tolist(), w[cand].tolist(), z[cand].tolist(), mode[cand].tolist()):
                zt = tt * abs(wi)
                if mi == _FREE and (wi < 0.0 or zi < -zt):
                    enter.append(i)
                elif mi == _CONTACT and (wi > 0.0 or zi > zt):
                    leave.append(i)
            if enter or leave:
                self._switch(t, w, z, mode, np.array(enter, int), np.array(leave, int), np.empty(0, int),
                             events)
        if held.any():
            cfg = self._config(mode)
            v = self._violation(t, w, z, mode, cfg, with_rate=False)
            rel = np.flatnonzero(held & (v > 0.0))
            if rel.size:
                self._switch(t, w, z, mode, np.empty(0, int), np.empty(0, int), rel, events)

    def _switch(self, t, w, z, mode, enter, leave, release, events):
        """Apply the switches at time t in place, with the sticking rule; append event records."""
        vs = self.stick_speed
        # free accelerations (L w)_j + g(t) of the slow switching nodes, from the state before any capture
        # (rows of the full operator)
        a = {}
        if vs > 0.0:
            g = math.sin(t) - 1.0 / self.Gamma
            n = self.n
            for j in list(enter) + list(leave):
                if abs(w[j]) <= vs:
                    x = self._Ld[j] * w[j]
                    if j > 0:
                        x += self._Ll[j - 1] * w[j - 1]
                    if j < n - 1:
                        x += self._Lu[j] * w[j + 1]
                    a[j] = x + g
        for j in enter:
            wb = float(w[j])
            if j in a and a[j] <= 0.0:
                mode[j] = _HELD
                w[j] = z[j] = 0.0
                events.append((t, int(j), "stick", wb))
            else:
                mode[j] = _CONTACT
                events.append((t, int(j), "impact", wb))
        for j in leave:
            wb = float(w[j])
            if j in a and a[j] <= 0.0:
                mode[j] = _HELD
                w[j] = z[j] = 0.0
                events.append((t, int(j), "stick", wb))
            else:
                mode[j] = _FREE
                events.append((t, int(j), "liftoff", wb))
        for j in release:
            mode[j] = _FREE
            w[j] = z[j] = 0.0
            events.append((t, int(j), "liftoff", 0.0))

    def _count_events(self, t, nodes):
        """Per-node event bound within one forcing period 2 pi (RuntimeError beyond it)."""
        dq, counts = self._event_times, self._event_counts
        for j in nodes:
            dq.append((t, j))
            counts[j] += 1
        while dq and dq[0][0] < t - 2.0 * math.pi:
            counts[dq.popleft()[1]] -= 1
        worst = max(nodes, key=counts.__getitem__) if nodes else 0    # only these counts grew
        if counts[worst] > self.max_events:
            raise RuntimeError(
                f"soft integrator: node {worst} had more than max_events = {self.max_events} events "
                f"within one forcing period 2*pi before t = {t:.15g} (chattering); raise stick_speed "
                f"(now {self.stick_speed:g}) or max_events")

    def advance(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """Propagate from ``t`` to the next switch or to ``t_stop`` (see :meth:`Integrator.advance`).

        Parameters
        ----------
        t : float
        w, zeta : ndarray of float, shape (n_nodes,)
        stuck : ndarray of bool, shape (n_nodes,) or None
            Nodes in contact at ``t`` (soft contact or held; held nodes have
            ``w = zeta = 0``).  ``None``: nobody.
        t_stop : float
        t_eval : array_like of float
            Sorted output times; those in ``(t, t_new]`` are sampled (each is
            reached by a full step, so samples carry the method's accuracy).

        Returns
        -------
        Step
            ``events`` holds the switches at ``Step.t`` (several when
            simultaneous), ``stuck`` the nodes in contact after them.

        Raises
        ------
        RuntimeError
            More than ``max_events`` events per node within :math:`2\\pi`, or a
            failed event search.
        """
        t = float(t)
        t_stop = float(t_stop)
        w = np.array(w, float)
        z = np.array(zeta, float)
        mode = self._initial_mode(w, z, stuck)
        events = []
        self._consistency(t, w, z, mode, events)
        if events:
            self._count_events(t, [ev[1] for ev in events])
            return Step(t=t, w=w, zeta=z, events=events, stuck=mode != _FREE)
        t_eval = np.asarray(() if t_eval is None else t_eval, float).ravel()
        k_eval = int(np.searchsorted(t_eval, t, side="right"))
        samples = []
        cfg = self._config(mode)
        fc, self._forecast = self._forecast, None
        if fc is not None and not (fc["t"] == t and np.array_equal(fc["w"], w) and np.array_equal(fc["z"], z)):
            fc = None
        if self._h is None:
            self._h = min(self.max_step, 0.1 * self.tau_c)
        order = self._order
        while True:
            t_target = t_stop if k_eval >= t_eval.size else min(t_stop, t_eval[k_eval])
            R0 = None if self.compiled else self._start(w, z, cfg)
            if fc is not None:
                # the previous trial step predicted more crossings: go straight to the next one
                found = self._from_forecast(t, w, z, mode, cfg, fc, t_target, R0)
                fc = None
                if found is not None:
                    return self._finish(t, w, z, mode, cfg, *found, t_eval, k_eval, samples, events, R0)
            if self.compiled:
                # the loop below as one kernel call: steps to t_target or to a step with a crossing
                t, crossing = self._march(t, t_target, w, z, mode, cfg)
                if crossing is not None:
                    return self._finish(t, w, z, mode, cfg, *crossing, t_eval, k_eval, samples, events)
                if k_eval < t_eval.size and t_eval[k_eval] == t:
                    samples.append((t, w.copy(), z.copy()))
                    k_eval += 1
                if t >= t_stop:
                    return Step(t=t_stop, w=w, zeta=z, samples=samples, events=events, stuck=mode != _FREE)
                continue
            h = min(self._h, self.max_step, t_target - t)
            last = h >= t_target - t
            # step ends are floats and steps are their exact differences (no drift of t)
            t_new = t_target if last else t + h
            h = t_new - t
            t_mid = t + 0.5 * h
            hh, h2 = t_mid - t, t_new - t_mid
            # trial step and two half steps (error estimate)
            (w1, z1, _, _, _), (wa, za, Ywa, Yza, Zga) = self._steps(t, (h, hh), w, z, cfg, (False, True), R0)
            wb, zb, Ywb, Yzb, Zgb = self._step(t_mid, h2, wa, za, cfg)
            scale = self.atol + self.rtol * np.maximum(np.abs(np.concatenate((w, z))),
                                                       np.abs(np.concatenate((wb, zb))))
            err = float(np.max(np.abs(np.concatenate((w1 - wb, z1 - zb))) / scale))
            if not np.isfinite(err):
                raise RuntimeError(f"soft integrator: non-finite state at t = {t:.15g}")
            if err > 1.0:
                self.n_rejected += 1
                self._h = h * max(0.1, 0.8 * err ** (-1.0 / (order + 1)))
                if self._h < 1e-14 * max(1.0, abs(t)):
                    raise RuntimeError(f"soft integrator: step size underflow at t = {t:.15g}")
                continue
            grow = 4.0 if err == 0.0 else min(4.0, max(0.2, 0.8 * err ** (-1.0 / (order + 1))))
            if not last or h >= self._h:
                self._h = h * grow
            # scan both halves for crossings
            v0 = self._violation(t, w, z, mode, cfg, with_rate=False)
            tga, va = self._grid_violation(t, hh, w, Ywa, Zga, cfg)
            tgb, vb = self._grid_violation(t_mid, h2, wa, Ywb, Zgb, cfg)
            tg = np.concatenate(([t], tga[:-1], [t_mid], tgb[:-1], [t_new]))
            vg = np.concatenate((v0[None, :], va, vb))
            pos = vg > 0.0
            away = v0 > 0.0
            if away.any():
                # a node switched within the simultaneity window may start on the wrong side of its
                # switch, moving away (_consistency keeps it; it is back within 2 time_tol): v > 0
                # there is no crossing.  One counts after v has been <= 0 or past that sliver
                # (else a search inside the sliver, where v > 0 throughout, would stall)
                pos[:, away] &= (np.logical_or.accumulate(vg[:, away] <= 0.0, axis=0)
                                 | (tg > t + 4.0 * self.time_tol)[:, None])
                vg[0] = np.minimum(v0, 0.0)
            hit = pos.any(axis=0)
            if hit.any():
                nodes = np.flatnonzero(hit)
                k = np.argmax(pos[:, nodes], axis=0)                   # first grid index past a crossing
                lo, hi = vg[k - 1, nodes], vg[k, nodes]
                guess = tg[k - 1] + (tg[k] - tg[k - 1]) * (-lo) / (hi - lo)
                # v(t) may be 0 (a node that has just switched, moving away): search from the upper point
                guess = np.where(k == 1, tg[k], guess)
                G = self._theta.size
                for half, (ts_, hs_, z_, Yz_) in enumerate(((t, hh, z, Yza), (t_mid, h2, za, Yzb))):
                    sel = ((k <= G) if half == 0 else (k > G)) & (mode[nodes] != _HELD)
                    if sel.any():                            # polish on the collocation polynomial
                        idx = nodes[sel]
                        guess[sel] = ts_ + hs_ * self._poly_roots(
                            np.vstack((z_[idx][None, :], Yz_[:, idx])), (tg[k[sel] - 1] - ts_) / hs_,
                            (tg[k[sel]] - ts_) / hs_, (guess[sel] - ts_) / hs_)
                i = int(np.argmin(guess))
                j = int(nodes[i])
                he, we, ze = self._locate(t, w, z, mode, cfg, j, float(guess[i]) - t, float(tg[k[i]]) - t,
                                          R=R0, h_lo=4.0 * self.time_tol if away[j] else 0.0)
                fc = {"nodes": nodes, "guess": guess, "mode": mode[nodes].copy(), "t_limit": t_new}
                return self._finish(t, w, z, mode, cfg, j, he, we, ze, fc, t_eval, k_eval, samples, events, R0)
            # accept the two half steps (the more accurate value)
            t, w, z = t_new, wb, zb
            if k_eval < t_eval.size and t_eval[k_eval] == t:
                samples.append((t, w.copy(), z.copy()))
                k_eval += 1
            if t >= t_stop:
                return Step(t=t_stop, w=w, zeta=z, samples=samples, events=events, stuck=mode != _FREE)

    def _march(self, t, t_target, w, z, mode, cfg):
        """Compiled path of the step loop of :meth:`advance` (:func:`.soft_kernels.march`).

        Accepted steps update ``w, z`` in place.  Returns ``(t, None)`` at ``t_target``, or
        ``(t, (j, he, we, ze, fc))`` with the located crossing of a step that starts at ``t``.
        """
        kn = self._kernels
        n = self.n
        xnodes, xguess, xtop, xstate = np.empty(n, np.int64), np.empty(n), np.empty(n), np.empty(2)
        status, t, self._h, count, steps, rejected = kn.march_packed(
            t, t_target, self._h, self.max_step, w, z, cfg.F, cfg.held, cfg.H, cfg.HL, 1.0 / self.Gamma, self.rtol,
            self.atol, self._order, self.time_tol, *self._keig, self._theta, self._vinv, xnodes, xguess, xtop,
            xstate)
        self.n_steps += steps
        self.n_rejected += rejected
        if status == kn.NONFINITE:
            raise RuntimeError(f"soft integrator: non-finite state at t = {t:.15g}")
        if status == kn.UNDERFLOW:
            raise RuntimeError(f"soft integrator: step size underflow at t = {t:.15g}")
        if status == kn.SINGULAR:
            raise RuntimeError(f"soft integrator: singular stage system at t = {t:.15g}")
        if status == kn.REACHED:
            return t, None
        nodes, guess = xnodes[:count], xguess[:count]
        i = int(np.argmin(guess))
        j = int(nodes[i])
        he, we, ze = self._locate(t, w, z, mode, cfg, j, float(guess[i]) - t, float(xtop[i]) - t,
                                  h_lo=4.0 * self.time_tol if xstate[1] else 0.0)
        fc = {"nodes": nodes, "guess": guess, "mode": mode[nodes].copy(), "t_limit": float(xstate[0])}
        return t, (j, he, we, ze, fc)

    def _from_forecast(self, t, w, z, mode, cfg, fc, t_target, R0):
        """Locate the next predicted crossing without a trial step; None if the prediction fails."""
        ok = (fc["mode"] == mode[fc["nodes"]]) & (fc["guess"] < fc["t_limit"])
        if not ok.any():
            return None
        nodes, guess = fc["nodes"][ok], fc["guess"][ok]
        h_max = min(fc["t_limit"], t_target) - t
        i = int(np.argmin(guess))
        if guess[i] - t > h_max or h_max <= 0.0:
            return None
        j = int(nodes[i])
        res = self._locate(t, w, z, mode, cfg, j, max(float(guess[i]) - t, 0.0), h_max, verified=False, R=R0)
        if res is None:
            return None
        he, we, ze = res
        fc = {"nodes": nodes, "guess": guess, "mode": mode[nodes].copy(), "t_limit": fc["t_limit"]}
        return j, he, we, ze, fc

    def _finish(self, t, w, z, mode, cfg, j, he, we, ze, fc, t_eval, k_eval, samples, events, R0=None):
        """Complete a switch located at t + he (node j): simultaneous nodes, sticking rule, Step."""
        for _ in range(4 * self.n + 4):
            ev, early, dt_early = self._simultaneous(t + he, we, ze, mode, cfg, j)
            if early < 0:
                break
            j = early
            he, we, ze = self._locate(t, w, z, mode, cfg, j, he - dt_early, he, R=R0)
        else:
            raise RuntimeError(f"soft integrator: switch search stalled after t = {t:.15g}; "
                               "try a smaller max_step")
        # the switch happens at the real time t + he; report the float te = fl(t + he) and
        # move the post-switch state along the post-switch flow by te - (t + he) (|.| <= ulp)
        te = t + he
        delta = -((t - (te - (te - t))) + (he - (te - t)))     # te - (t + he), exact (TwoSum)
        if k_eval < t_eval.size and t_eval[k_eval] <= te:
            samples.append((float(t_eval[k_eval]), we.copy(), ze.copy()))
        enter = ev[mode[ev] == _FREE]
        leave = ev[mode[ev] == _CONTACT]
        release = ev[mode[ev] == _HELD]
        self._switch(te, we, ze, mode, enter, leave, release, events)
        if delta != 0.0:
            dw, dz = self._rhs(t + he, we, ze, self._config(mode))
            we, ze = we + delta * dw, ze + delta * dz
        self._count_events(te, [ev[1] for ev in events])
        switched = np.zeros(self.n, bool)
        switched[ev] = True
        keep = ~switched[fc["nodes"]]
        if keep.any():
            self._forecast = {"t": te, "w": we, "z": ze, "nodes": fc["nodes"][keep],
                              "guess": fc["guess"][keep], "mode": fc["mode"][keep], "t_limit": fc["t_limit"]}
        return Step(t=te, w=we, zeta=ze, samples=samples, events=events, stuck=mode != _FREE)

    # ------------------------------------------------------------ event location
    def _locate(self, t0, w0, z0, mode, cfg, j, guess, h_hi, verified=True, R=None, h_lo=0.0):
        """Safeguarded Newton in the step size h for the crossing of node j in (h_lo, h_hi].

        Every evaluation is a full collocation step from ``t0``; h is kept relative to ``t0``, so the
        switch is located to the precision of h (not of t).  Returns (h, w, zeta) at the crossing.
        ``h_lo > 0``: node j starts on the wrong side of its last switch (see :meth:`advance`).
        """
        if self.compiled:
            kn = self._kernels
            we, ze = np.empty(self.n), np.empty(self.n)
            status, hk, steps = kn.locate_packed(
                t0, w0, z0, int(j), float(guess), float(h_hi), bool(verified), float(h_lo), cfg.F, self._Ld[j],
                self._kLl[j], self._kLu[j], 1.0 / self.Gamma, *self._keig, we, ze)
            self.n_steps += steps
            if status == 0:
                return hk, we, ze
            if status == kn.UNVERIFIED:
                return None
            raise RuntimeError(f"soft integrator: switch search of node {j} stalled near t = {t0 + hk:.15g}; "
                               "try a smaller max_step or time_tol")
        lo, hi = min(h_lo, 0.5 * h_hi), h_hi
        hk = min(max(guess, 0.0), h_hi)
        best = None
        for it in range(60):
            if not verified and it >= 6:
                return None
            if hk <= lo:
                hk = 0.5 * (lo + hi)
            we, ze = self._steps(t0, (hk,), w0, z0, cfg, (False,), R)[0][:2]
            vj, dvj = self._violation_at(j, t0 + hk, we, ze, cfg)
            if vj > 0.0:
                hi = hk
                verified = True
            else:
                lo = hk
            corr = -vj / dvj if dvj > 0.0 else math.inf
            if best is None or abs(corr) < best[0]:
                best = (abs(corr), hk, we, ze)
            if abs(corr) <= 1e-10:
                # Newton has converged quadratically: the root is hk + corr to O(corr^2); move the
                # state there along the (pre-switch) flow, an O(corr^2) error
                dw, dz = self._rhs(t0 + hk, we, ze, cfg)
                return hk + corr, we + corr * dw, ze + corr * dz
            if hi - lo <= 4.0 * math.ulp(hk):
                return (best[1], best[2], best[3]) if verified else None
            hn = hk + corr
            if not (lo < hn < hi) or not math.isfinite(hn):
                hn = 0.5 * (lo + hi)
            hk = hn
        raise RuntimeError(f"soft integrator: switch search of node {j} stalled near t = {t0 + hk:.15g} "
                           f"(bracket width {hi - lo:.3g}); try a smaller max_step or time_tol")

    def _poly_roots(self, vals, lo, hi, guess):
        """Roots in [lo, hi] of the collocation polynomials with values ``vals`` (s+1, k) at (0, c)."""
        coef = self._vinv @ vals                          # ascending monomial coefficients, (s+1, k)
        x = np.clip(guess, lo, hi)
        deg = coef.shape[0] - 1
        if x.size <= 16:                                  # few roots: Newton on floats
            out = x.copy()
            for i, (xi, a, b) in enumerate(zip(x.tolist(), lo.tolist(), hi.tolist())):
                ci = coef[::-1, i].tolist()                   # descending
                for _ in range(5):
                    p, dp = ci[0], 0.0
                    for cm in ci[1:]:
                        dp = dp * xi + p
                        p = p * xi + cm
                    if dp == 0.0 or not math.isfinite(p / dp):
                        break
                    xn = xi - p / dp
                    if not (a <= xn <= b):
                        break
                    done = abs(xn - xi) <= 1e-15
                    xi = xn
                    if done:
                        break
                out[i] = xi
            return out
        dcoef = coef[1:] * np.arange(1, deg + 1)[:, None]
        for _ in range(5):
            p = coef[deg].copy()
            dp = dcoef[deg - 1].copy()
            for m in range(deg - 1, -1, -1):
                p *= x
                p += coef[m]
                if m:
                    dp *= x
                    dp += dcoef[m - 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                step = p / dp
            xn = x - step
            good = np.isfinite(xn) & (xn >= lo) & (xn <= hi)
            x = np.where(good, xn, x)
            if not np.any(good & (np.abs(step) > 1e-15)):
                break
        return x

    def _simultaneous(self, te, we, ze, mode, cfg, j):
        """Nodes switching at te: j and every node whose crossing lies within time_tol of te.

        Returns (nodes, early, dt): ``early`` >= 0 is a node that crossed more than time_tol before
        te (the earliest such, ``dt`` before te), else -1.
        """
        if self.compiled:
            nodes, early, dt = self._kernels.simultaneous_packed(te, we, ze, cfg.F, cfg.H, cfg.HL, 1.0 / self.Gamma,
                                                                 int(j), self.time_tol)
            return (None, early, dt) if early >= 0 else (nodes, -1, 0.0)
        v, dv = self._violation(te, we, ze, mode, cfg)
        thr = self.time_tol * dv                   # |te - t_cross| <= time_tol  <=>  |v| <= thr (dv > 0)
        early = v > np.maximum(thr, 0.0)           # crossed more than time_tol before te
        # ... but not a node moving away within the window of _consistency (switched by an earlier
        # event of the window, on the wrong side by round-off; a search for it would stall)
        early &= ~((dv < 0.0) & (v <= -2.0 * thr))
        early[j] = False
        if early.any():
            idx = np.flatnonzero(early)
            with np.errstate(divide="ignore", invalid="ignore"):
                dts = np.where(dv[idx] > 0.0, v[idx] / dv[idx], np.inf)             # te - t_cross
            i = int(np.argmax(dts))
            return None, int(idx[i]), (float(dts[i]) if np.isfinite(dts[i]) else 0.0)
        near = np.abs(v) <= thr
        near &= dv > 0.0
        near[j] = True
        return np.flatnonzero(near), -1, 0.0
