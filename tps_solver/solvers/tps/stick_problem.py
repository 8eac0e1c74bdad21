r"""The impact-and-stick TPS problem: the all-orders lattice kernel and the residual of a contact pattern.

The formulation is the one of :mod:`tps_solver.solvers.tps.stick` (which solves it):
The eigen-decomposition of the Neumann lattice operator and the all-orders kernels are
:class:`~tps_solver.operators.modal.ModalBasis`, :func:`~tps_solver.operators.modal.kernel`
and :func:`~tps_solver.operators.modal.kernel_integral`; :class:`StickProblem` evaluates the
residual and Jacobian of the unknowns of a :class:`~tps_solver.solvers.tps.stick_pattern.StickPattern`.
:func:`flat_stick_orbit` reads the completely inelastic flat layer of
:mod:`tps_solver.model.sticking` in the TPS's alphabet.
"""
import math

import numpy as np
from numpy.polynomial.legendre import leggauss, legvander

from tps_solver.core import archive
from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_int, check_positive
from tps_solver.core.problem import Inadmissible, Problem
from tps_solver.model.sticking import sticking_orbit
from tps_solver.operators.modal import kernel, kernel_integral

__all__ = ["flat_stick_orbit"]

KINDS = ("bounce", "stick")
_COLLAPSE = 1e-10           # stick intervals shorter than this: an impact with w+ = 0
_BREAK_MARGIN = 1e-12      # neighbour events closer than this to an end do not cut a segment
_LIFT_MARGIN = 1e-6        # the same for a neighbour's lift-off (a kink of the reaction, not a jump: the
                           # polynomial's error from not cutting within this of an end is ~ margin^2)
_MEDIUM = 1e-6              # segments shorter than this: at most 2 reaction terms (was 1e-3: too coarse at dx = 0.5)
_COLL_SCALE = 1e-2          # collocated w = 0 is divided by max(segment length, this)
_BREAK_DISTANCE = 3          # cut stick intervals at events of nodes up to this graph distance
_SHORT = 1e-6               # shorter than this: one reaction term, balanced at the midpoint
_CHUNK = 2 ** 22            # elements of the (requests, segments, modes) temporaries per chunk


