"""Argument checks shared by every public entry point.

Every check raises :class:`ValueError` whose message starts with the parameter
name and states the allowed range, e.g. ``"Gamma must be a finite number > 0,
got -1.0"``.  Checks return the value converted to its canonical type so callers
can write ``Gamma = check_positive(Gamma, "Gamma")``.
"""
import numbers
import operator

import numpy as np

__all__ = [
    "check_real", "check_positive", "check_nonnegative", "check_in_range",
    "check_restitution", "check_int", "check_choice", "check_array", "check_bool", "check_state_scale",
    "STATE_SCALE",
]

#: The largest magnitude of a state variable (velocity, height, thickness, in plate units) that the
#: integrators take: their flight algebra squares states and multiplies them by times, and 1e300
#: squared overflows (1e100 leaves room for products with times and coefficients).
STATE_SCALE = 1e100


def check_bool(value, name):
    """``value`` as a bool; only ``True``/``False`` (and numpy bools) are accepted.

    Examples
    --------
    >>> check_bool(True, "multipliers")
    True
    >>> check_bool("yes", "multipliers")
    Traceback (most recent call last):
    ...
    ValueError: multipliers must be True or False, got 'yes'
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")


def _is_real_scalar(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool) or (
        isinstance(value, np.ndarray) and value.ndim == 0 and np.isrealobj(value)
        and value.dtype.kind in "fiu")


def check_real(value, name):
    """Return ``value`` as a finite float or raise ``ValueError`` naming ``name``.

    Examples
    --------
    >>> check_real(3, "h")
    3.0
    >>> check_real(float("nan"), "h")
    Traceback (most recent call last):
    ...
    ValueError: h must be a finite real number, got nan
    >>> check_real(True, "h")
    Traceback (most recent call last):
    ...
    ValueError: h must be a finite real number, got True
    """
    if not _is_real_scalar(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    return value


def check_positive(value, name):
    """Return ``value`` as a float in (0, inf) or raise ``ValueError``.

    Examples
    --------
    >>> check_positive(2.5, "Gamma")
    2.5
    >>> check_positive(-1, "Gamma")
    Traceback (most recent call last):
    ...
    ValueError: Gamma must be a finite number > 0, got -1
    """
    if not _is_real_scalar(value) or not np.isfinite(float(value)) or float(value) <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def check_nonnegative(value, name):
    """Return ``value`` as a float in [0, inf) or raise ``ValueError``.

    Examples
    --------
    >>> check_nonnegative(0, "e")
    0.0
    >>> check_nonnegative(-0.5, "e")
    Traceback (most recent call last):
    ...
    ValueError: e must be a finite number >= 0, got -0.5
    """
    if not _is_real_scalar(value) or not np.isfinite(float(value)) or float(value) < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def check_in_range(value, name, low, high, *, low_closed=True, high_closed=True):
    """Return ``value`` as a float in the stated interval or raise ``ValueError``.

    Examples
    --------
    >>> check_in_range(1, "x", 0, 1)
    1.0
    >>> check_in_range(1, "x", 0, 1, high_closed=False)
    Traceback (most recent call last):
    ...
    ValueError: x must be a finite number in [0, 1), got 1
    """
    left = "[" if low_closed else "("
    right = "]" if high_closed else ")"
    message = f"{name} must be a finite number in {left}{low}, {high}{right}, got {value!r}"
    if not _is_real_scalar(value) or not np.isfinite(float(value)):
        raise ValueError(message)
    v = float(value)
    if (v < low if low_closed else v <= low) or (v > high if high_closed else v >= high):
        raise ValueError(message)
    return v


def check_restitution(value, name="e"):
    """Return the restitution as a float in [0, 1) or raise ``ValueError``.

    Examples
    --------
    >>> check_restitution(0.9)
    0.9
    >>> check_restitution(1.0)
    Traceback (most recent call last):
    ...
    ValueError: e must be a finite number in [0.0, 1.0), got 1.0
    """
    return check_in_range(value, name, 0.0, 1.0, low_closed=True, high_closed=False)


def check_int(value, name, minimum=1, maximum=None):
    """Return ``value`` as an ``int`` >= ``minimum`` (and <= ``maximum``) or raise.

    Integral floats (``2.0``, ``np.float64(4.0)``) are accepted and converted;
    booleans, non-integral and non-finite floats are rejected.

    Examples
    --------
    >>> check_int(2, "M")
    2
    >>> check_int(41.0, "n_nodes")
    41
    >>> check_int(2.5, "M")
    Traceback (most recent call last):
    ...
    ValueError: M must be an integer >= 1, got 2.5
    """
    bounds = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
    message = f"{name} must be an integer {bounds}, got {value!r}"
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(message)
    try:
        ivalue = operator.index(value)
    except TypeError:
        ivalue = _integral_float(value)
        if ivalue is None:
            raise ValueError(message) from None
    if ivalue < minimum or (maximum is not None and ivalue > maximum):
        raise ValueError(message)
    return int(ivalue)


def _integral_float(value):
    """``int(value)`` for a finite real float scalar with no fractional part, else None."""
    if not _is_real_scalar(value):
        return None
    v = float(value)
    if not np.isfinite(v) or v != int(v):
        return None
    return int(v)


def check_choice(value, name, choices):
    """Return ``value`` if it is one of ``choices`` or raise ``ValueError``.

    Examples
    --------
    >>> check_choice("soft", "method", ("point", "soft"))
    'soft'
    >>> check_choice("rk4", "method", ("point", "soft"))
    Traceback (most recent call last):
    ...
    ValueError: method must be one of 'point', 'soft', got 'rk4'
    """
    if not isinstance(value, str) or value not in choices:
        allowed = ", ".join(repr(c) for c in choices)
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
    return value


def check_array(value, name, *, shape=None, ndim=None, dtype=float, finite=True):
    """Return ``value`` as an ndarray of ``dtype`` with the given shape/ndim, or raise.

    ``shape`` entries may be ``None`` to accept any length along that axis.
    NaN or infinite entries are rejected when ``finite`` is true.

    Examples
    --------
    >>> check_array([1, 2, 3], "x", shape=(None,)).tolist()
    [1.0, 2.0, 3.0]
    >>> check_array([[1, 2]], "x", shape=(None,))
    Traceback (most recent call last):
    ...
    ValueError: x must have shape ('any',), got (1, 2)
    >>> check_array([1.0, float("inf")], "x")
    Traceback (most recent call last):
    ...
    ValueError: x must contain only finite values (no NaN or inf)
    """
    try:
        arr = np.asarray(value)
    except Exception as exc:  # pragma: no cover - exotic inputs
        raise ValueError(f"{name} must be array-like: {exc}") from None
    if arr.dtype.kind not in "biufc":
        raise ValueError(f"{name} must be numeric, got dtype {arr.dtype}")
    if np.dtype(dtype).kind == "f" and arr.dtype.kind == "c":
        raise ValueError(f"{name} must be real-valued, got complex entries")
    arr = arr.astype(dtype, copy=True)
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimension(s), got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = tuple("any" if s is None else s for s in shape)
            raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    return arr


def check_state_scale(values, name, scale=None):
    """Refuse a state array whose entries exceed :data:`STATE_SCALE` in magnitude (finite ones).

    Examples
    --------
    >>> check_state_scale(np.array([1.0, -2.0]), "w0")
    >>> check_state_scale(np.array([1e300]), "w0")
    Traceback (most recent call last):
    ...
    ValueError: w0 must hold values of magnitude <= 1e+100 (plate units; larger ones overflow the flight algebra), got 1e+300
    """
    scale = STATE_SCALE if scale is None else scale
    a = np.asarray(values, dtype=float)
    if a.size:
        big = float(np.max(np.abs(a)))
        if big > scale:
            raise ValueError(f"{name} must hold values of magnitude <= {scale:g} (plate units; larger ones "
                             f"overflow the flight algebra), got {big!r}")
