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
  on one candidate: its value and slope are two rows of the evaluation matrix ``K``
  below against the same vector (:math:`\zeta_j' = w_j`; for a stuck node, minus
  :math:`a_j = g + (\underline L\underline w)_j` and its time derivative).
* **Work per free set, once.**  The forcing part of the derivative bounds, the modal
  data, the banded rows of :math:`\underline L` (at most three entries per row on a
  one-dimensional lattice) and the templates of the evaluation matrix below are built once
  per free set and cached.
* **One product per search step.**  Every quantity the search needs -- velocities,
  heights, free accelerations :math:`\underline L_{FF}\underline w_F + g`, the derivative
  bounds :math:`D_1, D_2` and, with stuck nodes, their accelerations, jerks and bounds --
  is a fixed linear combination of :math:`e^{\lambda\tau} - 1`
  (:math:`\tau^2\varphi_2(\lambda\tau)`) and a few scalars of :math:`\tau`, so it is one
  row of a matrix ``K`` built per segment (:class:`_Segment`), and a step is ``K @ y(tau)``
  plus the safe-step formula on three contiguous slices of the result: a dozen numpy calls,
  which is what a step costs on a small lattice.
* **Repeated searches in one product.**  Each segment leaves the natural ends
  :math:`\tau_i + h_i` of its search steps (moved earlier by :math:`(i + 1)10^{-11}(1 + \tau)`)
  as a proposal for the next segment of its free set; once two consecutive segments propose
  the same points (a periodic orbit), the next search evaluates all proposed points in one
  product ``K @ Y`` and walks through them while each lies within the certified step of the
  one before (otherwise it continues step by step from there), so the certificate and the
  event rules are unchanged.
* **Exact uniform forcing.**  With no stuck node :math:`\underline\sigma_F` is a null vector
  of :math:`\underline L_{FF}`, so gravity forces the zero modes only; the round-off
  projections of :math:`V^{-1}\underline\sigma_F` on the other modes are dropped, and the
  derivative bounds of a zero mode use :math:`|g| \le 1 + 1/\Gamma`, :math:`|g^{(p)}| \le 1`
  instead of the general factor :math:`(m + 1)(1 + 1/\Gamma)` (larger safe steps).