# ----------------------------------------------------------------- flat layer
def flat_stick_orbit(Gamma, M=2):
    r"""The completely inelastic flat layer (e = 0): contacts, kinds and lift-off, in closed form.

    Lift-off from rest at :math:`t_L` with :math:`\sin t_L = 1/\Gamma`,
    :math:`\cos t_L > 0`; flight (17) with :math:`W_0 = 0`,
    :math:`w = \cos t_L - \cos t - (t - t_L)/\Gamma`; a landing where
    :math:`g > 0` is a touch-and-go (a new flight from rest), the first landing
    where :math:`g \le 0` ends in sticking until the next lift-off phase.  This is the
    e = 0 :func:`tps_solver.model.sticking.sticking_orbit` (certified landings,
    :class:`tps_solver.model.flight.Flight`) read in the TPS's alphabet
    (:data:`KINDS`: a touch-and-go is a ``"bounce"`` with :math:`w^+ = 0`); an orbit whose
    period divides :math:`2\pi M` is repeated.

    Parameters
    ----------
    Gamma : float
        Plate acceleration, ``Gamma > 1`` (otherwise the layer never lifts off).
    M : int
        Subharmonic order; the orbit must close after ``M`` forcing cycles.

    Returns
    -------
    Bunch
        ``t_liftoff`` (float, in [0, 2 pi)), ``t`` (contact times, ndarray of float,
        shape (K,), increasing, in (t_L, t_L + T)), ``kind`` (ndarray of str, shape
        (K,)), ``w_minus`` (pre-impact velocities, shape (K,)), ``tau`` (lift-off
        after each contact, nan for a bounce), ``period``, ``Gamma``, ``M`` and ``orbit``
        (the :class:`~tps_solver.model.sticking.ContactOrbit`; its ``velocity(t)`` and
        ``height(t)``, zeta = 0 at the contacts, are the orbit's w and zeta), ``own_M`` (int: the
        orbit's own period is ``2 pi own_M``; ``own_M < M`` when it is repeated).

    Raises
    ------
    ValueError
        If ``Gamma <= 1`` or the e = 0 orbit does not close with period
        ``2 pi M`` (it has another period at this Gamma).

    Examples
    --------
    >>> orb = flat_stick_orbit(4.1, 2)
    >>> [str(k) for k in orb.kind], bool(abs(np.sin(orb.t_liftoff) - 1 / 4.1) < 1e-15)
    (['bounce', 'stick'], True)
    """
    Gamma = check_positive(Gamma, "Gamma")
    M = check_int(M, "M", minimum=1)
    if Gamma <= 1.0:
        raise ValueError(f"Gamma must be > 1 for the layer to lift off, got {Gamma}")
    T = 2 * math.pi * M
    orbit, info = sticking_orbit(Gamma, 0.0, M)
    k = M
    for d in range(M - 1, 0, -1):       # an orbit whose period divides 2 pi M, repeated
        if orbit is not None:
            break
        if M % d == 0:
            orbit, _ = sticking_orbit(Gamma, 0.0, d)
            k = d
    if orbit is None:
        raise ValueError(f"the e = 0 flat orbit at Gamma = {Gamma} does not close after "
                         f"M = {M} forcing cycles ({info})")
    ts, kinds, wm, taus = [], [], [], []
    for rep in range(M // k):
        shift = 2 * math.pi * k * rep
        for t, kind, w_minus, lift in orbit.landings():
            ts.append(t + shift)
            kinds.append("bounce" if kind == "touch" else kind)
            wm.append(w_minus)
            taus.append(lift + shift)
    return Bunch(t_liftoff=orbit.t0, t=np.array(ts), kind=np.array(kinds), w_minus=np.array(wm),
                 tau=np.array(taus), period=T, Gamma=Gamma, M=M, orbit=orbit, own_M=k)


# ------------------------------------------------------------------ patterns
class StickProblem(Problem):
    """Unknowns, requests and residual of the impact-and-stick TPS on a Neumann lattice.

    Unknowns ``x = [t (C), tau (S), J (C), coef]`` with ``theta = [t, tau]`` the times.
    Each stick interval is cut into *segments* at the impacts and lift-offs of its
    lattice neighbours that fall inside it (there the reaction jumps or kinks); every
    segment carries its own Legendre expansion of the reaction.  *Requests* are the
    values the equations need: ``w(t_c^-)`` ("minus"), the antiderivative ``W(t_c)``
    ("W"), ``w`` at the collocation points ("coll") and, on very short segments, the
    neighbours' ``w`` at the midpoint ("nbr").  Every request value is affine in ``J``
    and ``coef``: ``v = forcing + B_imp J + B_int coef + b_int.sum(1)``.
    """

    def __init__(self, modal, pattern, Gamma, e, n_basis, n_quad, margins=None):
        self.inputs = {"modal": modal, "pattern": pattern, "Gamma": Gamma, "e": e, "n_basis": n_basis,
                       "n_quad": n_quad}                                  # for the file codec
        # neighbour impacts / lift-offs closer than these to an end of a stick interval do not cut
        # it (the defaults resolve the reaction to rounding; coarser ones merge near-coincident
        # events, as the continuation of :mod:`tps_solver.solvers.tps.stick_discovery` does)
        self.break_margin, self.lift_margin = (_BREAK_MARGIN, _LIFT_MARGIN) if margins is None else margins
        if margins is not None:
            self.inputs["margins"] = tuple(float(m) for m in margins)
        self.m = modal
        self.p = pattern
        self.Gamma, self.e = Gamma, e
        self.T = T = pattern.period
        C = pattern.node.size
        self.C = C
        ell = pattern.tau - pattern.t
        is_stick = pattern.kind == "stick"
        # stick intervals below _COLLAPSE are an impact with w+ = 0 (their reaction impulse
        # ell |L w| is below ~1e-10)
        self.collapsed = is_stick & (ell < _COLLAPSE)
        self.stick = np.nonzero(is_stick & ~self.collapsed)[0]
        self.S = S = self.stick.size
        self.stick_of = np.full(C, -1)
        self.stick_of[self.stick] = np.arange(S)
        self.xq, self.wq = leggauss(n_quad)
        self.restit = np.where(pattern.kind == "bounce", 1.0 + e, 1.0)
        self.n_theta = C + S
        theta0 = np.concatenate([pattern.t, pattern.tau[self.stick]])
        A = modal.A
        nn = pattern.n_nodes
        # ---- segments: the reaction -(L w)_j jumps at a neighbour's impact and has weaker
        # singularities at events further away (graph distance d: impacts make a jump in the
        # (d-1)-th derivative, lift-offs one order weaker); cut at impacts with d <= 3 and
        # lift-offs with d <= 2
        adj = (A != 0) & ~np.eye(nn, dtype=bool)
        dist = np.full((nn, nn), 99)
        reach = np.eye(nn, dtype=bool)
        for d in range(1, _BREAK_DISTANCE + 1):
            reach = reach | (reach.astype(int) @ adj.astype(int) > 0)
            dist[(dist == 99) & reach] = d
        np.fill_diagonal(dist, 0)
        def canonical(idx, m):
            # a triggered lift-off *is* its trigger's impact (tau = t[trig] + shift T): the same
            # event, whatever the iterate
            if idx >= C:
                cc = self.stick[idx - C]
                if pattern.trigger[cc] >= 0:
                    return int(pattern.trigger[cc]), int(m + pattern.trigger_shift[cc])
            return int(idx), int(m)

        seg = []                      # (s, node, a_idx, a_shift, b_idx, b_shift)
        for s, c in enumerate(self.stick):
            j = pattern.node[c]
            a0, b0 = theta0[c], theta0[C + s]
            # the interval's own ends are never cuts, also where a neighbour event coincides
            # with them structurally (the impact that triggers this lift-off, a neighbour's
            # lift-off triggered by this landing) but not numerically at the initial iterate
            own = {(int(c), 0), canonical(C + s, 0)}
            pts = []
            for k in np.nonzero((dist[j, pattern.node] >= 1) & (dist[j, pattern.node] <= _BREAK_DISTANCE))[0]:
                cands = [(k, theta0[k])]
                if self.stick_of[k] >= 0 and dist[j, pattern.node[k]] < _BREAK_DISTANCE:
                    cands.append((C + self.stick_of[k], theta0[C + self.stick_of[k]]))
                for idx, tv in cands:
                    m = math.floor((a0 - tv) / T) + 1
                    while tv + m * T < b0:
                        tm = tv + m * T
                        key = canonical(idx, m)
                        margin = self.break_margin if key[0] < C else self.lift_margin
                        if key not in own and a0 + margin < tm < b0 - margin:
                            pts.append((tm, key[0], key[1]))
                        m += 1
            pts.sort()
            kept, seen = [], set()
            for tm, idx, m in pts:         # one cut per event (a triggered lift-off is its trigger)
                if (idx, m) in seen:
                    continue
                if not kept or tm - kept[-1][0] > self.break_margin:
                    kept.append((tm, idx, m))
                elif idx < C:
                    kept[-1] = (tm, idx, m)
                seen.add((idx, m))
            ends = [(c, 0)] + [(idx, m) for _, idx, m in kept] + [(C + s, 0)]
            for (ia, ma), (ib, mb) in zip(ends[:-1], ends[1:]):
                seg.append((s, j, ia, ma, ib, mb))
        self.G = len(seg)
        self.seg_s = np.array([g[0] for g in seg], dtype=int)
        self.seg_node = np.array([g[1] for g in seg], dtype=int)
        self.seg_a = np.array([g[2] for g in seg], dtype=int)
        self.seg_ash = np.array([g[3] for g in seg], dtype=float)
        self.seg_b = np.array([g[4] for g in seg], dtype=int)
        self.seg_bsh = np.array([g[5] for g in seg], dtype=float)
        lens = self.seg_ends(theta0)
        self.short = (lens[1] - lens[0]) < _SHORT
        seg_len = lens[1] - lens[0]
        self.nb = np.where(self.short, 1, np.where(seg_len < _MEDIUM, min(2, n_basis), n_basis)).astype(int)
        self.nbmax = int(self.nb.max()) if self.G else 1
        self.coef_off = np.concatenate([[0], np.cumsum(self.nb)]).astype(int)
        self.n_coef = int(self.coef_off[-1])
        self.last_seg = np.array([np.nonzero(self.seg_s == s)[0][-1] for s in range(S)], dtype=int)
        self.n_unknowns = self.n_theta + C + self.n_coef
        # ---- requests: (node, W, own, kind, ia, ca, ib, cb, const, seg)
        rows = []
        for c in range(C):
            rows.append((pattern.node[c], False, c, "minus", c, 1.0, -1, 0.0, 0.0, -1))
        for c in range(C):
            rows.append((pattern.node[c], True, -1, "W", c, 1.0, -1, 0.0, 0.0, -1))
        for g in range(self.G):
            j = self.seg_node[g]
            ia, ib, ma, mb = self.seg_a[g], self.seg_b[g], self.seg_ash[g], self.seg_bsh[g]
            if self.short[g]:
                for i in np.nonzero((A[j] != 0) & (np.arange(nn) != j))[0]:
                    rows.append((i, False, -1, "nbr", ia, 0.5, ib, 0.5, 0.5 * (ma + mb) * T, g))
            else:
                for xq in leggauss(self.nb[g])[0]:
                    ca, cb = (1 - xq) / 2, (1 + xq) / 2
                    rows.append((j, False, -1, "coll", ia, ca, ib, cb, (ca * ma + cb * mb) * T, g))
        self.rq_node = np.array([r[0] for r in rows], dtype=int)
        self.rq_W = np.array([r[1] for r in rows], dtype=bool)
        self.rq_own = np.array([r[2] for r in rows], dtype=int)
        self.rq_kind = np.array([r[3] for r in rows])
        self.rq_ia = np.array([r[4] for r in rows], dtype=int)
        self.rq_ca = np.array([r[5] for r in rows])
        self.rq_ib = np.array([r[6] for r in rows], dtype=int)
        self.rq_cb = np.array([r[7] for r in rows])
        self.rq_const = np.array([r[8] for r in rows])
        self.rq_g = np.array([r[9] for r in rows], dtype=int)
        self.E = len(rows)
        self.rows_of_theta = [np.nonzero((self.rq_ia == k) | (self.rq_ib == k))[0] for k in range(self.n_theta)]
        self.segs_of_theta = [np.nonzero((self.seg_a == k) | (self.seg_b == k))[0] for k in range(self.n_theta)]
        self.coll_rows = [np.nonzero((self.rq_g == g) & (self.rq_kind == "coll"))[0] for g in range(self.G)]
        self.nbr_rows = [np.nonzero((self.rq_g == g) & (self.rq_kind == "nbr"))[0] for g in range(self.G)]
        self.by_node = [np.nonzero(pattern.node == j)[0] for j in range(nn)]

    # --------------------------------------------------------------- packing
    def pack(self, t, tau_s, J, coef):
        return np.concatenate([t, tau_s, J, coef])

    def unpack(self, x):
        C, S = self.C, self.S
        return x[:C], x[C:C + S], x[C + S:2 * C + S], x[2 * C + S:]

    def initial(self):
        p = self.p
        return self.pack(p.t, p.tau[self.stick], p.J, np.zeros(self.n_coef))

    def seg_ends(self, theta, segs=None):
        segs = np.arange(self.G) if segs is None else segs
        return (theta[self.seg_a[segs]] + self.seg_ash[segs] * self.T,
                theta[self.seg_b[segs]] + self.seg_bsh[segs] * self.T)

    def request_times(self, theta, rows=None):
        rows = np.arange(self.E) if rows is None else np.asarray(rows, dtype=int)
        ib = self.rq_ib[rows]
        tb = np.where(ib >= 0, theta[np.maximum(ib, 0)], 0.0)
        return self.rq_ca[rows] * theta[self.rq_ia[rows]] + self.rq_cb[rows] * tb + self.rq_const[rows]

    # --------------------------------------------------------------- kernels
    def _impulse(self, req_node, req_time, req_W, req_own, imp, t, deriv=False):
        """R_{j,i}(tau) (or dR/dtau) for requests x impulses; shape (E, len(imp)) (in chunks of requests)."""
        E = req_node.size
        step = max(1, _CHUNK // max(1, imp.size * self.m.lam.size))
        if E <= step:
            return self._impulse_chunk(req_node, req_time, req_W, req_own, imp, t, deriv)
        out = np.empty((E, imp.size))
        for i in range(0, E, step):
            sl = slice(i, i + step)
            out[sl] = self._impulse_chunk(req_node[sl], req_time[sl], req_W[sl], req_own[sl], imp, t, deriv)
        return out

    def _impulse_chunk(self, req_node, req_time, req_W, req_own, imp, t, deriv=False):
        T, md = self.T, self.m
        tau = np.mod(req_time[:, None] - t[imp][None, :], T)
        tau = np.where(req_own[:, None] == imp[None, :], T, tau)
        out = np.empty(tau.shape)
        i = self.p.node[imp]
        for W in (False, True):
            r = np.nonzero(req_W == W)[0]
            if r.size == 0:
                continue
            kA = md.separable_table(W)[0]
            j = req_node[r]
            ex = np.exp(md.lam[None, None, :] * tau[r][:, :, None])        # (E, X, P)
            VA = md.V[j] * (kA * (md.lam if deriv else 1.0))[None, :]
            core = np.einsum("ep,exp,px->ex", VA, ex, md.Vinv[:, i])
            MB, MC, MD = md.separable_poly(W)
            tr = tau[r]
            if deriv:
                out[r] = core + MC[j][:, i] + 2 * MD[j][:, i] * tr
            else:
                out[r] = core + MB[j][:, i] + MC[j][:, i] * tr + MD[j][:, i] * tr * tr
        return out

    def _f_values(self, xi, s, nb):
        """Source values at points: Legendre P_0..P_{nb-1}(xi) padded, and -g(s) last."""
        Fv = np.zeros(s.shape + (self.nbmax + 1,))
        Fv[..., :self.nbmax] = legvander(xi, self.nbmax - 1)
        Fv[..., :self.nbmax] *= np.arange(self.nbmax) < np.reshape(nb, nb.shape + (1,) * (s.ndim - nb.ndim + 1))
        Fv[..., -1] = -(np.sin(s) - 1.0 / self.Gamma)
        return Fv

    def _intervals(self, req_node, req_time, req_W, segs, theta):
        """Responses of requests to segment sources; shape (E, len(segs), nbmax + 1).

        Evaluated in chunks of requests so that the (requests, segments, modes) temporaries
        stay below ~``_CHUNK`` elements (a 81-node kink has ~300 segments and 81 modes)."""
        E = req_node.size
        per = max(1, segs.size * self.m.lam.size)
        step = max(1, _CHUNK // per)
        if E <= step:
            return self._intervals_chunk(req_node, req_time, req_W, segs, theta)
        out = np.empty((E, segs.size, self.nbmax + 1))
        for i in range(0, E, step):
            sl = slice(i, i + step)
            out[sl] = self._intervals_chunk(req_node[sl], req_time[sl], req_W[sl], segs, theta)
        return out

    def _intervals_chunk(self, req_node, req_time, req_W, segs, theta):
        T, md = self.T, self.m
        E = req_node.size
        out = np.zeros((E, segs.size, self.nbmax + 1))
        if E == 0 or segs.size == 0:
            return out
        a, b = self.seg_ends(theta, segs)
        h = (b - a) / 2
        s = a[:, None] + h[:, None] * (1 + self.xq)[None, :]                 # (X, Q)
        wts = h[:, None] * self.wq[None, :]
        Fv = self._f_values(np.broadcast_to(self.xq, s.shape), s, self.nb[segs])
        u = b[:, None] - s
        i = self.seg_node[segs]
        tp = a[None, :] + np.mod(req_time[:, None] - a[None, :], T)           # (E, X) in [a, a+T)
        d = tp - b[None, :]
        inside = d < 0.0
        ex_u = np.exp(md.lam[None, None, :] * u[:, :, None])                 # (X, Q, P)
        mu = [np.einsum("xq,xqm->xm", wts * u ** k, Fv) for k in range(3)]
        dd = np.maximum(d, 0.0)
        for W in (False, True):
            r = np.nonzero(req_W == W)[0]
            if r.size == 0:
                continue
            kA = md.separable_table(W)[0]
            Gx = np.einsum("xq,xqp,xqm->xmp", wts, ex_u, Fv) * (kA[None, :] * md.Vinv[:, i].T)[:, None, :]
            j = req_node[r]
            ed = np.exp(md.lam[None, None, :] * dd[r][:, :, None])
            val = np.einsum("ep,exp,xmp->exm", md.V[j], ed, Gx)
            MB, MC, MD = md.separable_poly(W)
            mb, mc, mdd = MB[j][:, i][..., None], MC[j][:, i][..., None], MD[j][:, i][..., None]
            dr = dd[r][..., None]
            val += (mb * mu[0][None] + mc * (dr * mu[0][None] + mu[1][None])
                    + mdd * (dr ** 2 * mu[0][None] + 2 * dr * mu[1][None] + mu[2][None]))
            out[r] = val
        er, xr = np.nonzero(inside)
        if er.size:
            sq, wsq, tau, xi = self._split_quadrature(a[xr], b[xr], tp[er, xr])
            Fq = self._f_values(xi, sq, self.nb[segs][xr])
            jn, inode = req_node[er], i[xr]
            Rk = np.empty(tau.shape)
            for W in (False, True):
                m = req_W[er] == W
                if not np.any(m):
                    continue
                lt = (md.lam[None, None, :], tau[m][:, :, None], T)
                if W:   # the separable tables' antiderivative: zero-mean except the zero mode's (+T/12)
                    K = kernel_integral(*lt) + np.where(md.zero_modes(), T / 12.0, 0.0)
                else:
                    K = kernel(*lt, at_jump="right")
                coefp = md.V[jn[m]] * md.Vinv[:, inode[m]].T
                Rk[m] = np.einsum("np,nqp->nq", coefp, K)
            out[er, xr] = np.einsum("nq,nq,nqm->nm", Rk, wsq, Fq)
        return out

    def _split_quadrature(self, aa, bb, tt):
        """Gauss-Legendre on [a, t] and [t, b] for evaluation times t inside segments [a, b]
        (the kernel jumps at t): points, weights, kernel lags in (0, T) and Legendre abscissae,
        each of shape (pairs, 2 n_quad)."""
        xq, wq = self.xq, self.wq
        h1, h2 = (tt - aa) / 2, (bb - tt) / 2
        s1 = aa[:, None] + h1[:, None] * (1 + xq)
        s2 = tt[:, None] + h2[:, None] * (1 + xq)
        sq = np.concatenate([s1, s2], axis=1)
        wsq = np.concatenate([h1[:, None] * wq, h2[:, None] * wq], axis=1)
        lag = np.concatenate([tt[:, None] - s1, tt[:, None] - s2 + self.T], axis=1)
        xi = (2 * sq - (aa + bb)[:, None]) / (bb - aa)[:, None]
        return sq, wsq, lag, xi

    def _scatter(self, vals, segs):
        """(E, X, nbmax+1) -> B_int columns (E, sum nb[segs]) and b_int (E, X)."""
        cols = [vals[:, k, :self.nb[g]] for k, g in enumerate(segs)]
        B = np.concatenate(cols, axis=1) if cols else np.zeros((vals.shape[0], 0))
        return B, vals[:, :, -1]

    def _cols(self, segs):
        if len(segs) == 0:
            return np.zeros(0, dtype=int)
        return np.concatenate([np.arange(self.coef_off[g], self.coef_off[g + 1]) for g in segs])

    def evaluate(self, x, req_node, req_time, req_W, req_own=None):
        """Request values at arbitrary (node, time) pairs."""
        t, tau_s, J, coef = self.unpack(x)
        theta = x[:self.n_theta]
        own = np.full(req_node.size, -1) if req_own is None else req_own
        Bi = self._impulse(req_node, req_time, req_W, own, np.arange(self.C), t)
        Bn, bn = self._scatter(self._intervals(req_node, req_time, req_W, np.arange(self.G), theta),
                               np.arange(self.G))
        forcing = np.where(req_W, -np.sin(req_time), -np.cos(req_time))
        return forcing + Bi @ J + Bn @ coef + bn.sum(axis=1)

    def evaluate_nodes(self, x, times, integral=False):
        r"""Velocity (or its antiderivative) at every node for each of ``times``, shape (n_times, n_nodes).

        The values of :meth:`evaluate` for the requests (every node, each time), summed in the
        modal basis before the nodes are formed: every source is contracted with its
        coefficients first, so the cost is O(n_times (C + G) P + n_times P n) instead of
        :meth:`evaluate`'s n times that.  Agrees with :meth:`evaluate` to rounding: measured
        1.8e-14 (velocity, max 1.8) and 2.7e-12 (antiderivative, max 5.1) on the dx = 2 kink,
        where the antiderivative's low modes carry amplitudes ~ 1/(lambda^2 T) that cancel
        in both sums.
        """
        times = np.atleast_1d(np.asarray(times, dtype=float))
        t, tau_s, J, coef = self.unpack(x)
        theta = x[:self.n_theta]
        T, md, W = self.T, self.m, bool(integral)
        lam, V, Vinv = md.lam, md.V, md.Vinv
        kA = md.separable_table(W)[0]
        MB, MC, MD = md.separable_poly(W)
        ni = self.p.node
        # impulses: tau = mod(t_e - t_i, T) (the post-impact value at an impact instant)
        tau = np.mod(times[:, None] - t[None, :], T)                               # (E, C)
        modal = kA * np.einsum("eip,pi->ep", np.exp(lam[None, None, :] * tau[:, :, None]),
                               Vinv[:, ni] * J[None, :])
        node_vals = (MB[:, ni] @ J)[None, :] + (tau * J) @ MC[:, ni].T + (tau * tau * J) @ MD[:, ni].T
        if self.G:
            segs = np.arange(self.G)
            a, b = self.seg_ends(theta)
            h = (b - a) / 2
            s = a[:, None] + h[:, None] * (1 + self.xq)[None, :]
            wts = h[:, None] * self.wq[None, :]
            Fv = self._f_values(np.broadcast_to(self.xq, s.shape), s, self.nb)
            cc = np.zeros((self.G, self.nbmax + 1))                 # the coefficients, 1 for -g
            for g in segs:
                cc[g, :self.nb[g]] = coef[self.coef_off[g]:self.coef_off[g + 1]]
            cc[:, -1] = 1.0
            fc = np.einsum("xqm,xm->xq", Fv, cc)                  # the source at the nodes
            u = b[:, None] - s
            ix = self.seg_node
            Gc = np.einsum("xq,xqp->xp", wts * fc, np.exp(lam[None, None, :] * u[:, :, None])) * (kA[None, :] * Vinv[:, ix].T)
            mu = [np.sum(wts * u ** k * fc, axis=1) for k in range(3)]
            tp = a[None, :] + np.mod(times[:, None] - a[None, :], T)                # (E, X)
            d = tp - b[None, :]
            inside = d < 0.0
            out = ~inside
            dd = np.where(out, d, 0.0)
            modal += np.einsum("exp,xp->ep", np.exp(lam[None, None, :] * dd[:, :, None]) * out[:, :, None], Gc)
            o = out.astype(float)
            node_vals += ((o * mu[0]) @ MB[:, ix].T + (o * (dd * mu[0] + mu[1])) @ MC[:, ix].T
                          + (o * (dd * dd * mu[0] + 2 * dd * mu[1] + mu[2])) @ MD[:, ix].T)
            er, xr = np.nonzero(inside)
            if er.size:
                sq, wsq, tq, xi = self._split_quadrature(a[xr], b[xr], tp[er, xr])
                fq = np.einsum("nqm,nm->nq", self._f_values(xi, sq, self.nb[xr]), cc[xr])
                lt = (lam[None, None, :], tq[:, :, None], T)
                if W:
                    K = kernel_integral(*lt) + np.where(md.zero_modes(), T / 12.0, 0.0)
                else:
                    K = kernel(*lt, at_jump="right")
                pair = np.einsum("nq,nqp->np", wsq * fq, K) * Vinv[:, ix[xr]].T
                np.add.at(modal, er, pair)
        forcing = -np.sin(times) if W else -np.cos(times)
        return forcing[:, None] + modal @ V.T + node_vals

    def assemble(self, x):
        t = x[:self.C]
        theta = x[:self.n_theta]
        rt = self.request_times(theta)
        B_imp = self._impulse(self.rq_node, rt, self.rq_W, self.rq_own, np.arange(self.C), t)
        vals = self._intervals(self.rq_node, rt, self.rq_W, np.arange(self.G), theta)
        B_int, b_int = self._scatter(vals, np.arange(self.G))
        return dict(rt=rt, B_imp=B_imp, B_int=B_int, b_int=b_int)

    def values(self, x, st):
        t, tau_s, J, coef = self.unpack(x)
        rt = st["rt"]
        forcing = np.where(self.rq_W, -np.sin(rt), -np.cos(rt))
        return forcing + st["B_imp"] @ J + st["B_int"] @ coef + st["b_int"].sum(axis=1)

    def equations(self, x, v):
        """Residual from request values v and unknowns x (see the module docstring)."""
        t, tau_s, J, coef = self.unpack(x)
        theta = x[:self.n_theta]
        S, T, G, C = self.S, self.T, self.Gamma, self.C
        vm, vW = v[:C], v[C:2 * C]
        F = [J + self.restit * vm]
        zeta = [vW[idx[1:]] - vW[idx[:-1]] for idx in self.by_node if idx.size > 1]
        F.append(np.concatenate(zeta) if zeta else np.zeros(0))
        a, b = self.seg_ends(theta)
        ell = b - a
        F.append(self._local(coef, v, ell))
        lift = np.empty(S)
        for s, c in enumerate(self.stick):
            trig = self.p.trigger[c]
            if trig >= 0:
                lift[s] = tau_s[s] - (t[trig] + self.p.trigger_shift[c] * T)
            else:
                g = self.last_seg[s]
                lift[s] = np.sum(coef[self.coef_off[g]:self.coef_off[g + 1]]) - (math.sin(tau_s[s]) - 1.0 / G)
        F.append(lift)
        mean = np.zeros(self.p.n_nodes)
        np.add.at(mean, self.p.node, J)
        np.add.at(mean, self.seg_node, ell * coef[self.coef_off[:-1]])
        ta, tb = t[self.stick], tau_s
        np.add.at(mean, self.p.node[self.stick], -(np.cos(ta) - np.cos(tb) - (tb - ta) / G))
        F.append(mean - T / G)
        return np.concatenate(F)

    def _local(self, coef, v, ell):
        """The stick equations: collocated w = 0 (scaled), or a short segment's balance against its
        neighbours; ``v`` of shape (E,) or (E, K) (then ``coef`` (n_coef, K))."""
        A = self.m.A
        loc = []
        for g in range(self.G):
            if self.short[g]:
                r = self.nbr_rows[g]
                loc.append((coef[self.coef_off[g]] + A[self.seg_node[g], self.rq_node[r]] @ v[r])[None])
            else:
                loc.append(v[self.coll_rows[g]] / max(ell[g], _COLL_SCALE))
        return np.concatenate(loc) if loc else np.zeros((0,) + v.shape[1:])

    def linear_part(self, x, dlin, dv):
        """The change of :meth:`equations` for changes ``dlin`` of ``[J, coef]`` and ``dv`` of the
        request values, at the times of ``x``; shapes (n_linear, K), (E, K) -> (n_equations, K).

        :meth:`equations` is affine in ``J``, ``coef`` and ``v`` at fixed times, so this is exact
        (the linear columns of the Jacobian, all at once).
        """
        C = self.C
        theta = x[:self.n_theta]
        dJ, dc = dlin[:C], dlin[C:]
        K = dlin.shape[1]
        F = [dJ + self.restit[:, None] * dv[:C]]
        dW = dv[C:2 * C]
        zeta = [dW[idx[1:]] - dW[idx[:-1]] for idx in self.by_node if idx.size > 1]
        F.append(np.concatenate(zeta) if zeta else np.zeros((0, K)))
        a, b = self.seg_ends(theta)
        ell = b - a
        F.append(self._local(dc, dv, ell))
        lift = np.zeros((self.S, K))
        for s_, c in enumerate(self.stick):
            if self.p.trigger[c] < 0:
                g = self.last_seg[s_]
                lift[s_] = dc[self.coef_off[g]:self.coef_off[g + 1]].sum(axis=0)
        F.append(lift)
        mean = np.zeros((self.p.n_nodes, K))
        np.add.at(mean, self.p.node, dJ)
        np.add.at(mean, self.seg_node, ell[:, None] * dc[self.coef_off[:-1]])
        F.append(mean)
        return np.concatenate(F)

    def residual(self, x):
        st = self.assemble(x)
        v = self.values(x, st)
        return self.equations(x, v), st, v

    # --------------------------------------------------------------- jacobian
    # ------------------------------------------------- the problem protocol (tps_solver.core.problem)
    @property
    def parameters(self):
        """``Gamma`` and ``e`` by name (:meth:`at` rebuilds the problem at other values)."""
        return {"Gamma": float(self.Gamma), "e": float(self.e)}

    def at(self, **values):
        """The problem of the same pattern at other ``Gamma`` or ``e``."""
        unknown = sorted(set(values) - {"Gamma", "e"})
        if unknown:
            raise ValueError(f"parameter must be one of ['Gamma', 'e'], got {unknown[0]!r}")
        return StickProblem(**{**self.inputs, **{k: float(v) for k, v in values.items()}})

    def jacobian(self, x, F, data):
        """The dense Jacobian (:meth:`jacobian_matrix`) from the data of :meth:`residual`."""
        st, v = data
        return self.jacobian_matrix(x, st, v, F)

    def limit_step(self, x, dx):
        """Keep the times ordered: the largest time step is capped at 0.25."""
        big = float(np.max(np.abs(dx[:self.n_theta]))) if self.n_theta else 0.0
        return dx * (0.25 / big) if big > 0.25 else dx

    def project(self, x):
        """``x`` itself if its contact order and stick segments are intact, else :class:`Inadmissible`."""
        t = self.unpack(x)[0]
        a, b = self.seg_ends(x[:self.n_theta])
        if np.any(b <= a):
            raise Inadmissible("a stick segment collapsed")
        for idx in self.by_node:
            tj = t[idx]
            if np.any(np.diff(tj) <= 0) or tj[-1] - tj[0] >= self.T:
                raise Inadmissible("contact order changed")
        return x

    def jacobian_matrix(self, x, st, v, F, times=True):
        """Dense Jacobian: exact in J and coef; in the times, the impulse kernels (which
        kink where two impacts coincide) analytically, the smooth rest by forward differences.
        ``times=False``: only the (cheap, exact) columns of the linear unknowns J and coef
        (the time columns are left unset)."""
        t, tau_s, J, coef = self.unpack(x)
        n = self.n_unknowns
        Jm = np.empty((F.size, n))
        dv_lin = np.concatenate([st["B_imp"], st["B_int"]], axis=1)
        base = self.equations(x, v)
        Jm[:, self.n_theta:] = self.linear_part(x, np.eye(n - self.n_theta), dv_lin)
        if not times:
            return Jm
        rt = st["rt"]
        allg = np.arange(self.G)
        dR = self._impulse(self.rq_node, rt, self.rq_W, self.rq_own, np.arange(self.C), t, deriv=True)
        for k in range(self.n_theta):
            rows = self.rows_of_theta[k]
            kap = self.rq_ca[rows] * (self.rq_ia[rows] == k) + self.rq_cb[rows] * (self.rq_ib[rows] == k)
            segs = self.segs_of_theta[k]
            h = 1e-7 * max(1.0, abs(x[k]))
            if segs.size:
                a, b = self.seg_ends(x[:self.n_theta], segs)
                shortest = float(np.min(b - a))
                if shortest > 0.0:
                    h = min(h, 1e-3 * shortest)
            xk = x.copy()
            xk[k] += h
            thk = xk[:self.n_theta]
            dv = np.zeros(self.E)
            if rows.size:
                dv[rows] += kap * (dR[rows] @ J)
                rtr = rt[rows]
                dv[rows] += kap * np.where(self.rq_W[rows], -np.cos(rtr), np.sin(rtr))
            if k < self.C:
                dv -= dR[:, k] * J[k]
            rt_new = rt.copy()
            rt_new[rows] = self.request_times(thk, rows)
            delta = np.zeros(self.E)
            if rows.size:
                others = np.setdiff1d(allg, segs)
                if others.size:
                    vals = self._intervals(self.rq_node[rows], rt_new[rows], self.rq_W[rows], others, thk)
                    Bn, bn = self._scatter(vals, others)
                    cols = self._cols(others)
                    delta[rows] += (Bn @ coef[cols] + bn.sum(axis=1)
                                    - st["B_int"][rows][:, cols] @ coef[cols]
                                    - st["b_int"][rows][:, others].sum(axis=1))
            if segs.size:
                vals = self._intervals(self.rq_node, rt_new, self.rq_W, segs, thk)
                Bn, bn = self._scatter(vals, segs)
                cols = self._cols(segs)
                delta += (Bn @ coef[cols] + bn.sum(axis=1) - st["B_int"][:, cols] @ coef[cols]
                          - st["b_int"][:, segs].sum(axis=1))
            Jm[:, k] = (self.equations(xk, v + h * dv + delta) - base) / h
        return Jm


# ------------------------------------------------------------------ result


# ------------------------------------------------------------------ file codecs (tps_solver.core.archive)
archive.register("StickProblem", StickProblem, encode=lambda p: dict(p.inputs), decode=lambda d: StickProblem(**d))
