r"""Contact times from the truncated velocity series: the contact condition (46).

At a node the velocity is the truncated series
:math:`S(t) = \sum_{n=-N}^{N} \hat w_n e^{i n\alpha t}` (convention of
:mod:`tps_solver.model.harmonics`, :math:`\alpha = 1/M`, :math:`T = 2\pi M`).  The
contact condition (46) asks for the time :math:`t_c` at which the series takes
the mean of :math:`w^-` and :math:`w^+` at the jump,

.. math::  S(t_c) = \ell, \qquad \ell = -\cos t_0 ,

the *level*.  With :math:`z = e^{i\alpha t}`, :math:`z^N (S - \ell)` is a
polynomial of degree :math:`2N` in :math:`z` (:func:`contact_polynomial`).  Its
roots on the unit circle are all the real solutions of :math:`S(t) = \ell`, and
there are several: the velocity also passes the level in flight.

Root-selection rule
-------------------
By (44) the velocity jumps *upwards* at contact by :math:`J = T/\Gamma` at every
node, so the series contains :math:`J` times a sawtooth whose symmetric partial
sum rises, at the jump, with slope :math:`J N\alpha/\pi`, while the flight
crossings have slopes bounded by :math:`\max|\partial_t w|` (of order
:math:`1 + 1/\Gamma`), independent of :math:`N`.  The rule is therefore

    **the contact is the real up-crossing** (:math:`S(t_c) = \ell`,
    :math:`S'(t_c) > 0`) **with the largest slope** :math:`S'(t_c)`,

polished by Newton's method on the real trigonometric sum.  A safety test
checks that the chosen crossing is jump-like: its slope is compared with the
largest slope any time can have, :math:`\bar S' = \alpha\sum_n |n|\,|\hat w_n|`
(for the sawtooth partial sum alone the two are equal), and the node is
flagged ``ok=False`` when ``slope / bound < min_slope_ratio`` (default 0.25).
For a level strictly inside the jump the ratio of the jump crossing is
:math:`\ge 0.6` asymptotically (:math:`\sin x/x` at :math:`\mathrm{Si}(x) =
\pm\pi/2`); flight crossings have ratio :math:`O(1/N)`; crossings on the Gibbs
ripples have ratio :math:`\lesssim 0.22` (Dirichlet-kernel estimate, not a bound).  A node is also flagged when no
up-crossing exists or Newton's method fails to reach the residual tolerance.

Methods
-------
``"grid"``
    The series is synthesised on ``oversample * (2N+1)`` equispaced times by
    one FFT per node (vectorised over nodes, in chunks), the
    up-crossing brackets are located, the bracket with the steepest secant is
    chosen and refined by bracket-safeguarded Newton.  Cost
    :math:`O(N\log N)` per node.
``"polynomial"``
    :func:`numpy.polynomial.polynomial.polyroots` (companion-matrix
    eigenvalues) on every node; roots with :math:`||z| - 1| <`
    ``circle_tol`` are mapped to :math:`t = \arg z/\alpha \bmod T`,
    Newton-polished, and the rule is applied.  Cost :math:`O(N^3)` per node
    (measured 0.9-2 s per node at N = 256 with single-threaded BLAS, far more
    with contended multithreaded BLAS; the grid needs about 1 ms).
``"track"``
    Newton's method from ``tc_guess`` (:math:`O(N)` per node and iteration),
    with steps clamped to :math:`T/(4(2N+1))`, about an eighth of the width
    of the jump's rise.  A node
    is accepted only if Newton converges to an up-crossing that passes the
    same safety test; otherwise that node falls back to the global method
    ``fallback`` (``"grid"`` by default).
``"auto"``
    ``"track"`` if ``tc_guess`` is given, else ``"grid"``.

Truncation and the tail
-----------------------
The symmetric partial sum of a sawtooth vanishes exactly at its jump, so for a
series "analytic part + :math:`J`-sawtooth" whose level is the mean at the jump
(e.g. the flat layer) the truncated root *is* the jump location up to the
truncation error of the analytic part: no correction is needed, and none is
applied by default.  A derivative jump (kink) :math:`K` of the remaining part
*at* the contact leaves the tail :math:`-(2K/T\alpha^2)\psi'(N+1) = O(K/N)` in
the value at the contact and hence an :math:`O(N^{-2})` error in :math:`t_c`.
``tail="kink"`` fits :math:`J, K` and the offset from the top harmonics
(:func:`jump_asymptotics`), shifts the level by that closed-form tail
(:func:`kink_tail`) and re-polishes -- but only at nodes where the fit is
trustworthy (relative standard error of :math:`K` at most 5 % and fitted jump
offset :math:`|\delta| N\alpha \le 0.1`); ``tail_applied`` says where.  On
manufactured data this reduces the :math:`O(N^{-2})` error of a kink at the
contact by factors :math:`10^4`-:math:`10^6` at :math:`N \ge 64`; where the top harmonics also carry other
singularities (a kink elsewhere, an unresolved steep feature) the fit is
unreliable and the correction is skipped (it would make things worse).  When
the level is *not* the mean at the jump (an unconverged iterate) the truncated
root sits :math:`O(1/N)` from the jump; that offset is the information an
iteration on :math:`t_c` uses and is not corrected.

Limitation: the rule assumes the jump is the steepest feature the truncated
series resolves.  A smooth but steeper, unresolved feature (slope above
:math:`JN\alpha/\pi`) would be selected and passes the slope test; pass
``expected_jump`` (:math:`T/\Gamma`) to have such nodes flagged.

Examples
--------
>>> from tps_solver.model.harmonics import flat_w_hat
>>> import numpy as np
>>> Gamma, M, e = 2.5, 2, 0.45
>>> s = (1 - e) / (1 + e)
>>> t0 = np.arccos(s * 2 * np.pi * M / (2 * Gamma))
>>> w = flat_w_hat(30, M, Gamma, t0)
>>> res = contact_times(w[:, None], M, -np.cos(t0))
>>> bool(res.ok[0]), bool(abs(res.tc[0] - t0) < 1e-12)
(True, True)
"""
import numpy as np
from numpy.polynomial import polynomial as npoly
from scipy import fft as sp_fft
from scipy.special import polygamma

