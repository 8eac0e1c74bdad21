r"""Point impacts with modal amplitudes carried across events: :class:`PointIntegrator`.

The flight between two events is the closed form (55)-(56) of the free sub-lattice
(53), written in the modes :math:`\underline L_{FF} = V\Lambda V^{-1}` of the free set
(the decomposition of ``method="exact"``):

.. math::
    \underline w_F(t_c + \tau) = V\underline c_w(\tau), \quad
    \underline\zeta_F(t_c + \tau) = \underline\zeta_F(t_c) + V\underline c_\zeta(\tau),
    \quad \underline c_w = e^{\Lambda\tau}\underline a + \underline s\odot\mathcal W_\Lambda(\tau),
    \quad \underline c_\zeta = \tau\varphi_1(\Lambda\tau)\underline a + \underline s\odot\mathcal Z_\Lambda(\tau).

What this integrator does differently from ``method="exact"`` (same event rules, same
certified search, same contact sets (54)):

* **No modal round trip at an impact.**  The modal amplitudes are the state between
  events.  When the next call starts where the previous one stopped, on the same free
  set, the post-event amplitudes are a rank-:math:`k` correction of the propagated ones,
  :math:`\underline a^+ = \alpha\,\underline c_w + V^{-1}_{:,K}\,(\underline w^+ - \alpha\underline w^-)_K`
  with :math:`\alpha \in \{1, -e\}` chosen so that :math:`K` (the nodes the impact
  rule did not map by :math:`w \mapsto \alpha w`) is smallest: a point impact (54) of
  :math:`k` nodes costs :math:`O(nk)`, and a contact set holding every free node (a flat
  region) is :math:`\underline a^+ = -e\,\underline c_w` exactly, so a flat layer stays
  flat to round-off instead of accumulating projection errors event after event.
  The heights stay nodal (:math:`\underline\zeta_F(t_c)` is never projected).
* **O(n) single-node evaluations.**  The root polish is a safeguarded Newton iteration
  on one candidate: its value and slope are one row of :math:`V` against the modal
  coefficients (:math:`\zeta_j' = w_j`; for a stuck node, the two lattice neighbours of
  :math:`a_j = g + (\underline L\underline w)_j`).
* **Work per free set, once.**  The forcing part of the derivative bounds, the modal
  data and the banded rows of :math:`\underline L` (at most three entries per row on
  a one-dimensional lattice) are built once per free set and cached; products with
  :math:`\underline L` use the band, not a dense matrix.
* **Exact uniform forcing.**  With no stuck node :math:`\underline\sigma_F` is a null vector
  of :math:`\underline L_{FF}`, so gravity forces the zero modes only; the round-off
  projections of :math:`V^{-1}\underline\sigma_F` on the other modes are dropped, and the
  derivative bounds of a zero mode use :math:`|g| \le 1 + 1/\Gamma`, :math:`|g^{(p)}| \le 1`
  instead of the general factor :math:`(m + 1)(1 + 1/\Gamma)` (larger safe steps).

Cost: a search step is one product with ``[V | P]`` (heights and velocities of all free
nodes) and one with :math:`|V|` (the bounds), two BLAS calls of :math:`O(n^2)` flops; the
event itself is the rank-:math:`k` update (:math:`O(nk)`), a polish of :math:`O(n)` per
Newton step, and the shared contact-set rule :func:`~.events.event_sets`.  A new free set
(sticking, lift-off) costs one decomposition (cached) and one projection.

Contact search (docs/design.md, hazard 4 and 5)
-----------------------------------------------
The search is the certified rule of ``method="exact"``: with :math:`A_j \ge |f_j''|`
for every later time (the modal derivative bounds), no zero of a candidate
:math:`f_j` (height of a free node, minus the free acceleration of a stuck node) lies
in :math:`(t, t + h_j)` where :math:`f_j + f_j'h - A_jh^2/2 > 0`, so no crossing --
single or double -- is stepped over; a candidate is bracketed once it is certified
strictly decreasing up to its root bound, the earliest root is polished to
:math:`10^{-15}` in the local time, and every candidate reaching zero within
``time_tol`` of it joins the contact set (54).
"""
import math
from collections import OrderedDict

import numpy as np

