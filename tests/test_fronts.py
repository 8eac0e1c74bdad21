"""The fate of a front, its invasion speed and its contact chains (tps_solver.analyses.fronts)."""
import math

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.analyses.fronts import FATES, chain_statistics, front_fate, invasion_speed

SOFT = dict(front_max=math.inf, settle_width=0.0, decay_periods=5, stationary_periods=None, localized=True)


# ------------------------------------------------------------------ invasion speed
@pytest.mark.parametrize("slope, offset", [(2.5, 1.0), (0.75, 0.0), (7.0, 3.0)])
def test_invasion_speed_recovers_a_manufactured_slope(slope, offset):
    """A linear ramp, saturated once it fills 80 % of the domain: the slope of the ramp, whatever follows."""
    extent = 100.0
    k = np.arange(400)
    sizes = np.minimum(offset + slope * k, extent)
    assert invasion_speed(sizes, extent) == pytest.approx(slope, rel=1e-12)
    # the periods after the first filled one do not enter: noise there changes nothing
    first = int(np.argmax(sizes >= 0.8 * extent))
    noisy = sizes.copy()
    noisy[first + 1:] = np.random.default_rng(0).uniform(0.0, extent, noisy.size - first - 1)
    assert invasion_speed(noisy, extent) == pytest.approx(slope, rel=1e-12)


def test_invasion_speed_of_a_noisy_ramp_is_the_least_squares_slope():
    rng = np.random.default_rng(3)
    k = np.arange(12)
    sizes = 2.0 + 1.5 * k + rng.normal(0.0, 0.2, k.size)
    kb = k - k.mean()                                   # closed-form least-squares slope
    want = float(np.sum(kb * (sizes - sizes.mean())) / np.sum(kb ** 2))
    assert invasion_speed(sizes, 1e3) == pytest.approx(want, rel=1e-12)


def test_invasion_speed_none_when_filled_at_once():
    assert invasion_speed([9.0, 10.0], 10.0) is None
    assert invasion_speed([3.0], 10.0) is None
    assert invasion_speed([1.0, 9.0, 10.0], 10.0) == pytest.approx(8.0, rel=1e-12)   # two periods: their slope


@pytest.mark.parametrize("kw, name", [
    (dict(sizes=[]), "sizes"), (dict(sizes=[1.0, -1.0]), "sizes"), (dict(sizes=[[1.0]]), "sizes"),
    (dict(sizes=[1.0, np.nan]), "sizes"), (dict(extent=0.0), "extent"), (dict(fraction=0.0), "fraction"),
    (dict(fraction=1.5), "fraction"),
])
def test_invasion_speed_bad_input(kw, name):
    args = dict(sizes=[1.0, 2.0], extent=10.0, fraction=0.8)
    args.update(kw)
    with pytest.raises(ValueError, match=name):
        invasion_speed(**args)


# ------------------------------------------------------------------ front fate: existence-map rules
def test_front_fate_invades_at_the_manufactured_rate():
    k = np.arange(8)
    widths = np.minimum(0.4 + 3.0 * k, 40.0)
    label, rate = front_fate(np.ones(8), widths, 40.0, fronts=np.full(8, 20.0))
    assert label == "invades" and rate == pytest.approx(3.0, rel=1e-12)
    # growth by more than front_max without filling the domain is an invasion too
    label, rate = front_fate([1.0] * 3, [1.0, 3.0, 6.0], 40.0, front_max=4.0)
    assert label == "invades" and rate == pytest.approx(2.5, rel=1e-12)


def test_front_fate_drift_and_collapse_rates_are_front_velocities():
    k = np.arange(6)
    label, rate = front_fate([0.1] * 6, [0.8] * 6, 40.0, fronts=20.0 - 0.7 * k)
    assert label == "drifts" and rate == pytest.approx(-0.7, rel=1e-12)
    alive = np.array([True] * 4 + [False] * 2)
    fronts = np.where(alive, 10.0 + 2.0 * k, 40.0)          # dead periods do not enter the fit
    label, rate = front_fate([0.1] * 6, [0.0] * 6, 40.0, fronts=fronts, alive=alive)
    assert label == "collapses" and rate == pytest.approx(2.0, rel=1e-12)


