r"""The fate of a front from per-period records: :func:`front_fate`, :func:`invasion_speed`, :func:`chain_statistics`.

A kink or an oscillon time-stepped period by period leaves, after every period :math:`T`,

* a *periodicity defect* :math:`\max(|w(t+T) - w(t)|, |\zeta(t+T) - \zeta(t)|)` over the nodes;
* a *disordered size*: how much of the lattice does something else than the flat layer (the
  studies count the nodes whose contacts in the period differ from the flat orbit's, times the
  spacing for a length, or as a number of nodes);
* optionally a *front position* (kink: distance of the phase switch from the left end;
  oscillon: core radius) and whether both flat phases are still present.

:func:`front_fate` reads these records and says what happened: the front **settles** to a
periodic state, **drifts** (one flat layer encroaches on the other), **collapses** (one phase
took over), **invades** (the disorder fills the lattice), is **stationary** (frozen but not
periodic to the tolerance), **decays** (the disorder is gone and the defect falls), is left with
**localized disorder**, or is **undecided**; :func:`invasion_speed` is the growth rate of an
invasion.  The rules are those of the existence-map study (``validation/existence_map.py``);
the soft-kink study (``validation/soft_kinks.py``) uses the same function with its options
(``front_max=inf, settle_width=0, decay_periods=5, stationary_periods=None,
localized=True``), see the example of :func:`front_fate`.

:func:`chain_statistics` classifies the contacts of one period of a lattice orbit into touches,
smoothly ending sticks and sticks whose lift-off is triggered by a neighbour's landing (the
chains along a tilted front of the completely inelastic kink).
"""
import numpy as np

from tps_solver.core.checks import (check_array, check_in_range, check_int, check_nonnegative, check_positive,
                                    check_real)

__all__ = ["FATES", "front_fate", "invasion_speed", "chain_statistics"]

#: Every label :func:`front_fate` returns.
FATES = ("invades", "collapses", "drifts", "settles", "decays", "stationary", "localized disorder", "undecided")


def _records(values, name, n=None, minimum=0.0):
    arr = check_array(values, name, ndim=1)
    if arr.size == 0:
        raise ValueError(f"{name} must hold at least one period, got an empty array")
    if n is not None and arr.size != n:
        raise ValueError(f"{name} must have one entry per period ({n}), got {arr.size}")
    if minimum is not None and np.any(arr < minimum):
        raise ValueError(f"{name} must be >= {minimum:g} (a size), got min {arr.min():g}")
    return arr


def _bound(value, name):
    """A float in [0, inf] (inf allowed: no bound)."""
    if value is not None and not isinstance(value, bool):
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = float("nan")
        if v >= 0.0:
            return v
    raise ValueError(f"{name} must be a number in [0, inf], got {value!r}")


def invasion_speed(sizes, extent, fraction=0.8):
    r"""Growth rate of a disordered region: least-squares slope of its size per period.

    The fit runs over the periods up to and including the first one in which the size reaches
    ``fraction * extent`` (the lattice is filled); later periods are left out.

    Parameters
    ----------
    sizes : array_like of float, shape (n_periods,)
        Size of the disordered region after each period (a length, or a number of nodes), >= 0.
    extent : float
        Size of the whole domain in the same unit (length, r_max, or number of nodes), > 0.
    fraction : float
        Filled fraction, in (0, 1].

    Returns
    -------
    float or None
        Size per period (the unit of ``sizes``); None when fewer than two periods enter the fit
        (the region filled the domain within the first period: faster than the run resolves).
        A kink has two fronts, so each of its fronts moves at half of it.

    Raises
    ------
    ValueError
        If ``sizes`` is empty, not 1-D, not finite or negative, or ``extent``/``fraction`` out
        of range.

    Examples
    --------
    >>> round(invasion_speed([4, 14, 24, 34, 44, 49, 49], 49), 9)
    10.0
    >>> invasion_speed([45.0, 49.0], 49) is None          # filled within the first period
    True
    """
    c = _records(sizes, "sizes")
    extent = check_positive(extent, "extent")
    fraction = check_in_range(fraction, "fraction", 0.0, 1.0, low_closed=False)
    full = fraction * extent
    if c[0] >= full:
        return None
    below = c < full
    last = c.size if below.all() else int(np.argmax(~below)) + 1
    if last < 2:
        return None
    return float(np.polyfit(np.arange(last), c[:last], 1)[0])