from ..flight import phi2_expm1
from .base import Integrator, Step
from .events import event_sets
from .exact import Modes, candidate_group

__all__ = ["PointIntegrator"]

_EPS = np.finfo(float).eps


class _Band:
    """Rows of a sparse matrix as padded (column, value) pairs: O(nnz) products.

    Parameters
    ----------
    M : ndarray of float, shape (m, k)
    """

    def __init__(self, M):
        m = M.shape[0]
        rows, cols = np.nonzero(M)
        count = np.bincount(rows, minlength=m)
        width = int(count.max(initial=0))
        start = np.concatenate(([0], np.cumsum(count)[:-1]))
        slot = np.arange(rows.size) - start[rows]
        self.cols = np.zeros((m, width), dtype=np.int64)
        self.vals = np.zeros((m, width))
        self.cols[rows, slot] = cols
        self.vals[rows, slot] = M[rows, cols]
        self.abs_vals = np.abs(self.vals)

    def dot(self, x):
        """``M @ x`` for ``x`` of shape (k,)."""
        return (self.vals * x[self.cols]).sum(axis=1)

    def absdot(self, x):
        """``|M| @ x``."""
        return (self.abs_vals * x[self.cols]).sum(axis=1)


class _FreeSet:
    """Everything of one free set that does not depend on the state (cached)."""

    def __init__(self, lattice, free, Gamma):
        md = Modes(lattice, free)
        self.modes = md
        self.F, self.S = md.index, md.stuck
        self.nf = md.index.size
        self.lam, self.abs_lam = md.lam, md.abs_lam
        self.V, self.Vinv, self.absV = md.V, md.Vinv, md.absV
        s = md.s.copy()
        L_FF = md.L_FF
        # with no stuck neighbour (zero row sums of L_FF) sigma_F is a null vector of L_FF, so
        # gravity forces the zero modes only: the other projections of V^{-1} 1 are round-off
        if np.all(np.abs(L_FF.sum(axis=1)) <= 64 * _EPS * np.abs(L_FF).sum(axis=1)):
            s[self.lam != 0.0] = 0.0
        forced = np.zeros(self.nf, dtype=bool)
        forced[md.forced] = True
        s[~forced] = 0.0
        self.s = s
        self.zero_only = bool(np.all(self.lam[s != 0.0] == 0.0))
        self.zero = (self.lam == 0.0).astype(float)
        self.lam_safe = np.where(self.lam == 0.0, 1.0, self.lam)
        res = np.zeros(self.nf, dtype=complex)
        res[forced] = 1.0 / (1j - self.lam[forced])
        self.s_re, self.s_im = s * res.real, s * res.imag
        # [V | V (s Re r) | V (s Im r) | V s / Gamma]: the scalar-coefficient part of the flight
        self.VP = np.column_stack((self.V, self.V @ np.column_stack((self.s_re, self.s_im, s / Gamma))))
        G = 1.0 + 1.0 / Gamma
        big = np.maximum(1.0, self.abs_lam)
        abs_s = np.abs(s)
        zero = self.lam == 0.0
        # time-independent forcing part of the derivative bounds D_1, D_2, D_3: the m-th derivative
        # of s W_lam is bounded by (m + 1) G max(1, |lam|)^(m-1) |s| (|g^(p)| <= G = 1 + 1/Gamma), and
        # for a zero mode W^(m) = g^(m-1) exactly, so by G |s| (m = 1) and |s| (m >= 2)
        factors = [np.where(zero, G if m == 1 else 1.0, (m + 1) * G * big ** (m - 1)) for m in (1, 2, 3)]
        self.forcing = md.absV @ np.column_stack([fm * abs_s for fm in factors])
        # [|V| |lam|; |V| lam^2] @ (e^{lam tau} |a|) = (D_1, D_2) without the forcing part
        self.absV_lam12 = np.vstack((self.absV * self.abs_lam, self.absV * self.abs_lam ** 2))
        self.forcing_T = np.ascontiguousarray(self.forcing[:, :2].T)
        self.L_FF = _Band(md.L_FF)
        self.L_SF = _Band(md.L_SF)