@pytest.mark.parametrize("defects, widths, fronts, want", [
    ([1e-2, 1e-5, 1e-8], [0.4, 0.4, 0.0], [20.0] * 3, "settles"),
    ([1e-3] * 4, [6.8] * 4, [20.0] * 4, "stationary"),            # frozen, not periodic; width > front_max
    ([1e-3] * 4, [0.0, 1.0, 0.4, 1.2], [20.0] * 4, "undecided"),  # width still changes
    ([1e-3] * 2, [0.4] * 2, [20.0] * 2, "undecided"),             # too short to be stationary
    ([1e-8] * 3, [4.4] * 3, [20.0] * 3, "stationary"),            # periodic but wider than front_max
])
def test_front_fate_labels(defects, widths, fronts, want):
    assert front_fate(defects, widths, 40.0, fronts=fronts) == (want, None)


def test_front_fate_without_fronts_has_no_drift():
    """A moving front is 'drifts' only when the front positions are given."""
    assert front_fate([0.1] * 4, [0.0] * 4, 40.0, fronts=[20.0, 21.0, 22.0, 23.0])[0] == "drifts"
    assert front_fate([0.1] * 4, [0.0] * 4, 40.0) == ("stationary", None)


# ------------------------------------------------------------------ front fate: soft-kink rules
@pytest.mark.parametrize("defects, counts, want", [
    ([1e-2, 1e-4, 1e-7], [3, 1, 0], "settles"),
    ([1e-2, 1e-4, 1e-7], [3, 1, 1], "localized disorder"),         # periodic but disordered nodes left
    ([1e-1, 1e-2, 1e-3, 1e-3, 1e-4, 1e-5], [4, 0, 0, 0, 0, 0], "decays"),
    ([1e-1] * 2 + [1e-2, 1e-3, 1e-3, 1e-4, 1e-5], [4, 1, 0, 0, 0, 0, 0], "decays"),   # window: last five only
    ([1e-1, 1e-2, 1e-3, 1e-3, 1e-4, 1e-5], [4, 0, 0, 1, 0, 0], "undecided"),
    ([1e-3, 1e-2, 1e-3, 1e-3, 1e-4, 2e-3], [4, 0, 0, 0, 0, 0], "undecided"),  # defect did not fall
    ([1e-3] * 4, [2, 2, 2, 2], "localized disorder"),              # no "stationary" in these rules
])
def test_front_fate_soft_kink_rules(defects, counts, want):
    assert front_fate(defects, counts, 12, **SOFT) == (want, None)


def test_front_fate_soft_kink_invasion_in_nodes_per_period():
    counts = [1, 3, 5, 7, 9, 10, 12, 12]           # 80 % of 12 nodes = 9.6: reached in period 6 (index 5)
    label, rate = front_fate([1.0] * 8, counts, 12, **SOFT)
    want = float(np.polyfit(np.arange(6), counts[:6], 1)[0])
    assert label == "invades" and rate == pytest.approx(want, rel=1e-12) and rate == pytest.approx(13.0 / 7.0, rel=1e-12)
    # unbounded growth short of 80 % is no invasion under these rules
    assert front_fate([1.0] * 4, [0, 3, 6, 9], 12, **SOFT)[0] == "localized disorder"


def test_front_fate_labels_are_the_documented_set():
    seen = {front_fate([1e-3] * 4, [6.8] * 4, 40.0)[0], front_fate([1.0] * 3, [1.0, 3.0, 6.0], 40.0)[0],
            front_fate([1e-2, 1e-3, 1e-3], [2, 3, 3], 12, **SOFT)[0]}
    assert seen <= set(FATES)


def test_front_fate_is_public():
    assert tps.front_fate is front_fate and tps.invasion_speed is invasion_speed


