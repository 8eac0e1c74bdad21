"""The one-node flight and its certified landing (tps_solver.model.flight) against mpmath.

The references use the textbook form (17) of the flight, which cancels about
log10(1/d^2) digits for a flight of length d (a 1e-12 flight: 24), so they run at 30 + 30 digits:
30 significant digits after the cancellation."""
import math

import mpmath as mp
import numpy as np
import pytest

from tps_solver.model.flight import Flight, gravity_zeros, next_liftoff, one_minus_cos, sin_minus_x

EPS = np.finfo(float).eps
DPS = 60


def _mp_flight(t_a, w_a, G, z_a):
    """w(d), z(d) of the same (binary) launch data (evaluate under mp.workdps(DPS))."""
    ta, wa, za, Gm = mp.mpf(t_a), mp.mpf(w_a), mp.mpf(z_a), mp.mpf(G)

    def w(d):
        return wa + mp.cos(ta) - mp.cos(ta + d) - d / Gm

    def z(d):
        return za + (wa + mp.cos(ta)) * d + mp.sin(ta) - mp.sin(ta + d) - d * d / (2 * Gm)

    return w, z


def _check_landing(t_a, w_a, G, z_a, d_guess_lo, d_guess_hi, ulps=8):
    """The landing against the mpmath root bracketed in [lo, hi]; error within the root's conditioning."""
    fl = Flight(t_a, w_a, G, z_a)
    d = fl.first_landing(40.0)
    with mp.workdps(DPS):
        w, z = _mp_flight(t_a, w_a, G, z_a)
        ref = mp.findroot(z, (mp.mpf(d_guess_lo), mp.mpf(d_guess_hi)), solver="illinois")
        # |z| is computed to eps times the sum of the moduli of its terms: that over |w| is the
        # root's condition; plus the rounding of d itself
        ta = mp.mpf(t_a)
        terms = (abs(mp.mpf(z_a)) + abs((mp.mpf(w_a) + mp.cos(ta)) * ref) + abs(mp.sin(ta)) * (1 - mp.cos(ref))
                 + abs(mp.cos(ta)) * abs(mp.sin(ref) - ref) + ref * ref / (2 * G))
        bound = ulps * EPS * (abs(ref) + float(terms / abs(w(ref))))
        assert d is not None
        assert abs(d - float(ref)) <= bound, (d, float(ref), bound)
    return d, float(ref)


def test_series_helpers_against_mpmath():
    with mp.workdps(DPS):
        for x in (1e-12, 1e-6, 1e-3, 0.1, 0.5, 0.999, 1.5, 3.0):
            assert abs(sin_minus_x(x) - float(mp.sin(x) - x)) <= 2 * EPS * abs(float(mp.sin(x) - x))
            assert abs(one_minus_cos(x) - float(1 - mp.cos(x))) <= 2 * EPS * float(1 - mp.cos(x))


@pytest.mark.parametrize("G", [1.2, 2.5, 3.9, 4.1, 4.4, 6.0, 9.5])
def test_launch_from_rest_at_the_liftoff_phase(G):
    """sin t_a = 1/Gamma to 1 ulp: w and zeta start with the wrong sign by round-off, no false landing."""
    t_a = math.asin(1.0 / G)
    fl = Flight(t_a, 0.0, G)
    d = fl.first_landing(40.0)
    assert d is not None and d > 1.0
    _check_landing(t_a, 0.0, G, 0.0, 0.9 * d, 1.1 * d)


@pytest.mark.parametrize("v", [1e-2, 1e-5, 1e-8, 1e-12])
@pytest.mark.parametrize("t_a", [3.6, 4.7, 5.9])
def test_short_chatter_flights_keep_relative_precision(v, t_a):
    """A rebound at speed v where g < 0 lands after about 2 v/|g|: relative error a few eps."""
    G = 4.1
    g = math.sin(t_a) - 1.0 / G
    d, ref = _check_landing(t_a, v, G, 0.0, 1.5 * v / -g, 2.5 * v / -g)
    assert abs(d - ref) <= 8 * EPS * ref


@pytest.mark.parametrize("delta", [1e-6, 1e-10, 1e-14])
def test_grazing_landing_is_found(delta):
    """A fall that turns round (w = 0, g > 0) at height -delta: the landing just before (sqrt conditioning)."""
    G = 4.1
    t_a, w_a = math.asin(1 / G) + 0.1, -0.5         # falling while g > 0: w reaches 0 at d_min
    with mp.workdps(DPS):
        w, z = _mp_flight(t_a, w_a, G, 0.0)
        d_min = mp.findroot(w, (mp.mpf(0.1), mp.mpf(2.5)), solver="illinois")
        assert mp.sin(t_a + d_min) > 1 / mp.mpf(G) and 0 < d_min < 2.5
        z_a = float(-z(d_min) - delta)
    fl = Flight(t_a, w_a, G, z_a)
    d = fl.first_landing(4 * math.pi)
    assert d is not None and d < float(d_min)
    width = math.sqrt(2 * delta / (math.sin(t_a + float(d_min)) - 1 / G))
    _check_landing(t_a, w_a, G, z_a, float(d_min) - 3 * width, float(d_min))
    # the same turn at +delta: no landing there (the next one is after the next fall)
    with mp.workdps(DPS):
        z_miss = float(-z(d_min) + delta)
    d_miss = Flight(t_a, w_a, G, z_miss).first_landing(4 * math.pi)
    assert d_miss is None or d_miss > float(d_min) + 1.0


def test_gravity_zeros_and_liftoff():
    G = 2.0
    z = gravity_zeros(-7.0, 7.0, G)
    assert np.allclose(np.sin(z), 0.5, atol=1e-15) and len(z) == 5
    assert abs(next_liftoff(0.6, G) - (math.pi / 6 + 2 * math.pi)) < 1e-15
    assert next_liftoff(0.0, 0.9) is None