Cost: a search step is one product of ``K`` (:math:`5n_F` rows, :math:`3n_F + 3n_S` with
stuck nodes, by :math:`n_F + 9` columns; :math:`2n_F + 9` when gravity also forces
non-zero modes) with a vector, :math:`O(n^2)` flops; a segment costs the scaling of the
per-free-set templates by the modal amplitudes (:math:`O(n^2)`); the event itself is the
rank-:math:`k` update (:math:`O(nk)`), a polish of :math:`O(n)` per Newton step (two rows
of ``K``), and the shared contact-set rule :func:`~.events.event_sets`.  A new free set
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
``time_tol`` of it joins the contact set (54).  The bounds are evaluated as
:math:`(|V||\lambda|^m\,\mathrm{diag}|a|)(e^{\lambda\tau} - 1) + |V||\lambda|^m|a| + F_m`
(one product with the rest of ``K``); their constant part is enlarged by the relative
round-off of that sum, so the computed bound is not below the exact one.
"""
import math
from collections import OrderedDict

import numpy as np

from tps_solver.core import jit
from tps_solver.model.flight import phi2_expm1
from tps_solver.solvers.fda.base import Integrator, Step
from tps_solver.solvers.fda.events import event_sets
from tps_solver.solvers.fda.exact import Modes

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
    """Everything of one free set that does not depend on the state (cached).

    Besides the modal data it holds the layout of the fused evaluation matrix of
    :class:`_Segment` (one product per search step): the rows are, for the free set
    without stuck nodes, ``[a_F, w_F, zeta_F, 2 D_2, 2 D_1]`` and otherwise
    ``[w_F, zeta_F, -a_S, a_F, w_F, -a_S', 2 D_2, 2 D_1, 2 C_S]`` (``a`` free accelerations,
    ``D`` the derivative bounds, ``C_S`` the bound of ``|a_S''|``), so that the values ``f``,
    slopes ``f'`` and doubled bounds ``2A`` of the velocity rows (first ``nf``) and of the
    candidates (heights, then minus the stuck accelerations) are three contiguous slices.
    The columns multiply ``y = [e^{lam tau} - 1, (tau^2 phi_2(lam tau)), sigma_1, sigma_2,
    zeta_1, zeta_2, zeta_3, tau, g, cos t, 1]`` (:meth:`_Segment.y`).
    """

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
        self.q = s / Gamma
        self.q_ls = self.q / self.lam_safe
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
        self._layout()
        # search points proposed by the last segment of this free set (see PointIntegrator.advance)
        # (used once two consecutive segments proposed the same points)
        self.proposal, self.confirmed, self.last_root = None, False, None

    def _layout(self):
        """Row offsets, column indices and the state-independent parts of the fused matrix."""
        nf, nS = self.nf, self.S.size
        self.nS = nS
        L = 2 * nf + nS
        self.L = L
        if nS == 0:
            self.r_acc, self.r_w, self.r_B = 0, nf, 3 * nf
            self.f_off, self.fp_off, self.A_off = nf, 0, 3 * nf
            n_rows = 5 * nf
        else:
            self.r_w, self.r_acc, self.r_B = 0, L, 2 * L
            self.f_off, self.fp_off, self.A_off = 0, L, 2 * L
            n_rows = 3 * L
        self.r_z = self.r_w + nf
        b = nf if self.zero_only else 2 * nf
        self.b = b
        # scalar columns: sigma_1, sigma_2, tau, zeta_1, zeta_2, zeta_3, g, cos t, 1
        self.c_tau, self.c_g, self.c_cos, self.c_one = b + 2, b + 6, b + 7, b + 8
        self.ncol = b + 9
        self.inflate = 1.0 + 4.0 * self.ncol * _EPS
        V, P = self.V, self.VP[:, nf:]
        L_FF, L_SF = self.modes.L_FF, self.modes.L_SF
        # the modal (E) columns: per row block, a template scaled per segment by the coefficients
        # of e^{lam tau} - 1 of the velocities ('w'), of the heights ('z') or by |a| ('abs')
        LV = L_FF @ V
        T_B2 = 2.0 * self.absV * self.abs_lam ** 2
        T_A2 = 2.0 * self.absV * self.abs_lam
        K = np.zeros((n_rows, self.ncol))
        TE = np.zeros((n_rows, nf))
        rw, rz, ra, rB = self.r_w, self.r_z, self.r_acc, self.r_B
        Kw, Kz, Ka = K[rw:rw + nf], K[rz:rz + nf], K[ra:ra + nf]
        TE[rw:rw + nf], TE[rz:rz + nf], TE[ra:ra + nf] = V, V / self.lam_safe, LV
        TE[rB:rB + nf], TE[rB + nf:rB + 2 * nf] = T_B2, T_A2
        Kw[:, b], Kw[:, b + 1], Kw[:, b + 2] = P[:, 0], P[:, 1], V @ (-self.q * self.zero)
        Kz[:, b + 3], Kz[:, b + 4] = P[:, 0], P[:, 1]
        if self.zero_only:
            Kz[:, b + 5] = P[:, 2]
        else:
            Kz[:, nf:2 * nf] = V * -self.q
        Ka[:] = L_FF @ Kw
        Ka[:, self.c_g] = 1.0
        fixed = np.zeros(n_rows)                      # constant parts of the last column
        fixed[rB:rB + 2 * nf] = 2.0 * np.concatenate((self.forcing[:, 1], self.forcing[:, 0]))
        if nS:
            r_s = 2 * nf
            K[r_s:r_s + nS] = -(L_SF @ Kw)
            K[r_s:r_s + nS, self.c_g] = -1.0
            TE[r_s:r_s + nS] = -(L_SF @ V)
            K[L + nf:L + 2 * nf], TE[L + nf:L + 2 * nf] = Kw, V
            K[L + r_s:L + r_s + nS] = -(L_SF @ Ka)
            K[L + r_s:L + r_s + nS, self.c_cos] = -1.0
            TE[L + r_s:L + r_s + nS] = -(L_SF @ LV)
            # 2 C_S = 2 (1 + |L_SF| D_2) >= 2 |a_S''| = 2 |-sin t + L_SF w''|
            TE[2 * L + r_s:] = self.modes.absL_SF @ T_B2
            fixed[2 * L + r_s:] = self.modes.absL_SF @ fixed[rB:rB + nf] + 2.0
            blocks = [(0, nf, "w"), (nf, 2 * nf, "z"), (2 * nf, 2 * L, "w"), (2 * L, 3 * L, "abs")]
        else:
            blocks = [(0, 2 * nf, "w"), (2 * nf, 3 * nf, "z"), (3 * nf, 5 * nf, "abs")]
        if self.zero_only:                             # the same coefficients a for 'w' and 'z'
            blocks = [(r0, r1, "w" if kind == "z" else kind) for r0, r1, kind in blocks]
        for M in (K, TE):
            M[np.abs(M) < 1e-300] = 0.0               # no sub-normal arithmetic in the products
        merged = []
        for r0, r1, kind in blocks:
            if merged and merged[-1][2] == kind and merged[-1][1] == r0:
                merged[-1] = (merged[-1][0], r1, kind)
            else:
                merged.append((r0, r1, kind))
        self.blocks = merged
        self.abs_rows = slice(rB, n_rows)
        # the per-segment columns (modal block, tau column of the heights, last column) are
        # overwritten by each _Segment: one live segment per free set (the integrator's case)
        self.K, self.TE, self.fixed = K, TE, fixed
        self.TE_abs = TE[rB:]
        self.fixed_abs = fixed[rB:]
        # modal velocity amplitudes: a + (e^{lam tau} - 1) c_w + [s Re r, s Im r, -q] (sigma_1, sigma_2, tau)
        self.Sm = np.column_stack((self.s_re, self.s_im, -self.q * self.zero))


class _Segment:
    r"""Closed-form flight (55)-(56) of one free set from ``t_c``: one matrix product per evaluation.

    With :math:`r = 1/(i - \lambda)` and :math:`e^{it_c}r\,s = u + iv` per mode, the forced
    response of :func:`~.exact.forced_response` is

    .. math::
        s\mathcal W &= u\sin\tau - v\,\mathrm{vers}\,\tau - v(e^{\lambda\tau} - 1)
                      - \frac{s}{\Gamma}\tau\varphi_1(\lambda\tau),\\
        s\mathcal Z &= u\,\mathrm{vers}\,\tau + v\sin\tau - v\,\tau\varphi_1
                      - \frac{s}{\Gamma}\tau^2\varphi_2(\lambda\tau),

    :math:`\mathrm{vers}\,\tau = 1 - \cos\tau = 2\sin^2(\tau/2)` (no cancellation at
    small :math:`\tau`, which keeps the root polish convergent), and
    :math:`\tau\varphi_1(\lambda\tau) = (e^{\lambda\tau} - 1)/\lambda` (:math:`\tau` for a zero
    mode).  Every term is a per-segment vector times one of the scalars or of the vectors
    :math:`e^{\lambda\tau} - 1`, :math:`\tau^2\varphi_2(\lambda\tau)` of :meth:`y`, so the
    matrix ``K`` (rows: see :class:`_FreeSet`), built once per segment from per-free-set
    templates, gives the velocities, heights, free accelerations
    :math:`\underline L_{FF}\underline w_F + g`, the derivative bounds :math:`2D_2, 2D_1`
    (the decaying part :math:`|V||\lambda|^m e^{\lambda\tau}|a|` is
    :math:`(|V||\lambda|^m\,\mathrm{diag}|a|)(e^{\lambda\tau} - 1) + |V||\lambda|^m|a|`) and the
    stuck-node candidates as ``K @ y(tau)``.
    """

    def __init__(self, fs, a, zeta0, t_c, Gamma):
        self.fs, self.a, self.zeta0, self.t_c = fs, a, zeta0, t_c
        c, sn = math.cos(t_c), math.sin(t_c)
        self.cs = (c, sn)
        self.q = fs.q
        self.inv_gamma = 1.0 / Gamma
        self.zero_only = fs.zero_only
        nf, one = fs.nf, fs.c_one
        abs_a = np.abs(a)
        self.abs_a = abs_a
        if fs.zero_only:
            cz = cw = a
        else:
            cz = a - (sn * fs.s_re + c * fs.s_im)       # a - v
            cw = cz - fs.q_ls
        self.cw = cw
        K = fs.K
        TE = fs.TE
        for r0, r1, kind in fs.blocks:
            np.multiply(TE[r0:r1], cw if kind == "w" else cz if kind == "z" else abs_a, out=K[r0:r1, :nf])
        K[:, one] = TE @ a
        rB = fs.r_B
        K[rB:, one] = (fs.TE_abs @ abs_a + fs.fixed_abs) * fs.inflate
        r_z = fs.r_z
        K[r_z:r_z + nf, one] = zeta0
        K[r_z:r_z + nf, fs.c_tau] = fs.V @ (fs.zero * cz)
        self.K = K
        self._y = np.empty(fs.ncol)
        self._yE = self._y[:nf]
        self._ys = self._y[fs.b:fs.b + 3]
        self._tau = None
        self._out_tau, self._out = None, None

    def y(self, tau):
        """The column vector of ``K`` at local time ``tau`` (a buffer, overwritten by the next call)."""
        if tau == self._tau:
            return self._y
        fs = self.fs
        y, E = self._y, self._yE
        st = math.sin(tau)
        vers = 2.0 * math.sin(0.5 * tau) ** 2
        c, sn = self.cs
        if self.zero_only:
            np.multiply(fs.lam, tau, out=E)
            np.expm1(E, out=E)
            zv = st - tau
        else:
            z = fs.lam * tau
            np.expm1(z, out=E)
            y[fs.nf:fs.b] = (tau * tau) * phi2_expm1(z, E)
            zv = st
        t = self.t_c + tau
        y[fs.b:] = (c * st - sn * vers, -sn * st - c * vers, tau, c * vers + sn * zv, -sn * vers + c * zv,
                    -0.5 * tau * tau, math.sin(t) - self.inv_gamma, math.cos(t), 1.0)
        self._tau = tau
        return y

    def evaluate(self, tau):
        """``K @ y(tau)``: all rows (see :class:`_FreeSet`) at local time ``tau`` (the last one is kept)."""
        if tau != self._out_tau:
            self._out = self.K @ self.y(tau)
            self._out_tau = tau
        return self._out

    def evaluate_many(self, taus):
        """``K @ Y`` with the columns ``y(tau)`` for the local times ``taus`` (a list), shape (rows, k)."""
        fs = self.fs
        nf, b = fs.nf, fs.b
        k = len(taus)
        Y = np.empty((fs.ncol, k))
        z = np.multiply.outer(fs.lam, taus)
        np.expm1(z, out=Y[:nf])
        if not self.zero_only:
            Y[nf:b] = np.square(taus) * phi2_expm1(z, Y[:nf])
        c, sn = self.cs
        cols = []
        for tau in taus:
            st = math.sin(tau)
            vers = 2.0 * math.sin(0.5 * tau) ** 2
            zv = st - tau if self.zero_only else st
            t = self.t_c + tau
            cols.append((c * st - sn * vers, -sn * st - c * vers, tau, c * vers + sn * zv, -sn * vers + c * zv,
                         -0.5 * tau * tau, math.sin(t) - self.inv_gamma, math.cos(t), 1.0))
        Y[b:] = np.array(cols).T
        return self.K @ Y

    def velocity_amplitudes(self, tau):
        """Modal amplitudes of ``w_F`` at ``tau`` (the state carried to the next segment).

        :math:`\\underline c_w = \\underline a + (e^{\\lambda\\tau} - 1)\\underline c + s\\,\\mathrm{Re}\\,r\\,
        \\sigma_1 + s\\,\\mathrm{Im}\\,r\\,\\sigma_2 - q\\tau` (``q`` on the zero modes), with
        :math:`\\sigma_1 = \\cos t_c\\sin\\tau - \\sin t_c\\,\\mathrm{vers}\\,\\tau`,
        :math:`\\sigma_2 = -\\sin t_c\\sin\\tau - \\cos t_c\\,\\mathrm{vers}\\,\\tau`
        (:math:`u\\sin\\tau - v\\,\\mathrm{vers}\\,\\tau` regrouped).
        """
        self.y(tau)                         # fills _yE = e^{lam tau} - 1 and _ys
        cw = self._yE * self.cw
        cw += self.a
        cw += self.fs.Sm @ self._ys
        return cw

    def state(self, tau):
        """``(w_F, zeta_F, e^{lam tau})`` at local time ``tau``."""
        out = self.evaluate(tau)
        fo, nf = self.fs.f_off, self.fs.nf
        return out[fo:fo + nf], out[fo + nf:fo + 2 * nf], self._yE + 1.0


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
    compiled : bool or None, optional
        Run the contact search as one compiled kernel
        (:mod:`~tps_solver.solvers.fda.point_kernels`, the ``fast`` extra); ``None`` (default):
        where numba is installed (:func:`tps_solver.core.jit.enabled`).  ``False`` is the numpy
        reference path.  The two find the same events (times to ~1e-15).

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
    OPTIONS = {"time_tol": 1e-12, "max_steps": 200000, "cache_size": 64, "compiled": None}

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
        self.compiled = jit.compiled_option(self.options["compiled"])
        self._kernels = None
        if self.compiled:
            from tps_solver.solvers.fda import point_kernels
            self._kernels = point_kernels
        self._cache = OrderedDict()
        self.n_decompositions = 0
        self.n_projections = 0
        # absolute time until which a node released at rest is exempt from contact detection
        self._guard = np.full(lattice.n_nodes, -np.inf)
        self._guard_max = -math.inf
        # (t, free-set key, returned w_F, modal velocity amplitudes at t) of the last call
        self._carry = None

    # --------------------------------------------------------------- free sets
    def _free_set(self, stuck):
        key = stuck.tobytes()
        fs = self._cache.get(key)
        if fs is None:
            fs = _FreeSet(self.lattice, ~stuck, self.Gamma)
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
            if not isinstance(self.e, float):          # a speed-dependent law: no common factor
                moved = wF != w_prev
                a = c_prev.copy()
                if moved.any():
                    K = np.flatnonzero(moved)
                    a += fs.Vinv[:, K] @ (wF[K] - w_prev[K])
                return a
            flipped = wF != -self.e * w_prev
            n2 = np.count_nonzero(flipped)
            if n2 == 0 and wF.any():
                # every node mapped by w -> -e w (a flat contact set): fewer than n1 >= 1 moved
                return -self.e * c_prev
            moved = wF != w_prev
            n1 = np.count_nonzero(moved)
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
        key, fs = self._free_set(np.asarray(stuck, dtype=bool))
        F, nf = fs.F, fs.nf
        n = w.size
        if fs.nS:
            wF, zeta0 = np.asarray(w[F], dtype=float), np.asarray(zeta[F], dtype=float)
        else:
            wF, zeta0 = np.asarray(w, dtype=float), np.asarray(zeta, dtype=float)
        a = self._amplitudes(t, key, fs, wF)
        t_eval = np.asarray(t_eval, dtype=float)
        samples = []
        t0 = t
        tau = 0.0
        tau_stop = t_stop - t0
        floor = 16 * _EPS * max(1.0, abs(t0) + abs(t_stop))
        g0 = math.sin(t0) - 1.0 / Gamma
        seg = _Segment(fs, a, zeta0, t0, Gamma)
        abs_w = np.abs(wF)
        eps_w = 64 * _EPS * (1.0 + float(abs_w.max(initial=0.0)))
        at_plate = abs_w <= eps_w
        nodal = bool(at_plate.any())
        if nodal:
            at_plate &= zeta0 == 0.0
            nodal = bool(at_plate.any())
        if nodal:
            # released stuck nodes (a = 0, da/dt > 0): certified for 3 (da/dt) / D_3, and exempted
            # from contact detection until their height exceeds the modal round-off (a guard)
            accF = fs.L_FF.dot(wF) + g0
            eps_z = 64 * _EPS * (1.0 + np.abs(zeta0).max(initial=0.0) + float(abs_w.max(initial=0.0)))
            eps_a = 64 * _EPS * (1.0 + abs(g0) + fs.L_FF.absdot(abs_w))
            jerk = fs.L_FF.dot(accF) + math.cos(t0)
            C = fs.absV @ (fs.abs_lam ** 3 * seg.abs_a) + fs.forcing[:, 2]
            rel = at_plate & (jerk > 0.0) & (np.abs(accF) <= eps_a + time_tol * jerk)
            if rel.any():
                delay = np.maximum(-accF[rel], 0.0) / jerk[rel]
                guard = t0 + delay + np.maximum(3.0 * jerk[rel] / C[rel], np.cbrt(6.0 * eps_z / jerk[rel]))
                self._guard[F[rel]] = guard
                self._guard_max = max(self._guard_max, float(guard.max()))
        guarded = self._guard_max > t0
        if guarded:
            release_half = 0.5 * (self._guard[F] - t0)
        fo, po, Ao, L = fs.f_off, fs.fp_off, fs.A_off, fs.L
        steps = 0
        # natural ends tau + h of the search steps (the proposal for the next segment of this
        # free set: on a periodic orbit it is the same search, evaluated in one product)
        ends = []
        batch = None
        if self._kernels is not None:
            return self._compiled_search(seg, key, fs, wF, zeta0, g0, nodal, guarded,
                                         release_half if guarded else None, eps_w, t_stop, tau_stop, floor,
                                         t_eval, samples, n)
        if fs.confirmed and not nodal and not guarded:
            taus = [0.0] + [p for p in fs.proposal if p < tau_stop]
            if len(taus) >= 3:
                batch = _Batch(seg, taus, eps_w)
        i = 0
        while True:
            steps += 1
            if steps > self.max_steps:
                self.n_steps += steps - 1
                raise RuntimeError(f"contact search made {self.max_steps} steps without an event "
                                   f"near t = {t0 + tau:.15g} (grazing contact?)")
            if batch is not None:
                f, fp, A2, hh = batch.f[:, i], batch.fp[:, i], batch.A2[:, i], batch.hh[:, i]
                hc = hh[nf:]
                m, hm = batch.m[i], batch.hm[i]
            else:
                if tau > 0.0 or not nodal:
                    out = seg.evaluate(tau)
                    f, fp, A2 = out[fo:fo + L], out[po:po + L], out[Ao:Ao + L]
                else:
                    # a node at rest on the plate: its exact nodal zeros, not V a (round-off)
                    f, fp, A2 = _start_rows(seg, wF, zeta0, g0)
                # half safe steps of the velocity rows (first nf) and of the candidates (heights,
                # then minus the stuck accelerations); a rising node (w >= 0 to round-off) is safe
                # while either its height or its velocity's lower bound is
                hh = _half_step(f, fp, A2)
                hc = hh[nf:]
                hz = hh[nf:2 * nf]
                np.maximum(hz, hh[:nf], out=hz, where=f[:nf] >= -eps_w)
                if guarded:
                    np.maximum(hz, release_half - 0.5 * tau, out=hz)
                if hc.size == 0:
                    m, hm = 0, math.inf
                else:
                    m = int(hc.argmin())
                    hm = 2.0 * float(hc[m])
            if tau + hm >= tau_stop:
                self._sample(seg, tau, tau_stop, t_eval, samples, n)
                self.n_steps += steps
                return self._stop(seg, key, wF, zeta0, t_stop, tau_stop, n, samples)
            event = None
            fm, fpm = float(f[nf + m]), float(fp[nf + m])
            if fpm < 0.0 and fpm * fpm >= 1.25 * (float(A2[nf + m]) * max(fm, 0.0)):
                # on a repeated segment the last root is the polish's first iterate
                hint = fs.last_root if batch is not None else None
                event = self._bracket(seg, f[nf:], fp[nf:], A2[nf:], hc, tau, m, hint)
            if event is None and hm <= floor:
                event = tau + hm
            if event is not None:
                self._sample(seg, tau, event, t_eval, samples, n)
                self.n_steps += steps
                new = _proposal(ends)
                if batch is None:       # a repeated search confirms the proposal
                    fs.confirmed = _same_points(new, fs.proposal)
                elif i + 1 < batch.k:   # the proposal went past the event
                    fs.confirmed = False
                fs.proposal = new
                fs.last_root = event
                out = self._finish(seg, key, event, n, samples)
                if out.contact.size == 0 and out.liftoff.size == 0:     # guarantee progress
                    if m < nf:
                        out.contact = F[[m]]
                    else:
                        out.liftoff = fs.S[[m - nf]]
                return out
            nxt = tau + hm
            ends.append(nxt)
            if batch is not None:
                i += 1
                if i < batch.k and batch.taus[i] <= nxt:       # certified up to the next point
                    nxt = batch.taus[i]
                else:
                    fs.confirmed = False
                    batch = None
            self._sample(seg, tau, nxt, t_eval, samples, n)
            tau = nxt

    def _compiled_search(self, seg, key, fs, wF, zeta0, g0, nodal, guarded, release_half, eps_w, t_stop,
                         tau_stop, floor, t_eval, samples, n):
        """The search loop of :meth:`advance` as one kernel call (:func:`.point_kernels.search`)."""
        kn = self._kernels
        first = _start_rows(seg, wF, zeta0, g0) if nodal else None
        status, tau, m, steps, ends = kn.search(seg, eps_w, tau_stop, floor, self.max_steps, self.time_tol,
                                                first, release_half)
        self.n_steps += int(min(steps, self.max_steps))
        F = fs.F
        if status == kn.TOO_MANY_STEPS:
            raise RuntimeError(f"contact search made {self.max_steps} steps without an event "
                               f"near t = {seg.t_c + tau:.15g} (grazing contact?)")
        if status == kn.STOP:
            self._sample(seg, 0.0, tau_stop, t_eval, samples, n)
            return self._stop(seg, key, wF, zeta0, t_stop, tau_stop, n, samples)
        self._sample(seg, 0.0, tau, t_eval, samples, n)
        fs.proposal, fs.last_root = _proposal(list(ends)), tau
        out = self._finish(seg, key, tau, n, samples)
        if out.contact.size == 0 and out.liftoff.size == 0:     # guarantee progress
            if m < fs.nf:
                out.contact = F[[m]]
            else:
                out.liftoff = fs.S[[m - fs.nf]]
        return out

    def _stop(self, seg, key, wF, zeta0, t_stop, tau_stop, n, samples):
        """The Step of a segment that reached ``t_stop`` without an event."""
        if tau_stop > 0.0:
            wF, zF, _ = seg.state(tau_stop)
        else:
            wF, zF = np.array(wF), zeta0
        self._carry = (t_stop, key, wF, seg.velocity_amplitudes(max(tau_stop, 0.0)))
        wo, zo = _full(seg.fs.F, n, wF, zF)
        return Step(t_stop, wo, zo, np.empty(0, np.int64), np.empty(0, np.int64), samples)

    # ------------------------------------------------------------ internals
    def _sample(self, seg, tau_a, tau_b, t_eval, samples, n):
        if t_eval.size == 0:
            return
        t0 = seg.t_c
        sel = (t_eval > t0 + tau_a) & (t_eval <= t0 + tau_b)
        for te in t_eval[sel]:
            wF, zF, _ = seg.state(te - t0)
            samples.append((float(te),) + _full(seg.fs.F, n, wF, zF))

    def _bracket(self, seg, f, fp, A2, hh, tau, m, hint=None):
        """Monotone brackets for the leading candidates; None if not all certified.

        ``f, fp, A2``: values, slopes and doubled bounds of the candidates, ``hh`` their half
        safe steps, ``m`` the smallest; ``hint``: a first iterate for the polish of the lead
        candidate (used if inside its bracket).  The group is :func:`~.exact.candidate_group` (every
        candidate whose safe step is below the largest certified root bound of the group,
        grown until closed).
        """
        fpos = np.maximum(f, 0.0)
        fp2 = fp * fp
        Af = A2 * fpos
        ok = fp < 0.0
        ok &= fp2 >= 1.25 * Af                           # f'^2 >= 2.5 A f, as the caller's test of m
        root = fp2 - Af
        np.maximum(root, 0.0, out=root)
        np.sqrt(root, out=root)
        root -= fp
        # root bounds of the certified candidates (only those are read: a group with an
        # uncertified member returns None first)
        upper = np.empty(f.size)
        np.divide(2.0 * fpos, root, out=upper, where=ok)
        if not ok[m]:
            return None
        span = float(upper[m])
        while True:
            group = np.flatnonzero(hh < 0.5 * span)
            if group.size == 0:
                group = np.array([m])
            if not ok[group].all():
                return None
            new_span = float(upper[group].max())
            if new_span <= span or group.size == hh.size:   # closed (or nothing left to add)
                break
            span = new_span
        # earliest root: start from the smallest Newton estimate, then repair order
        fpg = fp[group]
        lead = int(group[int((fpos[group] / -fpg).argmin())])
        tau_c = self._root(seg, lead, tau, tau + float(upper[lead]), float(f[lead]), float(fp[lead]), hint)
        if group.size == 1:
            return tau_c
        threshold = -self.time_tol * np.abs(fpg) - 64 * _EPS
        rows = seg.fs.f_off + seg.fs.nf + group
        for _ in range(group.size):
            vals = seg.evaluate(tau_c)[rows]        # the state at tau_c is _finish's too
            if not (vals < threshold).any():
                break
            j = int(group[int((vals / -fpg).argmin())])
            tau_c = self._root(seg, j, tau, tau_c, float(f[j]), float(fp[j]))
        return tau_c

    def _root(self, seg, j, lo, hi, flo, dlo, hint=None):
        """Root of candidate ``j``, strictly decreasing on [lo, hi] (``flo``, ``dlo``: value, slope at lo).

        Safeguarded Newton (bisection whenever an iterate leaves the bracket), O(n) per iteration
        (two rows of the segment matrix), from ``hint`` if it lies in (lo, hi), else from ``lo``;
        stops when the Newton correction is below ``1e-15 + 4 eps |tau|`` (brentq's tolerance in
        ``method="exact"``) or the bracket is that narrow.
        """
        if flo <= 0.0:
            return lo
        fs = seg.fs
        rows = seg.K[[fs.f_off + fs.nf + j, fs.fp_off + fs.nf + j]]
        x, fx, dx = lo, flo, dlo
        first = hint if hint is not None and lo < hint < hi else None
        for _ in range(200):
            tol = 1e-15 + 4 * _EPS * abs(x)
            if first is not None:
                xn, first = first, None
            elif dx < 0.0:
                step = -fx / dx
                if abs(step) <= tol:
                    return min(max(x + step, lo), hi)
                xn = x + step
                if not lo < xn < hi:
                    xn = 0.5 * (lo + hi)
            else:
                xn = 0.5 * (lo + hi)
            v = rows @ seg.y(xn)
            fx, dx = float(v[0]), float(v[1])
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
        fs, zeta0, t0 = seg.fs, seg.zeta0, seg.t_c
        F, S = fs.F, fs.S
        wF, zF, _ = seg.state(tau_c)
        t_c = t0 + tau_c
        g = math.sin(t_c) - 1.0 / self.Gamma
        eps_z = 64 * _EPS * (1.0 + np.abs(zeta0) + fs.absV @ seg.abs_a * max(1.0, tau_c))
        if fs.nS:
            eps_a = 64 * _EPS * (1.0 + abs(g) + fs.L_SF.absdot(np.abs(wF)))
        else:
            eps_a = 64 * _EPS * (1.0 + abs(g))
        contact, liftoff = event_sets(t_c, wF, zF, F, S, fs.modes.L_FF, fs.modes.L_SF, self.Gamma,
                                      self.time_tol, eps_z, eps_a, absL_FF=fs.modes.absL_FF)
        if self._guard_max > t_c:
            contact = contact[self._guard[contact] <= t_c]
        self._carry = (t_c, key, wF, seg.velocity_amplitudes(tau_c))
        wo, zo = _full(F, n, wF, zF)
        return Step(t_c, wo, zo, contact, liftoff, samples)


class _Batch:
    """The search rows at proposed points ``taus`` (one product ``K @ Y``) and their safe steps.

    Attributes ``f, fp, A2, hh`` (shape (L, k)) are :func:`_half_step`'s inputs and output per
    column, ``m`` and ``hm`` (lists) each column's smallest candidate and its (full) step.
    """

    def __init__(self, seg, taus, eps_w):
        fs = seg.fs
        nf, L = fs.nf, fs.L
        self.taus, self.k = taus, len(taus)
        out = seg.evaluate_many(taus)
        fo, po, Ao = fs.f_off, fs.fp_off, fs.A_off
        self.f, self.fp, self.A2 = out[fo:fo + L], out[po:po + L], out[Ao:Ao + L]
        hh = _half_step(self.f, self.fp, self.A2)
        hz = hh[nf:2 * nf]
        np.maximum(hz, hh[:nf], out=hz, where=self.f[:nf] >= -eps_w)
        hc = hh[nf:]
        m = hc.argmin(axis=0)
        self.hh = hh
        self.hm = (2.0 * hc[m, np.arange(self.k)]).tolist()
        self.m = m.tolist()


def _proposal(ends):
    """Search points for the next segment of a free set: the natural ends ``tau + h`` of this
    one, each moved earlier by ``(i + 1) 1e-11 (1 + tau)`` so that on a repeated (periodic)
    segment every proposed point lies within the certified step of the one before it."""
    if len(ends) < 2:
        return None
    return [e - (i + 1) * 1e-11 * (1.0 + e) for i, e in enumerate(ends)]


def _same_points(a, b):
    """Whether two proposals agree to 1e-9 (relative): the segment repeats."""
    if a is None or b is None or len(a) != len(b):
        return False
    return all(abs(x - y) <= 1e-9 * (1.0 + abs(y)) for x, y in zip(a, b))


def _start_rows(seg, wF, zeta0, g0):
    """``(f, f', 2A)`` of :func:`_half_step` at the segment start from the nodal state.

    Using the nodal values (not ``V a``) keeps a node released at rest exactly at
    ``w = zeta = 0``; the bounds at ``tau = 0`` are the constant column of the bound rows.
    """
    fs = seg.fs
    accF = fs.L_FF.dot(wF) + g0
    A2 = seg.K[fs.A_off:fs.A_off + fs.L, fs.c_one]
    if fs.nS:
        t0 = seg.t_c
        accS = g0 + fs.L_SF.dot(wF)
        daccS = math.cos(t0) + fs.L_SF.dot(accF)
        return np.concatenate((wF, zeta0, -accS)), np.concatenate((accF, wF, -daccS)), A2
    return np.concatenate((wF, zeta0)), np.concatenate((accF, wF)), A2


def _full(F, n, wF, zF):
    if F.size == n:
        return np.array(wF), np.array(zF)
    w = np.zeros(n)
    z = np.zeros(n)
    w[F] = wF
    z[F] = zF
    return w, z


def _half_step(f, fp, A2):
    r"""Half the largest h with :math:`f + f'h - Ah^2/2 > 0` on (0, h), given ``A2 = 2A > 0``.

    0 where f <= 0 and f' <= 0.  With :math:`q = \sqrt{f'^2 + 2Af} + |f'|` (no cancellation)
    the step is :math:`h = 2f/q` for :math:`f' < 0` and :math:`q/A` otherwise, so
    :math:`h/2 = f/q` or :math:`q/(2A)` (one operation fewer; halving is exact).
    """
    fpos = np.maximum(f, 0.0)
    q = fp * fp
    q += A2 * fpos
    np.sqrt(q, out=q)
    q += np.abs(fp)
    h = q / A2
    np.divide(fpos, q, out=h, where=fp < 0.0)
    return h