@pytest.mark.parametrize("kw, name", [
    (dict(defects=[]), "defects"), (dict(widths=[1.0]), "widths"), (dict(widths=[-1.0, 0.0]), "widths"),
    (dict(defects=[np.nan, 1.0]), "defects"), (dict(fronts=[1.0]), "fronts"), (dict(alive=[1, 1]), "alive"),
    (dict(extent=-1.0), "extent"), (dict(settle_tol=0.0), "settle_tol"), (dict(front_max=-1.0), "front_max"),
    (dict(front_max=float("nan")), "front_max"), (dict(invade_fraction=2.0), "invade_fraction"),
    (dict(drift_tol=-1.0), "drift_tol"), (dict(settle_width=-1.0), "settle_width"),
    (dict(decay_periods=0), "decay_periods"), (dict(stationary_periods=1), "stationary_periods"),
    (dict(localized="yes"), "localized"),
])
def test_front_fate_bad_input(kw, name):
    args = dict(defects=[1.0, 1.0], widths=[0.0, 0.0], extent=40.0)
    args.update(kw)
    with pytest.raises(ValueError, match=name):
        front_fate(**args)


# ------------------------------------------------------------------ contact chains
def test_chain_statistics_counts_touches_smooth_and_triggered_sticks():
    T = 4 * np.pi
    # node 0: touch at 1.0; stick at 5.0 lifted off at 5.3 by node 1's landing (triggered, 0.3)
    # node 1: stick at 5.3, smooth lift-off at 7.0; node 2: stick at T - 0.5 lifting off at 0.2 after the wrap
    t = np.array([1.0, 5.0, 5.3, 5.3, 7.0, T - 0.5, 0.2])
    node = np.array([0, 0, 0, 1, 1, 2, 2])
    kind = np.array(["impact", "stick", "liftoff", "stick", "liftoff", "stick", "liftoff"])
    st = chain_statistics(t, node, kind, 0.0, T, 3)
    assert (st["touch"], st["stick_smooth"], st["stick_triggered"]) == (1, 2, 1)
    assert st["chain_nodes"].tolist() == [0] and st["chain_durations"] == pytest.approx([0.3], abs=1e-14)
    assert st["chain_durations"].dtype == float and st["chain_nodes"].dtype.kind == "i"


@pytest.mark.parametrize("kw, name", [
    (dict(node=[0, 5]), "node"), (dict(kind=["impact", "bounce"]), "kind"), (dict(period=0.0), "period"),
    (dict(n_nodes=0), "n_nodes"), (dict(tol=-1.0), "tol"), (dict(t=[1.0]), "node"),
])
def test_chain_statistics_bad_input(kw, name):
    args = dict(t=[1.0, 2.0], node=[0, 1], kind=["impact", "stick"], t_start=0.0, period=4 * np.pi, n_nodes=2)
    args.update(kw)
    with pytest.raises(ValueError, match=name):
        chain_statistics(**args)


# ------------------------------------------------------------------ front width (the one of analyses.localized)
class _StickLikeKink:
    """A manufactured tanh front between far fields with a high and a low flight, half a period apart.

    Like a StickSolution: ``nodes``, ``period``, ``height(t)``, no ``lattice`` and no ``t_start``.
    theta = (1 + tanh(x / w)) / 2 at every instant, so every instant has the 10-90 width 2 atanh(0.8) w.
    """

    period = 4 * np.pi

    def __init__(self, w, n=20001):
        self.w, self.nodes = w, np.linspace(-15.0 * w, 15.0 * w, n)

    @staticmethod
    def far_fields(t):
        t = np.atleast_1d(np.asarray(t, float))
        zl = 2.0 + np.cos(t / 2) + 0.6 * np.cos(t)          # high flight near t = 0, low flight near t = 2 pi
        zr = 2.0 - np.cos(t / 2) + 0.6 * np.cos(t)          # zl half a period later
        return zl, zr

    def height(self, t):
        zl, zr = self.far_fields(t)
        return zl[:, None] + (zr - zl)[:, None] * 0.5 * (1.0 + np.tanh(self.nodes[None, :] / self.w))


@pytest.mark.parametrize("w", [0.5, 2.0])
def test_front_width_at_the_lower_far_field_top_of_a_manufactured_front(w):
    want = 2.0 * math.atanh(0.8) * w
    orb = _StickLikeKink(w)
    (width,), (t,) = tps.front_width(orb, n_samples=256, instant="lower_far_field_top", return_times=True)
    assert abs(width - want) <= 1e-6 * want
    ts = orb.period * np.arange(256) / 256                  # the instant: min(zeta_L, zeta_R) largest
    zl, zr = orb.far_fields(ts)
    assert t == ts[int(np.argmax(np.minimum(zl, zr)))]
    assert min(orb.far_fields(t)[0][0], orb.far_fields(t)[1][0]) == pytest.approx(np.max(np.minimum(zl, zr)))
    wl, wr = tps.front_width(orb, n_samples=256)            # the default instants give the same analytic width
    assert abs(wl - want) <= 1e-6 * want and abs(wr - want) <= 1e-6 * want