from tps_solver.core.bunch import Bunch
from tps_solver.core.checks import check_array, check_choice, check_in_range, check_int, check_positive

__all__ = ["ContactResult", "contact_polynomial", "contact_times", "trig_sum",
           "contact_sensitivity", "kink_tail", "jump_asymptotics"]

_EPS = np.finfo(float).eps
_METHODS = ("auto", "grid", "polynomial", "track")
_GLOBAL = ("grid", "polynomial")
_TAILS = ("none", "kink")
# relative tolerance on the conjugate symmetry w_{-n} = conj(w_n) of the input
_HERMITIAN_RTOL = 1e-8
# tail="kink" is applied only where the fitted K has relative standard error <= _KINK_RTOL
# and the fitted jump offset delta satisfies |delta| N alpha <= _KINK_MAX_OFFSET
_KINK_RTOL = 0.05
_KINK_MAX_OFFSET = 0.1
# with expected_jump given, the fitted jump must lie within this relative distance of it
_JUMP_RTOL = 0.5


class ContactResult(Bunch):
    """Contact times of :func:`contact_times`.

    Attributes
    ----------
    tc : ndarray of float, shape (n_nodes,)
        Contact time per node in ``[0, T)`` (NaN where no up-crossing exists).
    slope : ndarray of float, shape (n_nodes,)
        :math:`S'(t_c)`.
    residual : ndarray of float, shape (n_nodes,)
        :math:`|S(t_c) - \\ell|` (against the shifted ``level`` where ``tail_applied``).
    slope_ratio : ndarray of float, shape (n_nodes,)
        ``slope`` divided by the bound :math:`\\alpha\\sum|n||\\hat w_n|`.
    ok : ndarray of bool, shape (n_nodes,)
        A jump-like up-crossing was found and polished to the residual tolerance.
    n_up_crossings : ndarray of int, shape (n_nodes,)
        Number of up-crossings seen by the global method (-1 on tracked nodes).
    global_solve : ndarray of bool, shape (n_nodes,)
        Nodes solved by the global method (all of them unless tracking).
    n_polynomial : int
        Number of nodes that needed the global solve.
    jump, kink, kink_stderr, jump_offset : ndarray of float, shape (n_nodes,)
        Fit of the top harmonics at ``tc`` (:func:`jump_asymptotics`; ``jump`` is
        its robust ``jump_abs``); NaN for ``N < 6``.  By (44) ``jump`` should be
        :math:`T/\\Gamma` at every node.
    tail_applied : ndarray of bool, shape (n_nodes,)
        Where the kink-tail correction was applied.
    level : ndarray of float, shape (n_nodes,)
        The level actually solved for (shifted where ``tail_applied``).
    method, global_method, tail : str
    success : bool
        ``ok.all()``.
    message : str

    Examples
    --------
    The velocity harmonics of the flat layer launched at ``t0 = 0.3``: the contact time is
    ``t0`` and the measured jump is ``T/Gamma = 4 pi/2.5`` (44):

    >>> import numpy as np
    >>> from tps_solver.model.harmonics import flat_w_hat
    >>> res = contact_times(flat_w_hat(30, 2, 2.5, 0.3)[:, None], 2, -np.cos(0.3))
    >>> type(res).__name__, res.success, res.tc.round(12).tolist()
    ('ContactResult', True, [0.3])
    >>> bool(abs(res.jump[0] - 4 * np.pi / 2.5) < 1e-6)
    True
    """


