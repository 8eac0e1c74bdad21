"""The shared argument checks of ``tps_solver.core.checks``."""
import math

import numpy as np
import pytest

from tps_solver.core.checks import (check_array, check_choice, check_in_range, check_int, check_nonnegative, check_positive, check_real, check_restitution)

GOOD = [
    (check_real, (-3,), -3.0),
    (check_real, (np.float32(0.5),), 0.5),
    (check_real, (np.array(2.0),), 2.0),
    (check_positive, (2.5,), 2.5),
    (check_positive, (np.int64(3),), 3.0),
    (check_nonnegative, (0,), 0.0),
    (check_in_range, (1.0, 0.0, 1.0), 1.0),
    (check_restitution, (0.0,), 0.0),
    (check_restitution, (0.999,), 0.999),
    (check_int, (2,), 2),
    (check_int, (np.int64(4),), 4),
    (check_choice, ("stable", ("stable", "unstable")), "stable"),
]


@pytest.mark.parametrize("func, args, expected", GOOD)
def test_accepts_and_canonicalises(func, args, expected):
    out = func(args[0], "x", *args[1:])
    assert out == expected and type(out) is type(expected)


BAD = [
    # (func, value, extra args, kwargs, fragment of the stated range)
    (check_real, math.nan, (), {}, "finite real"),
    (check_real, math.inf, (), {}, "finite real"),
    (check_real, "1", (), {}, "finite real"),
    (check_real, True, (), {}, "finite real"),
    (check_real, 1 + 2j, (), {}, "finite real"),
    (check_real, np.array([1.0]), (), {}, "finite real"),
    (check_positive, 0.0, (), {}, "> 0"),
    (check_positive, -1e-300, (), {}, "> 0"),
    (check_positive, math.nan, (), {}, "> 0"),
    (check_positive, -math.inf, (), {}, "> 0"),
    (check_positive, None, (), {}, "> 0"),
    (check_nonnegative, -1e-12, (), {}, ">= 0"),
    (check_nonnegative, math.nan, (), {}, ">= 0"),
    (check_in_range, 1.0, (0.0, 1.0), dict(high_closed=False), "[0.0, 1.0)"),
    (check_in_range, 0.0, (0.0, 1.0), dict(low_closed=False), "(0.0, 1.0]"),
    (check_in_range, -0.5, (0.0, 1.0), {}, "[0.0, 1.0]"),
    (check_in_range, math.nan, (0.0, 1.0), {}, "[0.0, 1.0]"),
    (check_restitution, 1.0, (), {}, "[0.0, 1.0)"),
    (check_restitution, -0.01, (), {}, "[0.0, 1.0)"),
    (check_restitution, math.nan, (), {}, "[0.0, 1.0)"),
    (check_int, 0, (), {}, ">= 1"),
    (check_int, -1, (), {}, ">= 1"),
    (check_int, 2.5, (), {}, ">= 1"),
    (check_int, True, (), {}, ">= 1"),
    (check_int, "2", (), {}, ">= 1"),
    (check_int, 7, (), dict(minimum=1, maximum=5), "in [1, 5]"),
    (check_choice, "Stable", (("stable", "unstable"),), {}, "'stable', 'unstable'"),
    (check_choice, None, (("stable", "unstable"),), {}, "'stable', 'unstable'"),
]


@pytest.mark.parametrize("func, value, args, kwargs, allowed", BAD)
def test_rejects_with_name_and_range(func, value, args, kwargs, allowed):
    with pytest.raises(ValueError) as info:
        func(value, "param", *args, **kwargs)
    msg = str(info.value)
    assert msg.startswith("param ")
    assert allowed in msg


def test_check_array():
    a = check_array([[1, 2], [3, 4]], "A", shape=(None, 2))
    assert a.dtype == float and a.shape == (2, 2)
    src = np.ones(3)
    assert check_array(src, "A") is not src                # a copy
    c = check_array([1j, 2.0], "A", dtype=complex)
    assert c.dtype == complex
    for value, kwargs, fragment in [
        ([1.0, math.nan], {}, "finite"),
        ([1.0, math.inf], {}, "finite"),
        ([1j, 2.0], {}, "real-valued"),
        (["a"], {}, "numeric"),
        ([1.0, 2.0], dict(ndim=2), "dimension"),
        ([[1.0, 2.0]], dict(shape=(None, 3)), "shape"),
        ([1.0, 2.0], dict(shape=(2, 1)), "shape"),
    ]:
        with pytest.raises(ValueError, match=rf"^A .*{fragment}"):
            check_array(value, "A", **kwargs)
    assert np.isnan(check_array([math.nan], "A", finite=False)[0])