class _Segment:
    r"""Closed-form flight (55)-(56) of one free set from ``t_c``, O(n) per evaluated node.

    With :math:`r = 1/(i - \lambda)` and :math:`e^{it_c}r\,s = u + iv` per mode, the forced
    response of :func:`~.exact.forced_response` is

    .. math::
        s\mathcal W &= u\sin\tau - v\,\mathrm{vers}\,\tau - v(e^{\lambda\tau} - 1)
                      - \frac{s}{\Gamma}\tau\varphi_1(\lambda\tau),\\
        s\mathcal Z &= u\,\mathrm{vers}\,\tau + v\sin\tau - v\,\tau\varphi_1
                      - \frac{s}{\Gamma}\tau^2\varphi_2(\lambda\tau),

    :math:`\mathrm{vers}\,\tau = 1 - \cos\tau = 2\sin^2(\tau/2)` (no cancellation at
    small :math:`\tau`, which keeps the root polish convergent).  The terms with scalar
    coefficients go through the per-free-set columns :math:`V(s\,\mathrm{Re}\,r)`,
    :math:`V(s\,\mathrm{Im}\,r)`, :math:`Vs/\Gamma`, rotated by :math:`t_c`, so one
    evaluation is one product with ``[V | P]``; when gravity forces zero modes only
    (no stuck node) all forcing terms are of that kind.
    """

    def __init__(self, fs, a, zeta0, t_c, Gamma):
        self.fs, self.a, self.zeta0, self.t_c = fs, a, zeta0, t_c
        c, sn = math.cos(t_c), math.sin(t_c)
        # (u, v) = rotation of (s Re r, s Im r) by t_c
        self.cs = (c, sn)
        self.u = c * fs.s_re - sn * fs.s_im
        self.v = sn * fs.s_re + c * fs.s_im
        self.q = fs.s / Gamma
        self.a_v = a - self.v
        self.zero_only = fs.zero_only
        self._memo = (None, None, None)

    def coefficients(self, tau):
        """``(M, e^{lam tau})``: ``[V | P] @ M`` is ``(w_F, zeta_F - zeta_F(t_c))`` at ``tau``."""
        if self._memo[0] == tau:
            return self._memo[1:]
        fs = self.fs
        nf = fs.nf
        z = fs.lam * tau
        em1 = np.expm1(z)
        expo = em1 + 1.0
        p1 = em1 / fs.lam_safe + fs.zero * tau              # tau phi_1(lam tau)
        st = math.sin(tau)
        vers = 2.0 * math.sin(0.5 * tau) ** 2
        M = np.empty((nf + 3, 2))
        c, sn = self.cs
        if self.zero_only:
            M[:nf, 0] = expo * self.a
            M[:nf, 1] = p1 * self.a
            zv, zq = st - tau, -0.5 * tau * tau
            M[nf:] = ((c * st - sn * vers, c * vers + sn * zv), (-sn * st - c * vers, -sn * vers + c * zv),
                      (-tau, zq))
        else:
            M[:nf, 0] = expo * self.a - self.v * em1 - self.q * p1
            M[:nf, 1] = p1 * self.a_v - self.q * (tau * tau * phi2_expm1(z, em1))
            M[nf:] = ((c * st - sn * vers, c * vers + sn * st), (-sn * st - c * vers, -sn * vers + c * st),
                      (0.0, 0.0))
        self._memo = (tau, M, expo)
        return M, expo

    def velocity_amplitudes(self, tau):
        """Modal amplitudes of ``w_F`` at ``tau`` (the state carried to the next segment)."""
        M, _ = self.coefficients(tau)
        st = math.sin(tau)
        vers = 2.0 * math.sin(0.5 * tau) ** 2
        cw = M[:self.fs.nf, 0] + self.u * st - self.v * vers
        if self.zero_only:                  # q is supported on zero modes: q tau phi_1 = q tau
            cw = cw - self.q * tau
        return cw

    def state(self, tau):
        """``(w_F, zeta_F, e^{lam tau})`` at local time ``tau``."""
        M, expo = self.coefficients(tau)
        WZ = self.fs.VP @ M
        return WZ[:, 0], self.zeta0 + WZ[:, 1], expo