def test_front_width_lower_top_refuses_crossing_far_fields():
    orb = _StickLikeKink(1.0, n=401)
    orb.far_fields = lambda t: (1.0 + np.sin(np.atleast_1d(t) / 2), 1.0 - np.sin(np.atleast_1d(t) / 2))
    with pytest.raises(ValueError, match="ill-conditioned"):
        tps.front_width(orb, instant="lower_far_field_top")
    assert tps.front_width(orb)[0] == pytest.approx(2.0 * math.atanh(0.8), rel=1e-3)


def test_front_width_takes_a_stick_solution_and_checks_its_options():
    from tps_solver.solvers.tps.stick import solve_stick_flat

    flat = solve_stick_flat(4.1, n_nodes=4, length=6.0, perturbation=1e-3)
    with pytest.raises(ValueError, match="no front"):            # read as a lattice orbit, but it is flat
        tps.front_width(flat, instant="lower_far_field_top")
    with pytest.raises(ValueError, match="instant"):
        tps.front_width(_StickLikeKink(1.0, n=11), instant="max_contrast")
    with pytest.raises(ValueError, match="n_samples"):
        tps.front_width(_StickLikeKink(1.0, n=11), n_samples=4)


# ------------------------------------------------------------------ the study alphabet as a view of ContactPattern
def test_event_sequences_of_a_manufactured_pattern():
    """Known contacts -> known tokens: landings T/S/s, lift-offs L/L*, rotated to the first lift-off."""
    T = 4 * math.pi
    p = tps.ContactPattern.from_contacts(
        node=[0, 0, 1, 1, 2], t=[3.0, 6.0, 0.5, 7.0, 9.0], kind=["touch", "stick", "stick", "stick", "touch"],
        liftoff=[math.nan, 1.0 + T, 3.5, 11.0, math.nan], trigger=[-1, -1, -1, 0, -1], n_nodes=3, period=T)
    # node 0: lift-off at 1 (smooth, from the rest across the section), touch 3, stick 6; node 1: stick 0.5
    # off at 3.5, stick 7 off at 11 (triggered by node 0); node 2: a touch only (no lift-off: no rotation)
    assert p.event_sequences() == ["L T S", "L S L* S", "T"]
    # times at rest of node 1: 3.0 and 4.0
    assert p.event_sequences(brief=3.5) == ["L T S", "L S L* s", "T"]
    with pytest.raises(ValueError, match="brief"):
        p.event_sequences(brief=-1.0)


def test_inelastic_kinks_summary_is_the_pattern_view():
    """validation.inelastic_kinks.contact_pattern on hand-built events: sequences from ContactPattern."""
    from validation.inelastic_kinks import contact_pattern, orbit_pattern

    T = 4 * math.pi
    ev = np.rec.fromrecords([(0.5, 2, "stick"), (1.0, 0, "liftoff"), (3.0, 1, "impact"), (3.000001, 2, "liftoff"),
                             (5.0, 0, "impact"), (6.0, 0, "stick"), (6.0, 1, "liftoff"), (7.0, 1, "stick"),
                             (9.0, 2, "impact")], names="t,node,kind")
    pat = orbit_pattern(ev, 3, T)
    assert pat.sequences() == ["TS", "TS", "ST"]
    assert pat.ended_by.tolist() == ["", "smooth", "", "triggered", "smooth", ""] and pat.trigger.tolist()[3] == 0
    assert pat.rest_times()[[1, 3, 4]] == pytest.approx([1.0 + T - 6.0, 6.0 + T - 7.0, 2.500001], abs=1e-12)
    p = contact_pattern(ev, 3, T, sticking_intervals=[], brief=2.6)
    assert p["sequences"] == ["L T S", "L* S T", "L T s"] == pat.event_sequences(brief=2.6)
    assert p["stuck_times"][2] == pytest.approx([2.500001], abs=1e-12) and p["brief_sticks"] == 1