def front_fate(defects, widths, extent, *, fronts=None, alive=None, settle_tol=1e-6, front_max=4.0,
               invade_fraction=0.8, drift_tol=None, settle_width=None, decay_periods=None, stationary_periods=3,
               localized=False):
    r"""Classify a time-stepped front from its per-period records (module docstring).

    The rules, in this order (the first that holds gives the label):

    1. ``"invades"``: the disordered width reaches ``invade_fraction * extent`` or grows by more
       than ``front_max`` over the run; rate: :func:`invasion_speed` (width per period).
    2. ``"collapses"`` (``alive`` given): one phase took over in the last period; rate: front
       velocity (least squares over the periods with both phases), if ``fronts`` is given.
    3. ``"drifts"`` (``fronts`` given): the width stays <= ``front_max`` but the front moves by
       more than ``drift_tol``; rate: front velocity.
    4. ``"settles"``: defect of the last period < ``settle_tol``, width <= ``front_max``
       throughout and <= ``settle_width`` in the last period.
    5. ``"decays"`` (``decay_periods`` = p given): the width is <= ``settle_width`` over the last
       p periods and the last defect is below the one p periods earlier.
    6. ``"stationary"`` (``stationary_periods`` = p given): over the last p periods the width
       is constant and the front moves by <= ``drift_tol``, the width is never above
       ``max(front_max, widths[0] + front_max)``, but the defect stays above ``settle_tol``
       (a localized state that is not T-periodic to that tolerance).
    7. ``"localized disorder"`` (``localized=True``): the last width is > 0.
    8. ``"undecided"``.

    Parameters
    ----------
    defects : array_like of float, shape (n_periods,)
        Periodicity defect after each period, finite, >= 0.
    widths : array_like of float, shape (n_periods,)
        Disordered width after each period (length, or number of nodes), finite, >= 0.
    extent : float
        Size of the domain in the unit of ``widths`` (kink: length; oscillon: r_max; or the
        number of nodes), > 0.
    fronts : array_like of float, shape (n_periods,), optional
        Front position after each period (kink: distance of the phase switch from the left
        end; oscillon: core radius).  Without it there is no ``"drifts"`` and no front velocity.
    alive : array_like of bool, shape (n_periods,), optional
        Both phases present after each period (default: all True, no ``"collapses"``).
    settle_tol : float
        Defect below which the last period counts as periodic, > 0.
    front_max : float
        Largest width of a bounded front and largest growth that is not an invasion, in
        [0, inf] (inf: only filling the domain is an invasion).
    invade_fraction : float
        Filled fraction of the domain that is an invasion, in (0, 1].
    drift_tol : float, optional
        Largest front displacement that counts as stationary, >= 0; default ``extent / 20``.
    settle_width : float, optional
        Largest width of the last period (and, for ``"decays"``, of the last ``decay_periods``)
        of a settled front, in [0, inf]; default ``front_max``.
    decay_periods : int, optional
        Periods of rule 5, >= 1; None (default): no ``"decays"``.
    stationary_periods : int, optional
        Periods of rule 6, >= 2; None: no ``"stationary"``.  Default 3.
    localized : bool
        Rule 7 (default off).

    Returns
    -------
    label : str
        One of :data:`FATES`.
    rate : float or None
        ``"invades"``: width per period (None if the domain filled within the first period);
        ``"drifts"``, ``"collapses"``: front velocity (None without ``fronts``); otherwise None.

    Raises
    ------
    ValueError
        If a record is empty, of another length than ``defects``, not finite or negative, or an
        option is out of its range (the message names it).

    Examples
    --------
    The existence-map rules (defaults):

    >>> front_fate([1e-2, 1e-5, 1e-8], [1.0, 1.0, 1.0], 40.0, fronts=[20.0, 20.0, 20.0])
    ('settles', None)
    >>> label, rate = front_fate([3.0] * 4, [2.0, 12.0, 22.0, 38.0], 40.0, fronts=[20.0] * 4)
    >>> label, round(rate, 9)
    ('invades', 11.8)
    >>> label, rate = front_fate([1e-1] * 4, [0.0] * 4, 40.0, fronts=[20.0, 21.0, 22.0, 23.0])
    >>> label, round(rate, 9)
    ('drifts', 1.0)

    The soft-kink rules (disordered nodes of a 12-node lattice):

    >>> soft = dict(front_max=float("inf"), settle_width=0, decay_periods=5, stationary_periods=None,
    ...             localized=True)
    >>> front_fate([1e-1, 1e-2, 1e-3, 1e-4, 1e-4, 1e-5], [2, 0, 0, 0, 0, 0], 12, **soft)
    ('decays', None)
    >>> front_fate([1e-2, 1e-3, 1e-3], [2, 3, 3], 12, **soft)
    ('localized disorder', None)
    """
    defects = _records(defects, "defects")
    n = defects.size
    widths = _records(widths, "widths", n)
    fronts = None if fronts is None else _records(fronts, "fronts", n, minimum=None)
    if alive is None:
        alive = np.ones(n, bool)
    else:
        alive = np.asarray(alive)
        if alive.dtype != bool or alive.shape != (n,):
            raise ValueError(f"alive must be a bool array of shape ({n},), got dtype {alive.dtype}, "
                             f"shape {alive.shape}")
    extent = check_positive(extent, "extent")
    settle_tol = check_positive(settle_tol, "settle_tol")
    front_max = _bound(front_max, "front_max")
    invade_fraction = check_in_range(invade_fraction, "invade_fraction", 0.0, 1.0, low_closed=False)
    drift_tol = extent / 20.0 if drift_tol is None else check_nonnegative(drift_tol, "drift_tol")
    settle_width = front_max if settle_width is None else _bound(settle_width, "settle_width")
    if decay_periods is not None:
        decay_periods = check_int(decay_periods, "decay_periods", minimum=1)
    if stationary_periods is not None:
        stationary_periods = check_int(stationary_periods, "stationary_periods", minimum=2)
    if not isinstance(localized, (bool, np.bool_)):
        raise ValueError(f"localized must be True or False, got {localized!r}")

    k = np.arange(n)
    full = invade_fraction * extent
    if widths.max() >= full or widths[-1] - widths[0] > front_max:
        return "invades", invasion_speed(widths, extent, invade_fraction)
    live = np.flatnonzero(alive)
    rate = (float(np.polyfit(k[live], fronts[live], 1)[0])
            if fronts is not None and live.size >= 2 else None)
    if not alive[-1]:
        return "collapses", rate
    if fronts is not None and widths.max() <= front_max and np.ptp(fronts) > drift_tol:
        return "drifts", rate
    if defects[-1] < settle_tol and widths.max() <= front_max and widths[-1] <= settle_width:
        return "settles", None
    p = decay_periods
    if p is not None and n >= p + 1 and widths[-p:].max() <= settle_width and defects[-1] < defects[-p - 1]:
        return "decays", None
    p = stationary_periods
    if (p is not None and n >= p and np.ptp(widths[-p:]) == 0.0
            and (fronts is None or np.ptp(fronts[-p:]) <= drift_tol)
            and widths.max() <= max(front_max, widths[0] + front_max)):
        return "stationary", None
    if localized and widths[-1] > 0:
        return "localized disorder", None
    return "undecided", None