class PointIntegrator(Integrator):
    r"""Point impacts (54) with exact modal flights, O(n) per impact (impulsive method).

    Between events the free nodes follow the closed form (55)-(56) of the free
    sub-lattice (53); see the module docstring for the certified contact search
    and for how the modal amplitudes are carried across impacts.  The driver
    applies the impact rule, sticking and lift-off to each returned
    :class:`~.base.Step`.

    Parameters
    ----------
    lattice : Lattice
    Gamma : float
        Plate acceleration, > 0.
    e : float
        Restitution in [0, 1).
    time_tol : float, optional
        Simultaneity window of a contact set (54) and floor of the safe step
        (default 1e-12).
    max_steps : int, optional
        Bound on search steps between two events; exceeding it raises
        ``RuntimeError`` (default 200000).
    cache_size : int, optional
        Number of free-set decompositions kept (default 64).

    Attributes
    ----------
    n_steps : int
        Search steps taken.
    n_decompositions : int
        Free-set decompositions built.
    n_projections : int
        Segments started by a full projection :math:`V^{-1}\underline w_F` (new
        free set or a state not produced by this integrator); every other
        segment started from a rank-k update.

    Examples
    --------
    A flat layer hits the plate once per period, every node in one contact set:

    >>> import numpy as np
    >>> import tps_solver as tps
    >>> fl = tps.FlatLayer(Gamma=2.5, M=2, e=0.45)
    >>> lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    >>> t = fl.t0 + 1.0
    >>> w, z = np.full(5, fl.velocity(t)), np.full(5, fl.height(t))
    >>> step = PointIntegrator(lat, 2.5, 0.45).advance(t, w, z, np.zeros(5, bool), t + fl.period)
    >>> step.contact
    array([0, 1, 2, 3, 4])
    >>> bool(abs(step.t - (fl.t0 + fl.period)) < 1e-13)
    True
    """

    name = "point"
    impulsive = True
    OPTIONS = {"time_tol": 1e-12, "max_steps": 200000, "cache_size": 64}

    def __init__(self, lattice, Gamma, e, **options):
        super().__init__(lattice, Gamma, e, **options)
        self.time_tol = float(self.options["time_tol"])
        self.max_steps = int(self.options["max_steps"])
        self._cache_size = int(self.options["cache_size"])
        if not self.time_tol > 0.0:
            raise ValueError(f"time_tol must be a finite number > 0, got {self.time_tol!r}")
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be an integer >= 1, got {self.max_steps!r}")
        if self._cache_size < 1:
            raise ValueError(f"cache_size must be an integer >= 1, got {self._cache_size!r}")
        self._cache = OrderedDict()
        self.n_decompositions = 0
        self.n_projections = 0
        # absolute time until which a node released at rest is exempt from contact detection
        self._guard = np.full(lattice.n_nodes, -np.inf)
        # (t, free-set key, returned w_F, modal velocity amplitudes at t) of the last call
        self._carry = None

    # --------------------------------------------------------------- free sets
    def _free_set(self, free):
        key = np.packbits(free).tobytes()
        fs = self._cache.get(key)
        if fs is None:
            fs = _FreeSet(self.lattice, free, self.Gamma)
            self.n_decompositions += 1
            self._cache[key] = fs
            if len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return key, fs

    def _amplitudes(self, t, key, fs, wF):
        """Modal velocity amplitudes of ``wF``: a rank-k update of the carried state if possible."""
        carry = self._carry
        if carry is not None and carry[0] == t and carry[1] == key:
            w_prev, c_prev = carry[2], carry[3]
            moved = wF != w_prev
            flipped = wF != -self.e * w_prev
            n1, n2 = np.count_nonzero(moved), np.count_nonzero(flipped)
            if n1 <= n2:
                a = c_prev.copy()
                if n1:
                    K = np.flatnonzero(moved)
                    a += fs.Vinv[:, K] @ (wF[K] - w_prev[K])
            else:
                a = -self.e * c_prev
                if n2:
                    K = np.flatnonzero(flipped)
                    a += fs.Vinv[:, K] @ (wF[K] + self.e * w_prev[K])
            return a
        self.n_projections += 1
        return fs.Vinv @ wF

    # ------------------------------------------------------- modal evaluation
    def _row_value(self, seg, j, tau):
        """Candidate ``j`` and its slope at ``tau`` (height of free row j, or minus a stuck
        acceleration): one row of ``V`` against the modal coefficients, O(n)."""
        fs = seg.fs
        M, _ = seg.coefficients(tau)
        if j < fs.nf:
            wz = fs.VP[j] @ M
            return seg.zeta0[j] + wz[1], wz[0]
        k = j - fs.nf
        t = seg.t_c + tau
        g = math.sin(t) - 1.0 / self.Gamma
        cols, vals = fs.L_SF.cols[k], fs.L_SF.vals[k]
        acc = g + vals @ (fs.VP[cols] @ M[:, 0])
        # w' = V (lam c_w + g s)
        dacc = math.cos(t) + vals @ (fs.V[cols] @ (fs.lam * seg.velocity_amplitudes(tau) + g * fs.s))
        return -acc, -dacc

    # ------------------------------------------------------------------ step
    def advance(self, t, w, zeta, stuck, t_stop, t_eval=()):
        """Propagate from ``t`` to the next contact or lift-off set, or to ``t_stop``.

        Parameters
        ----------
        t : float
        w, zeta : ndarray of float, shape (n_nodes,)
            Post-event state at ``t``.
        stuck : ndarray of bool, shape (n_nodes,)
        t_stop : float
        t_eval : ndarray of float
            Sorted output times; those in ``(t, t_new]`` are sampled.

        Returns
        -------
        Step
            ``t`` (event time or ``t_stop``), the pre-event ``w`` and ``zeta``, the
            contact set (54), the lift-off set and the samples.

        Raises
        ------
        RuntimeError
            After ``max_steps`` search steps without an event (grazing contact).
        """
        Gamma, time_tol = self.Gamma, self.time_tol
        free = ~np.asarray(stuck, dtype=bool)
        key, fs = self._free_set(free)
        F, S, nf = fs.F, fs.S, fs.nf
        n = w.size
        wF, zeta0 = w[F].astype(float), zeta[F].astype(float)
        a = self._amplitudes(t, key, fs, wF)
        abs_a = np.abs(a)
        has_stuck = S.size > 0
        t_eval = np.asarray(t_eval, dtype=float)
        samples = []
        t0 = t
        tau = 0.0
        tau_stop = t_stop - t0
        floor = 16 * _EPS * max(1.0, abs(t0) + abs(t_stop))
        zF = zeta0
        g0 = math.sin(t0) - 1.0 / Gamma
        accF = fs.L_FF.dot(wF) + g0
        eps_w = 64 * _EPS * (1.0 + np.abs(wF).max(initial=0.0))
        eps_z = 64 * _EPS * (1.0 + np.abs(zF).max(initial=0.0) + np.abs(wF).max(initial=0.0))
        at_plate = (zF == 0.0) & (np.abs(wF) <= eps_w)
        if at_plate.any():
            # released stuck nodes (a = 0, da/dt > 0): certified for 3 (da/dt) / D_3, and exempted
            # from contact detection until their height exceeds the modal round-off (a guard)
            eps_a = 64 * _EPS * (1.0 + abs(g0) + fs.L_FF.absdot(np.abs(wF)))
            jerk = fs.L_FF.dot(accF) + math.cos(t0)
            C = fs.absV @ (fs.abs_lam ** 3 * abs_a) + fs.forcing[:, 2]
            rel = at_plate & (jerk > 0.0) & (np.abs(accF) <= eps_a + time_tol * jerk)
            delay = np.maximum(-accF[rel], 0.0) / jerk[rel]
            self._guard[F[rel]] = t0 + delay + np.maximum(3.0 * jerk[rel] / C[rel],
                                                          np.cbrt(6.0 * eps_z / jerk[rel]))
        release = self._guard[F] - t0
        guarded = bool((release > 0.0).any())
        fv, dv = np.empty((2, nf)), np.empty((2, nf))
        seg = _Segment(fs, a, zeta0, t0, Gamma)
        steps = 0
        while True:
            steps += 1
            if steps > self.max_steps:
                self.n_steps += steps - 1
                raise RuntimeError(f"contact search made {self.max_steps} steps without an event "
                                   f"near t = {t0 + tau:.15g} (grazing contact?)")
            t_now = t0 + tau
            if tau > 0.0:
                wF, zF, expo = seg.state(tau)
                decay = expo * abs_a
            else:
                decay = abs_a
            g = math.sin(t_now) - 1.0 / Gamma
            accF = fs.L_FF.dot(wF) + g
            AB = (fs.absV_lam12 @ decay).reshape(2, nf) + fs.forcing_T
            A, B = AB[0], AB[1]
            # safe steps of the heights (row 0) and, for rising nodes (w >= 0 to round-off), of
            # the velocities' lower bound (row 1): one pass over both
            fv[0], fv[1] = zF, wF
            dv[0], dv[1] = wF, accF
            h2 = _safe_step(fv, dv, AB)
            h_contact = np.maximum(h2[0], np.where(wF >= -eps_w, h2[1], 0.0))
            if guarded:
                h_contact = np.maximum(h_contact, release - tau)
            if has_stuck:
                # lift-off candidates: f = -a for stuck nodes
                accS = g + fs.L_SF.dot(wF)
                daccS = math.cos(t_now) + fs.L_SF.dot(accF)
                CS = 1.0 + fs.L_SF.absdot(B)
                f = np.concatenate((zF, -accS))
                fp = np.concatenate((wF, -daccS))
                Abound = np.concatenate((A, CS))
                h = np.concatenate((h_contact, _safe_step(-accS, -daccS, CS)))
            else:
                f, fp, Abound, h = zF, wF, A, h_contact
            if h.size == 0:
                m, hm = 0, math.inf
            else:
                m = int(np.argmin(h))
                hm = float(h[m])
            if tau + hm >= tau_stop:
                self._sample(seg, tau, tau_stop, t_eval, samples, n)
                self.n_steps += steps
                if tau_stop > 0.0:
                    wF, zF, _ = seg.state(tau_stop)
                self._carry = (t_stop, key, wF, seg.velocity_amplitudes(max(tau_stop, 0.0)))
                wo, zo = _full(F, n, wF, zF)
                return Step(t_stop, wo, zo, np.empty(0, np.int64), np.empty(0, np.int64), samples)
            event = None
            if fp[m] < 0.0 and fp[m] ** 2 >= 2.5 * Abound[m] * max(f[m], 0.0):
                event = self._bracket(seg, f, fp, Abound, h, tau, m)
            if event is None and hm <= floor:
                event = tau + hm
            if event is not None:
                self._sample(seg, tau, event, t_eval, samples, n)
                self.n_steps += steps
                out = self._finish(seg, key, event, n, samples)
                if out.contact.size == 0 and out.liftoff.size == 0:     # guarantee progress
                    if m < nf:
                        out.contact = F[[m]]
                    else:
                        out.liftoff = S[[m - nf]]
                return out
            self._sample(seg, tau, tau + hm, t_eval, samples, n)
            tau += hm

    # ------------------------------------------------------------ internals
    def _sample(self, seg, tau_a, tau_b, t_eval, samples, n):
        if t_eval.size == 0:
            return
        t0 = seg.t_c
        sel = (t_eval > t0 + tau_a) & (t_eval <= t0 + tau_b)
        for te in t_eval[sel]:
            wF, zF, _ = seg.state(te - t0)
            samples.append((float(te),) + _full(seg.fs.F, n, wF, zF))

    def _values(self, seg, tau, group):
        """Candidates ``group`` (free rows, then stuck rows) at local time ``tau``."""
        fs, zeta0, t0 = seg.fs, seg.zeta0, seg.t_c
        M, _ = seg.coefficients(tau)
        out = np.empty(group.size)
        isf = group < fs.nf
        rows = group[isf]
        out[isf] = zeta0[rows] + fs.VP[rows] @ M[:, 1]
        if not isf.all():
            k = group[~isf] - fs.nf
            cols, vals = fs.L_SF.cols[k], fs.L_SF.vals[k]
            wn = (fs.VP[cols.ravel()] @ M[:, 0]).reshape(cols.shape)
            g = math.sin(t0 + tau) - 1.0 / self.Gamma
            out[~isf] = -(g + (vals * wn).sum(axis=1))
        return out

    def _bracket(self, seg, f, fp, A, h, tau, m):
        """Monotone brackets for the leading candidates; None if not all certified."""
        fpos = np.maximum(f, 0.0)
        disc = fp * fp - 2.0 * A * fpos
        ok = (fp < 0.0) & (fp * fp >= 2.5 * A * fpos)
        with np.errstate(invalid="ignore", divide="ignore"):
            upper = np.where(ok, 2.0 * fpos / (-fp + np.sqrt(np.maximum(disc, 0.0))), np.inf)
        group = candidate_group(h, upper, ok, m)
        if group is None:
            return None
        # earliest root: start from the smallest Newton estimate, then repair order
        newton = fpos[group] / -fp[group]
        lead = int(group[np.argmin(newton)])
        tau_c = self._root(seg, lead, tau, tau + upper[lead], f[lead], fp[lead])
        if group.size == 1:
            return tau_c
        for _ in range(group.size):
            vals = self._values(seg, tau_c, group)
            early = vals < -self.time_tol * np.abs(fp[group]) - 64 * _EPS
            if not early.any():
                break
            j = int(group[np.argmin(vals / -fp[group])])
            tau_c = self._root(seg, j, tau, tau_c, f[j], fp[j])
        return tau_c

    def _root(self, seg, j, lo, hi, flo, dlo):
        """Root of candidate ``j``, strictly decreasing on [lo, hi] (``flo``, ``dlo``: value, slope at lo).

        Safeguarded Newton (bisection whenever an iterate leaves the bracket), O(n) per iteration;
        stops when the Newton correction is below ``1e-15 + 4 eps |tau|`` (brentq's tolerance in
        ``method="exact"``) or the bracket is that narrow.
        """
        if flo <= 0.0:
            return lo
        x, fx, dx = lo, flo, dlo
        for _ in range(200):
            tol = 1e-15 + 4 * _EPS * abs(x)
            if dx < 0.0:
                step = -fx / dx
                if abs(step) <= tol:
                    return min(max(x + step, lo), hi)
                xn = x + step
                if not lo < xn < hi:
                    xn = 0.5 * (lo + hi)
            else:
                xn = 0.5 * (lo + hi)
            fx, dx = self._row_value(seg, j, xn)
            if fx == 0.0:
                return xn
            if fx > 0.0:
                lo = xn
            else:
                hi = xn
            if hi - lo <= tol:
                return xn
            x = xn
        return x

    def _finish(self, seg, key, tau_c, n, samples):
        """State at the event and the simultaneous sets (54)."""
        fs, a, zeta0, t0 = seg.fs, seg.a, seg.zeta0, seg.t_c
        F, S = fs.F, fs.S
        wF, zF, _ = seg.state(tau_c)
        t_c = t0 + tau_c
        g = math.sin(t_c) - 1.0 / self.Gamma
        eps_z = 64 * _EPS * (1.0 + np.abs(zeta0) + fs.absV @ np.abs(a) * max(1.0, tau_c))
        eps_a = 64 * _EPS * (1.0 + abs(g) + fs.L_SF.absdot(np.abs(wF)))
        contact, liftoff = event_sets(t_c, wF, zF, F, S, fs.modes.L_FF, fs.modes.L_SF, self.Gamma,
                                      self.time_tol, eps_z, eps_a)
        contact = contact[self._guard[contact] <= t_c]
        self._carry = (t_c, key, wF, seg.velocity_amplitudes(tau_c))
        wo, zo = _full(F, n, wF, zF)
        return Step(t_c, wo, zo, contact, liftoff, samples)


def _full(F, n, wF, zF):
    w = np.zeros(n)
    z = np.zeros(n)
    w[F] = wF
    z[F] = zF
    return w, z


def _safe_step(f, fp, A):
    r"""Largest h with :math:`f + f'h - Ah^2/2 > 0` on (0, h) (0 where f <= 0 and f' <= 0).

    ``A > 0``.  Uses :math:`h = 2f/(\sqrt{f'^2 + 2Af} + |f'|)` for :math:`f' < 0` (no
    cancellation) and :math:`(f' + \sqrt{f'^2 + 2Af})/A` otherwise.
    """
    f2 = 2.0 * np.maximum(f, 0.0)
    root = np.sqrt(fp * fp + A * f2)
    return np.where(fp >= 0.0, (fp + root) / A, f2 / (root + np.abs(fp) + 1e-300))