def _as_coefficients(w_hat, name="w_hat"):
    """Return ``(w, was_1d)`` with ``w`` complex of shape (2N+1, n_nodes)."""
    w = check_array(w_hat, name, dtype=complex)
    if w.ndim not in (1, 2):
        raise ValueError(f"{name} must have shape (2N+1,) or (2N+1, n_nodes), got {w.shape}")
    if w.shape[0] < 3 or w.shape[0] % 2 == 0:
        raise ValueError(f"{name} must have an odd length 2N+1 >= 3 along axis 0, "
                         f"got {w.shape[0]}")
    if w.ndim == 2 and w.shape[1] < 1:
        raise ValueError(f"{name} must have at least one node (column), got shape {w.shape}")
    was_1d = w.ndim == 1
    return (w[:, None] if was_1d else w), was_1d


def _per_node(value, name, n_nodes):
    """Scalar or (n_nodes,) real array -> float array (n_nodes,)."""
    arr = check_array(value, name, dtype=float)
    if arr.ndim == 0:
        return np.full(n_nodes, float(arr))
    if arr.shape != (n_nodes,):
        raise ValueError(f"{name} must be a scalar or have shape ({n_nodes},), got {arr.shape}")
    return arr


def contact_polynomial(w_hat, level):
    r"""Coefficients of :math:`z^N (S(z) - \ell)`, the contact polynomial of (46).

    Parameters
    ----------
    w_hat : array_like of complex, shape (2N+1,) or (2N+1, n_nodes)
        Centred velocity harmonics (entry ``N + n`` holds :math:`\hat w_n`).
    level : float or array_like of float, shape (n_nodes,)
        The level :math:`\ell = -\cos t_0`.

    Returns
    -------
    c : ndarray of complex, same shape as ``w_hat``
        Coefficients in **ascending** powers of :math:`z = e^{i\alpha t}`
        (the order of :mod:`numpy.polynomial.polynomial`):
        :math:`c_k = \hat w_{k-N} - \ell\,\delta_{kN}`, ``k = 0..2N``.

    Examples
    --------
    >>> contact_polynomial(np.array([0.5, 0.0, 0.5]), -0.25)
    array([0.5 +0.j, 0.25+0.j, 0.5 +0.j])
    """
    w, was_1d = _as_coefficients(w_hat)
    level = _per_node(level, "level", w.shape[1])
    N = (w.shape[0] - 1) // 2
    c = w.copy()
    c[N] -= level
    return c[:, 0] if was_1d else c


def trig_sum(w_hat, t, M, derivative=0):
    r"""The real trigonometric sum :math:`S^{(d)}(t) = \mathrm{Re}\sum_n (in\alpha)^d \hat w_n e^{in\alpha t}`.

    Parameters
    ----------
    w_hat : array_like of complex, shape (2N+1,) or (2N+1, n_nodes)
        Centred harmonics.
    t : array_like of float
        Times: any shape for 1-D ``w_hat``; shape ``(n_nodes,)`` (one time per
        node) for 2-D ``w_hat``.
    M : int
        Subharmonic order, :math:`\alpha = 1/M`.
    derivative : int, optional
        Order ``d >= 0`` of the time derivative.

    Returns
    -------
    S : ndarray of float
        Shape of ``t``.  Cost :math:`O(N)` per evaluation.

    Examples
    --------
    >>> w = np.array([0.5, 0.0, 0.5])        # cos(t/2) with M = 2
    >>> float(trig_sum(w, np.pi, 2, derivative=1))
    -0.5
    """
    w, was_1d = _as_coefficients(w_hat)
    M = check_int(M, "M", minimum=1)
    derivative = check_int(derivative, "derivative", minimum=0)
    tt = check_array(t, "t", dtype=float)
    if was_1d:
        return _sum_1d(w[:, 0], tt, M, derivative)
    if tt.shape != (w.shape[1],):
        raise ValueError(f"t must have shape ({w.shape[1]},) (one time per node), got {tt.shape}")
    return _sum_nodes(w, tt, M, derivative)


def _mode_factor(N, M, derivative):
    n = np.arange(-N, N + 1)
    return n, (1j * n / M) ** derivative