def chain_statistics(t, node, kind, t_start, period, n_nodes, tol=1e-9):
    """Classify the contacts of one period of a lattice orbit: touches, smooth and triggered sticks.

    A contact is a landing (``"impact"``: a touch; ``"stick"``) and, for a stick, the node's
    next lift-off (cyclically in the period).  A stick whose lift-off is within ``tol`` of its
    landing is a touch (lands and leaves at once); a lift-off within ``tol`` (mod T) of a
    lattice neighbour's landing is *triggered* (the neighbour's velocity jump makes the
    reaction tensile), otherwise *smooth*.

    Parameters
    ----------
    t : array_like of float, shape (n_events,)
        Event times of one period.
    node : array_like of int, shape (n_events,)
        Event nodes, in [0, n_nodes); node j's neighbours are j - 1 and j + 1.
    kind : array_like of str, shape (n_events,)
        ``"impact"``, ``"stick"`` or ``"liftoff"``.
    t_start, period : float
        Start of the period and the period T (> 0); times are taken modulo T from ``t_start``.
    n_nodes : int
        Nodes of the chain, >= 1.
    tol : float
        Touch and trigger tolerance, > 0.

    Returns
    -------
    dict
        ``touch``, ``stick_smooth``, ``stick_triggered`` (int, per period),
        ``chain_durations`` (ndarray of float, shape (n_triggered,): stuck times of the
        triggered sticks) and ``chain_nodes`` (ndarray of int, shape (n_triggered,)).

    Examples
    --------
    >>> import numpy as np
    >>> st = chain_statistics([1.0, 5.0, 5.3, 5.3, 7.0], [0, 0, 0, 1, 1],
    ...                       ["impact", "stick", "liftoff", "stick", "liftoff"], 0.0, 4 * np.pi, 2)
    >>> st["touch"], st["stick_smooth"], st["stick_triggered"], st["chain_nodes"].tolist()
    (1, 1, 1, [0])
    >>> round(float(st["chain_durations"][0]), 12)
    0.3
    """
    t = check_array(t, "t", ndim=1)
    node = np.asarray(node)
    kind = np.asarray(kind).astype(str)
    n_nodes = check_int(n_nodes, "n_nodes", minimum=1)
    if node.shape != t.shape or kind.shape != t.shape:
        raise ValueError(f"node and kind must have the shape of t {t.shape}, got {node.shape} and {kind.shape}")
    if node.size and (node.dtype.kind not in "iu" or node.min() < 0 or node.max() >= n_nodes):
        raise ValueError(f"node must hold integers in [0, {n_nodes - 1}], got {node!r}")
    bad = sorted(set(kind.tolist()) - {"impact", "stick", "liftoff"})
    if bad:
        raise ValueError(f"kind must be 'impact', 'stick' or 'liftoff', got {bad}")
    t_start = check_real(t_start, "t_start")
    period = check_positive(period, "period")
    tol = check_positive(tol, "tol")
    s = (t - t_start) % period
    landings = {j: s[(node == j) & (kind != "liftoff")] for j in range(n_nodes)}
    out = dict(touch=0, stick_smooth=0, stick_triggered=0, chain_durations=[], chain_nodes=[])
    for j in range(n_nodes):
        sel = node == j
        ev = sorted(zip(s[sel], kind[sel]))
        if not ev:
            continue
        for tk, kk in ev:
            if kk == "impact":
                out["touch"] += 1
                continue
            if kk != "stick":
                continue
            lifts = [tl - tk for tl, kl in ev if kl == "liftoff"]
            if not lifts:
                continue
            signed = [((d + 0.5 * period) % period) - 0.5 * period for d in lifts]
            if min(abs(d) for d in signed) < tol:       # lands and leaves at once (same event set)
                out["touch"] += 1
                continue
            dur = min(d % period for d in lifts)
            t_lift = (tk + dur) % period
            neigh = [i for i in (j - 1, j + 1) if 0 <= i < n_nodes]
            trig = any(np.any(np.abs(((landings[i] - t_lift + 0.5 * period) % period) - 0.5 * period) < tol)
                       for i in neigh)
            if trig:
                out["stick_triggered"] += 1
                out["chain_durations"].append(dur)
                out["chain_nodes"].append(j)
            else:
                out["stick_smooth"] += 1
    out["chain_durations"] = np.asarray(out["chain_durations"], dtype=float)
    out["chain_nodes"] = np.asarray(out["chain_nodes"], dtype=int)
    return out