def _sum_nodes(w, t, M, derivative=0):
    """Unchecked S^(d) at one time per node: w (2N+1, k), t (k,) -> (k,)."""
    N = (w.shape[0] - 1) // 2
    n, factor = _mode_factor(N, M, derivative)
    phase = np.exp(1j * np.outer(n, t / M))
    return np.einsum("nk,nk->k", w * factor[:, None], phase).real


def _sum_1d(w, t, M, derivative=0):
    """Unchecked S^(d) of one node at many times: w (2N+1,), t any shape."""
    N = (w.shape[0] - 1) // 2
    n, factor = _mode_factor(N, M, derivative)
    phase = np.exp(1j * np.multiply.outer(t / M, n))
    return (phase @ (w * factor)).real


def _slope_bound(w, M):
    """alpha * sum |n| |w_n| per node: the largest |S'| can be."""
    N = (w.shape[0] - 1) // 2
    n = np.abs(np.arange(-N, N + 1))
    return (n[:, None] * np.abs(w)).sum(axis=0) / M


def _hermitise(w, name="w_hat"):
    """Project on conjugate-symmetric coefficients; reject clearly non-real series."""
    wr = np.conj(w[::-1])
    scale = np.abs(w).sum(axis=0)
    defect = np.abs(w - wr).max(axis=0)
    bad = defect > _HERMITIAN_RTOL * np.maximum(scale, np.finfo(float).tiny)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name} must be conjugate-symmetric (w_{{-n}} = conj(w_n), a real "
                         f"series); node {k} has relative defect {defect[k] / scale[k]:.2e} "
                         f"> {_HERMITIAN_RTOL:g}")
    return 0.5 * (w + wr)


def kink_tail(kink, N, M):
    r"""Closed-form tail, at the kink itself, of the series of a derivative jump.

    A function whose derivative jumps by :math:`K` at :math:`t_c` has
    coefficients :math:`(K/T)\,e^{-in\alpha t_c}/(in\alpha)^2`; the part
    :math:`|n| > N` of its series, evaluated at :math:`t_c`, is

    .. math:: -\frac{K}{T\alpha^2}\, 2\sum_{n>N} n^{-2}
              = -\frac{2K}{T\alpha^2}\,\psi'(N+1) ,

    with the trigamma function :math:`\psi'`.  This is the :math:`O(K/N)`
    error of the truncated sum at the contact that remains after the jump's own
    partial sum (which vanishes at the jump) is accounted for.

    Parameters
    ----------
    kink : float or ndarray of float
        Derivative jump :math:`K` at the contact.
    N, M : int
        Truncation and subharmonic order.

    Returns
    -------
    tail : float or ndarray of float

    Examples
    --------
    >>> tail = 2 * (np.pi**2 / 6 - sum(1 / n**2 for n in range(1, 11)))
    >>> bool(abs(kink_tail(1.0, 10, 1) + tail / (2 * np.pi)) < 1e-15)
    True
    """
    N = check_int(N, "N", minimum=1)
    M = check_int(M, "M", minimum=1)
    kink = np.asarray(kink, dtype=float)
    period = 2.0 * np.pi * M
    return -2.0 * kink * M**2 / period * polygamma(1, N + 1.0)


def jump_asymptotics(w_hat, tc, M, fraction=0.5):
    r"""Fit the large-``n`` form of the harmonics near a jump at ``tc``.

    A series with a jump :math:`J` and a derivative jump :math:`K` at
    :math:`t_c + \delta` has
    :math:`y_n := T\,in\alpha\,\hat w_n e^{in\alpha t_c}
    = e^{-in\alpha\delta}\,(J + K/(in\alpha) + O(n^{-2}))`, so
    :math:`\mathrm{Re}\,y_n \approx J` and
    :math:`\mathrm{Im}\,y_n \approx -J\delta\,n\alpha - K/(n\alpha)`.
    Both parts are fitted by linear least squares over the top ``fraction``
    of ``n = 1..N``, leaving out the forcing harmonic ``n = M`` of (43) (bases :math:`1, (n\alpha)^{\pm 2}` and
    :math:`n\alpha, (n\alpha)^{-1}, (n\alpha)^{-3}`).  Other
    singularities of the series are not modelled; they enter as oscillating
    residuals.  By (44), a TPS iterate should have ``jump`` = :math:`T/\Gamma`.

    Parameters
    ----------
    w_hat : array_like of complex, shape (2N+1, n_nodes) or (2N+1,)
    tc : float or array_like of float, shape (n_nodes,)
    M : int
    fraction : float in (0, 1], optional

    Returns
    -------
    Bunch
        ``jump`` (J), ``kink`` (K), ``kink_stderr`` (standard error of K from the
        residual of the fit), ``offset`` (:math:`\delta`) and ``jump_abs`` (the
        median of :math:`|y_n|`, independent of ``tc``: equal to J when the
        jump dominates the top harmonics, larger when unresolved smooth content
        does, ~0 without a jump), each of shape (n_nodes,) (scalars for 1-D input).

    Examples
    --------
    >>> from tps_solver.model.harmonics import flat_w_hat
    >>> fit = jump_asymptotics(flat_w_hat(32, 2, 2.5, 0.3), 0.3, 2)
    >>> round(float(fit.jump), 12), round(float(fit.kink), 12)   # T/Gamma, 0
    (5.026548245744, 0.0)
    """
    w, was_1d = _as_coefficients(w_hat)
    M = check_int(M, "M", minimum=1)
    tcs = _per_node(tc, "tc", w.shape[1])
    fraction = check_in_range(fraction, "fraction", 0.0, 1.0, low_closed=False)
    N = (w.shape[0] - 1) // 2
    n = np.arange(max(1, int(np.ceil((1.0 - fraction) * N))), N + 1)
    n = n[n != M]       # the forcing harmonic of (43) is not part of the jump asymptotics
    if n.size < 3:
        raise ValueError(f"fraction must leave at least 3 harmonics to fit, got {n.size} "
                         f"(N = {N})")
    x = n / M
    y = (2.0 * np.pi * M) * (1j * x)[:, None] * w[N + n, :] * np.exp(1j * np.outer(x, tcs))
    # small bases, many right-hand sides: apply the pseudo-inverses directly
    re = np.linalg.pinv(np.stack([np.ones_like(x), x**2, x**-2], 1)) @ y.real
    basis = np.stack([x, x**-1, x**-3], 1)
    im = np.linalg.pinv(basis) @ y.imag
    # standard error of K from the residual of the imaginary fit
    rss = ((y.imag - basis @ im) ** 2).sum(axis=0)
    var = np.linalg.inv(basis.T @ basis)[1, 1] * rss / max(n.size - 3, 1)
    jump = re[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(jump != 0, -im[0] / jump, np.nan)
    out = Bunch(jump=jump, jump_abs=np.median(np.abs(y), axis=0), kink=-im[1],
                kink_stderr=np.sqrt(var), offset=offset)
    if was_1d:
        out = Bunch({k: float(v[0]) for k, v in out.items()})
    return out


def _newton_nodes(w, level, t, M, *, lo=None, hi=None, tol, maxiter, max_step=None):
    """Vectorised Newton on S(t) - level, one root per column.

    With brackets ``lo < hi`` (S(lo) < level <= S(hi)) steps leaving the bracket
    are replaced by bisection.  Without brackets steps are clamped to
    ``max_step``.  Returns ``t, converged``.
    """
    t = t.copy()
    converged = np.zeros(t.shape, dtype=bool)
    active = np.arange(t.size)
    bracketed = lo is not None
    if bracketed:
        lo, hi = lo.copy(), hi.copy()
    for _ in range(maxiter):
        if active.size == 0:
            break
        ta = t[active]
        wa = w[:, active]
        f = _sum_nodes(wa, ta, M) - level[active]
        fp = _sum_nodes(wa, ta, M, 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(fp != 0, f / fp, np.inf)
        if bracketed:
            la, ha = lo[active], hi[active]
            la = np.where(f < 0, ta, la)
            ha = np.where(f >= 0, ta, ha)
            tn = ta - step
            outside = ~np.isfinite(tn) | (tn < la) | (tn > ha)
            tn = np.where(outside, 0.5 * (la + ha), tn)
            lo[active], hi[active] = la, ha
            done = (f == 0) | (np.abs(tn - ta) <= tol * max(1.0, np.pi * M)) | (ha - la <= tol)
            tn = np.where(f == 0, ta, tn)
        else:
            step = np.where(np.isfinite(step), step, np.sign(f) * max_step)
            step = np.clip(step, -max_step, max_step)
            tn = ta - step
            done = np.abs(step) <= tol * max(1.0, np.pi * M)
        t[active] = tn
        converged[active[done]] = True
        active = active[~done]
    return t, converged


def _grid_candidates(w, level, M, oversample, chunk=256):
    """FFT synthesis on a fine grid; steepest up-crossing bracket per node.

    Nodes are processed in chunks of ``chunk`` columns to bound the memory
    (``oversample * (2N+1) * chunk`` complex numbers).
    """
    N = (w.shape[0] - 1) // 2
    K = sp_fft.next_fast_len(oversample * (2 * N + 1))
    h = 2.0 * np.pi * M / K
    n_nodes = w.shape[1]
    j = np.zeros(n_nodes, dtype=int)
    d0, d1 = np.zeros(n_nodes), np.zeros(n_nodes)
    found = np.zeros(n_nodes, dtype=bool)
    count = np.zeros(n_nodes, dtype=int)
    rows = np.arange(-N, N + 1) % K
    for start in range(0, n_nodes, chunk):
        sl = slice(start, min(start + chunk, n_nodes))
        C = np.zeros((K, sl.stop - sl.start), dtype=complex)
        C[rows] = w[:, sl]
        D = sp_fft.ifft(C, axis=0, norm="forward").real - level[sl]
        Dn = np.roll(D, -1, axis=0)
        up = (D < 0) & (Dn >= 0)
        jj = np.argmax(np.where(up, Dn - D, -np.inf), axis=0)
        cols = np.arange(D.shape[1])
        j[sl], d0[sl], d1[sl] = jj, D[jj, cols], Dn[jj, cols]
        found[sl], count[sl] = up.any(axis=0), up.sum(axis=0)
    lo = j * h
    with np.errstate(divide="ignore", invalid="ignore"):
        start_t = lo + h * np.where(found, -d0 / (d1 - d0), 0.5)
    return lo, lo + h, start_t, found, count


def _polynomial_candidates(w_node, level, M, circle_tol):
    """Real solution candidates of one node from the companion-matrix roots."""
    c = w_node.copy()
    N = (c.size - 1) // 2
    c[N] -= level
    z = npoly.polyroots(c)
    z = z[np.abs(np.abs(z) - 1.0) < circle_tol]
    return np.mod(np.angle(z) * M, 2.0 * np.pi * M)


def contact_times(w_hat, M, level, *, tc_guess=None, method="auto", tol=1e-13,
                  min_slope_ratio=0.25, oversample=8, fallback="grid", circle_tol=1e-6,
                  tail="none", expected_jump=None, maxiter=60):
    r"""Contact time at every node from the contact condition (46).

    Implements (46) with the root-selection rule of the module docstring: the
    contact is the real up-crossing of the level with the largest slope,
    Newton-polished on the real trigonometric sum.

    Parameters
    ----------
    w_hat : array_like of complex, shape (2N+1, n_nodes) or (2N+1,)
        Centred velocity harmonics per node (conjugate-symmetric to relative
        1e-8; the Hermitian part is used).
    M : int
        Subharmonic order (:math:`\alpha = 1/M`, :math:`T = 2\pi M`).
    level : float or array_like of float, shape (n_nodes,)
        :math:`\ell = -\cos t_0`.
    tc_guess : float or array_like of float, shape (n_nodes,), optional
        Starting times for tracking.
    method : {"auto", "grid", "polynomial", "track"}, optional
        See the module docstring.  ``"auto"``: ``"track"`` if ``tc_guess`` is
        given, else ``"grid"``.
    tol : float, optional
        Absolute Newton step tolerance on ``tc`` (scaled by ``max(1, T/2)``).
    min_slope_ratio : float in [0, 1], optional
        Safety threshold on ``slope / (alpha * sum |n| |w_n|)``.
    oversample : int >= 2, optional
        Grid points per coefficient for ``"grid"``.
    fallback : {"grid", "polynomial"}, optional
        Global method used by ``"track"`` for nodes it cannot accept.
    circle_tol : float, optional
        Roots with ``||z| - 1| < circle_tol`` count as real (``"polynomial"``).
    tail : {"none", "kink"}, optional
        ``"kink"`` shifts the level by the closed-form tail of the fitted
        :math:`1/(in\alpha)^2` (kink-at-contact) term where the fit is
        trustworthy, and re-polishes; see :func:`kink_tail`.
    expected_jump : float, optional
        The jump :math:`J` the series must carry at the contact (:math:`T/\Gamma`
        by (44)).  When given (and ``N >= 6``), a node is also flagged unless the
        jump size estimated from the top harmonics (``jump_abs`` of
        :func:`jump_asymptotics`) lies within 50 % of it, i.e. unless the top
        harmonics look like that jump.  This catches a series without a jump
        and unresolved smooth content that dominates the top harmonics (where
        the rule is unreliable), which the slope test alone cannot; it is
        conservative (it also flags such nodes when the root happens to be right).
    maxiter : int, optional
        Newton iterations per stage.

    Returns
    -------
    ContactResult
        ``tc``, ``slope``, ``residual``, ``slope_ratio``, ``ok``,
        ``n_up_crossings``, ``global_solve``, ``n_polynomial``, ``method``,
        ``global_method``, ``tail``, ``tail_applied``, ``jump``, ``kink``,
        ``kink_stderr``, ``jump_offset``, ``level``, ``success``, ``message``.

    Raises
    ------
    ValueError
        For malformed input (the message names the parameter).

    Examples
    --------
    >>> from tps_solver.model.harmonics import flat_w_hat
    >>> w = np.stack([flat_w_hat(16, 2, 2.5, t) for t in (0.3, 0.3 + 2 * np.pi)], 1)
    >>> res = contact_times(w, 2, -np.cos(0.3))
    >>> np.round(res.tc, 12)
    array([0.3       , 6.58318531])
    """
    w, _ = _as_coefficients(w_hat)
    M = check_int(M, "M", minimum=1)
    n_nodes = w.shape[1]
    N = (w.shape[0] - 1) // 2
    level = _per_node(level, "level", n_nodes)
    method = check_choice(method, "method", _METHODS)
    fallback = check_choice(fallback, "fallback", _GLOBAL)
    tail = check_choice(tail, "tail", _TAILS)
    tol = check_positive(tol, "tol")
    min_slope_ratio = check_in_range(min_slope_ratio, "min_slope_ratio", 0.0, 1.0)
    oversample = check_int(oversample, "oversample", minimum=2)
    circle_tol = check_positive(circle_tol, "circle_tol")
    maxiter = check_int(maxiter, "maxiter", minimum=1)
    if expected_jump is not None:
        expected_jump = check_positive(expected_jump, "expected_jump")
    if method == "track" and tc_guess is None:
        raise ValueError("tc_guess must be given for method='track'")
    if tc_guess is not None:
        tc_guess = _per_node(tc_guess, "tc_guess", n_nodes)
    if method == "auto":
        method = "track" if tc_guess is not None else "grid"
    global_method = method if method in _GLOBAL else fallback

    w = _hermitise(w)
    period = 2.0 * np.pi * M
    bound = _slope_bound(w, M)
    scale = np.abs(w).sum(axis=0) + np.abs(level)
    res_tol = 1e3 * _EPS * scale

    tc = np.full(n_nodes, np.nan)
    crossings = np.full(n_nodes, -1)
    solved_globally = np.zeros(n_nodes, dtype=bool)

    def acceptable(idx, t, conv):
        f = _sum_nodes(w[:, idx], t, M) - level[idx]
        fp = _sum_nodes(w[:, idx], t, M, 1)
        return conv & (np.abs(f) <= res_tol[idx]) & (fp >= min_slope_ratio * bound[idx]) & (fp > 0)

    todo = np.arange(n_nodes)
    if method == "track":
        t, conv = _newton_nodes(w, level, tc_guess, M, tol=tol, maxiter=min(maxiter, 20),
                                max_step=period / (4.0 * (2 * N + 1)))
        good = acceptable(todo, t, conv)
        tc[good] = t[good]
        todo = todo[~good]
    if todo.size:
        solved_globally[todo] = True
        if global_method == "grid":
            lo, hi, start, found, count = _grid_candidates(w[:, todo], level[todo], M, oversample)
            crossings[todo] = count
            idx = todo[found]
            t, _ = _newton_nodes(w[:, idx], level[idx], start[found], M, lo=lo[found],
                                 hi=hi[found], tol=tol, maxiter=maxiter)
            tc[idx] = t
        else:
            for k in todo:
                cand = _polynomial_candidates(w[:, k], level[k], M, circle_tol)
                if cand.size == 0:
                    crossings[k] = 0
                    continue
                wk = np.repeat(w[:, k:k + 1], cand.size, axis=1)
                lk = np.full(cand.size, level[k])
                t, conv = _newton_nodes(wk, lk, cand, M, tol=tol, maxiter=maxiter,
                                        max_step=period / (4.0 * (2 * N + 1)))
                f = _sum_nodes(wk, t, M) - lk
                fp = _sum_nodes(wk, t, M, 1)
                upc = conv & (fp > 0) & (np.abs(f) <= res_tol[k])
                crossings[k] = int(upc.sum())
                if upc.any():
                    tc[k] = t[np.argmax(np.where(upc, fp, -np.inf))]

    result = ContactResult(method=method, global_method=global_method, tail=tail)
    has = np.isfinite(tc)
    fit = Bunch(jump=np.full(n_nodes, np.nan), jump_abs=np.full(n_nodes, np.nan),
                kink=np.full(n_nodes, np.nan), kink_stderr=np.full(n_nodes, np.nan),
                offset=np.full(n_nodes, np.nan))
    if has.any() and N >= 6:
        idx = np.flatnonzero(has)
        f = jump_asymptotics(w[:, idx], tc[idx], M)
        for key in fit:
            fit[key][idx] = f[key]
    target = level
    tail_applied = np.zeros(n_nodes, dtype=bool)
    if tail == "kink":
        # only where the kink model explains the top harmonics and the root sits at the jump
        with np.errstate(invalid="ignore"):
            tail_applied = (has & (fit.kink_stderr <= _KINK_RTOL * np.abs(fit.kink))
                            & (np.abs(fit.offset) * N / M <= _KINK_MAX_OFFSET))
    if tail_applied.any():
        # shift the level by the closed-form tail of the fitted kink at the contact
        idx = np.flatnonzero(tail_applied)
        target = level.copy()
        target[idx] = level[idx] - kink_tail(fit.kink[idx], N, M)
        t, _ = _newton_nodes(w[:, idx], target[idx], tc[idx], M, tol=tol, maxiter=maxiter,
                             max_step=period / (4.0 * (2 * N + 1)))
        tc[idx] = t

    tc = np.where(has, np.mod(tc, period), np.nan)
    tc = np.where(tc >= period, 0.0, tc)
    safe = np.where(has, tc, 0.0)
    value = _sum_nodes(w, safe, M) - target
    slope = _sum_nodes(w, safe, M, 1)
    residual = np.where(has, np.abs(value), np.nan)
    slope = np.where(has, slope, np.nan)
    with np.errstate(invalid="ignore"):
        ratio = np.where(has, slope / np.where(bound > 0, bound, np.inf), np.nan)
        ok = has & (residual <= res_tol) & (slope > 0) & (ratio >= min_slope_ratio)
        if expected_jump is not None and N >= 6:
            ok &= np.abs(fit.jump_abs - expected_jump) <= _JUMP_RTOL * expected_jump
    n_bad = int((~ok).sum())
    result.update(tc=tc, slope=slope, residual=residual, slope_ratio=ratio, ok=ok,
                  n_up_crossings=crossings, global_solve=solved_globally,
                  n_polynomial=int(solved_globally.sum()), jump=fit.jump_abs, kink=fit.kink,
                  kink_stderr=fit.kink_stderr, jump_offset=fit.offset,
                  tail_applied=tail_applied, level=target, success=n_bad == 0)
    if n_bad == 0:
        result.message = f"jump-like up-crossing found at all {n_nodes} node(s)"
    else:
        result.message = (f"{n_bad} of {n_nodes} node(s) have no jump-like up-crossing "
                          f"(no up-crossing, residual > tolerance, slope ratio < "
                          f"{min_slope_ratio:g}, or fitted jump off expected_jump); "
                          f"see ok, slope_ratio, residual, jump")
    return result


def contact_sensitivity(w_hat, tc, M):
    r"""Derivative of the contact time with respect to the harmonics, at fixed level.

    Implicit differentiation of (46), :math:`S(t_c) = \ell`:

    .. math:: \delta t_c = -\frac{\mathrm{Re}\sum_n \delta\hat w_n e^{in\alpha t_c}}{S'(t_c)}
              = \mathrm{Re}\sum_n F_n\,\delta\hat w_n, \qquad
              F_n = -\frac{e^{in\alpha t_c}}{S'(t_c)} ,

    and :math:`\partial t_c/\partial\ell = 1/S'(t_c)`.

    Parameters
    ----------
    w_hat : array_like of complex, shape (2N+1, n_nodes) or (2N+1,)
    tc : float or array_like of float, shape (n_nodes,)
    M : int

    Returns
    -------
    F : ndarray of complex, same shape as ``w_hat``
        The factors :math:`F_n` (entry ``N + n``).

    Raises
    ------
    ValueError
        If :math:`S'(t_c) \le 0` at a node (not an up-crossing).

    Examples
    --------
    >>> w = np.array([0.5j, 0.0, -0.5j])          # sin(t) with M = 1
    >>> F = contact_sensitivity(w, 0.0, 1)
    >>> np.allclose(F, -1.0)
    True
    """
    w, was_1d = _as_coefficients(w_hat)
    M = check_int(M, "M", minimum=1)
    tcs = _per_node(tc, "tc", w.shape[1])
    slope = _sum_nodes(w, tcs, M, 1)
    if np.any(slope <= 0):
        k = int(np.flatnonzero(slope <= 0)[0])
        raise ValueError(f"tc must be an up-crossing (S'(tc) > 0) at every node; node {k} "
                         f"has S'(tc) = {slope[k]:.3g}")
    N = (w.shape[0] - 1) // 2
    n = np.arange(-N, N + 1)
    F = -np.exp(1j * np.outer(n, tcs) / M) / slope
    return F[:, 0] if was_1d else F
