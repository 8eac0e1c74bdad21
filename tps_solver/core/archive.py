r"""One file format for every result: the archive, its codecs and its validation.

A result file is a NumPy ``.npz`` archive read with ``allow_pickle=False``.  It holds

* ``format`` = ``"tps_solver"``, ``format_version`` (:data:`FORMAT_VERSION`) and ``kind``
  (the registered name of the result type, e.g. ``"PeriodicSolution"``);
* ``tree``: a JSON text describing the structure of the stored object -- for every field
  its type (``float``, ``int``, ``bool``, ``complex``, ``str``, ``None``, a NumPy scalar of
  its exact dtype, an array, a list, tuple or dict of such, a nested bunch, a nested
  registered object), and for an array or NumPy scalar its exact dtype and shape, checked on
  load (a file without these records, written earlier, is read without that check);
* one array per leaf, named by its path (``w_hat``, ``flat.Gamma``,
  ``special_points.0.solution.tc``), holding the value exactly (same dtype, same bits);
* a SHA-256 seal of every byte before it, written as the zip comment
  (``tps_solver-sha256:<hex>``): a flipped byte anywhere in the file, a truncated file or
  a file rewritten by another program is refused.

**Codecs.**  This module knows no result type: each type registers itself from its own
module with :func:`register` -- a ``Bunch`` result by its class (every field is stored by the
generic encoder, so fields added later round-trip without a new codec; fields that cannot
be stored, such as callables or live solver objects, are declared ``transient`` and rebuilt
by ``restore``), a value type (``FlatLayer``, ``Lattice``, ...) by ``encode``/``decode``
functions that give and take its constructor inputs.  A type's ``validate`` checks the
physical fields on load with the typed accessors of :class:`Fields`.  The public reader,
which imports every result module so that every codec is registered, is
:func:`tps_solver.analyses.files.load` (``tps_solver.load``).

**Validation on load.**  Every failure is a ``ValueError`` that names the file: not a
file name, a directory, a missing file (:class:`MissingFileError`, also a
``FileNotFoundError``), an empty, truncated, damaged (seal broken), pickled or foreign
file, a newer format version, an unknown kind, a missing or mistyped field, and an inconsistent
or unphysical one (the type's ``validate``).  Files of format versions 0 and 1 (before the
seal) are read by a type's ``legacy`` reader where it has one.

Examples
--------
>>> import os, tempfile
>>> from tps_solver.core.bunch import Bunch
>>> class Toy(Bunch):
...     pass
>>> register("Toy", Toy)
>>> toy = Toy(x=np.arange(3.0), label="a", n=np.int32(7), parts=[1.5, None])
>>> with tempfile.TemporaryDirectory() as d:
...     back = load(save(toy, os.path.join(d, "toy")))
>>> type(back).__name__, back.x.tolist(), back.label, type(back.n).__name__, back.parts
('Toy', [0.0, 1.0, 2.0], 'a', 'int32', [1.5, None])
"""
import hashlib
import json
import math
import os
import re
import tempfile
import zipfile
import zlib
from io import BytesIO

import numpy as np

from tps_solver.core.bunch import Bunch

__all__ = ["save", "load", "register", "registered", "npz_path", "Fields", "FORMAT", "FORMAT_VERSION",
           "MissingFileError"]

FORMAT = "tps_solver"
#: Version written by :func:`save`; versions 0 and 1 (no seal) are read by a type's ``legacy`` reader.
FORMAT_VERSION = 2
_META = ("format", "format_version", "kind", "tree")
_SEAL = b"tps_solver-sha256:"
_SEAL_LEN = len(_SEAL) + 64
_NAME = re.compile(r"^[A-Za-z0-9_]+$")


class MissingFileError(ValueError, FileNotFoundError):
    """A result file that does not exist: a ``ValueError`` (like every error of :func:`load`)
    and a ``FileNotFoundError``.

    Examples
    --------
    >>> issubclass(MissingFileError, ValueError), issubclass(MissingFileError, FileNotFoundError)
    (True, True)
    """


class _Codec:
    __slots__ = ("kind", "cls", "encode", "decode", "transient", "validate", "restore", "legacy")

    def __init__(self, **kw):
        for key, value in kw.items():
            setattr(self, key, value)


#: kind -> codec; filled once at import time by the modules that define the types (never changed later)
_CODECS = {}


def _registry():
    return _CODECS


def register(kind, cls, *, encode=None, decode=None, transient=(), validate=None, restore=None, legacy=None):
    """Register the codec of a result or value type (called once, from the type's own module).

    Parameters
    ----------
    kind : str
        The name written in files (normally the class name).
    cls : type
        The class; instances of exactly this class use this codec.
    encode, decode : callable, optional
        For a value type that is not a dict: ``encode(obj) -> dict`` of storable values
        (normally the constructor inputs, so the object is rebuilt bit for bit) and
        ``decode(dict) -> obj``.  A ``ValueError`` from ``decode`` is reported with the file
        and field.  Without them ``cls`` must be a ``dict`` subclass (a result ``Bunch``): every
        field not ``transient`` is stored by the generic encoder.
    transient : iterable of str, optional
        Fields not stored (callables, live solvers); ``restore`` rebuilds them.
    validate : callable, optional
        ``validate(f)`` with ``f`` a :class:`Fields` over the decoded fields: raise through
        ``f.fail`` (or ``f.array`` etc.) if a field is unphysical or inconsistent.
    restore : callable, optional
        ``restore(obj)`` after loading, e.g. to rebuild transient fields.
    legacy : callable, optional
        ``legacy(f) -> obj`` reading a file of format version 0 or 1.

    Examples
    --------
    >>> class Pair:
    ...     def __init__(self, a, b):
    ...         self.a, self.b = a, b
    >>> register("Pair", Pair, encode=lambda p: {"a": p.a, "b": p.b}, decode=lambda d: Pair(d["a"], d["b"]))
    >>> "Pair" in registered()
    True
    """
    if not isinstance(kind, str) or not _NAME.match(kind):
        raise ValueError(f"kind must be a name of letters, digits and '_', got {kind!r}")
    if not isinstance(cls, type):
        raise ValueError(f"cls must be a class, got {cls!r}")
    if (encode is None) != (decode is None):
        raise ValueError("encode and decode must be given together")
    if encode is None and not issubclass(cls, dict):
        raise ValueError(f"cls {cls.__name__} is not a dict: give encode and decode")
    reg = _registry()
    old = reg.get(kind)
    if old is not None and old.cls.__qualname__ != cls.__qualname__:
        raise ValueError(f"kind {kind!r} is already registered for {old.cls.__module__}.{old.cls.__qualname__}")
    reg[kind] = _Codec(kind=kind, cls=cls, encode=encode, decode=decode, transient=frozenset(transient),
                       validate=validate, restore=restore, legacy=legacy)


def registered():
    """The kinds registered so far, in registration order.

    Examples
    --------
    >>> isinstance(registered(), tuple)
    True
    """
    return tuple(_registry())


def _codec_of(obj):
    for codec in _registry().values():
        if type(obj) is codec.cls:
            return codec
    return None


def npz_path(path):
    """The file name :func:`save` writes for ``path``: ``path`` with ``.npz`` appended if missing.

    Examples
    --------
    >>> npz_path("run"), npz_path("run.npz")
    ('run.npz', 'run.npz')
    """
    path = _fspath(path)
    return path if path.endswith(".npz") else path + ".npz"


def _fspath(path):
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a file name (str or os.PathLike), got {path!r}")
    try:
        path = os.fspath(path)
    except TypeError as exc:
        raise ValueError(f"path must be a file name (str or os.PathLike): {exc}") from None
    if not isinstance(path, str) or not path:
        raise ValueError(f"path must be a non-empty file name, got {path!r}")
    if "\x00" in path:
        raise ValueError(f"path must be a file name without NUL characters, got {path!r}")
    return path


# ----------------------------------------------------------------------------- encoding

_SCALARS = {bool: ("bool", np.bool_), int: ("int", np.int64), float: ("float", np.float64),
            complex: ("complex", np.complex128), str: ("str", np.str_)}


def _join(path, name):
    return f"{path}.{name}" if path else str(name)


def _dtype_tag(a):
    """The exact dtype of the stored array ``a`` as text (recorded in the tree, checked on load)."""
    return a.dtype.str if a.dtype.names is None else json.dumps(np.lib.format.dtype_to_descr(a.dtype))


def _encode(value, path, arrays):
    """The tree node of ``value``; its arrays go into ``arrays`` under names derived from ``path``."""
    where = path or "the result"
    t = type(value)
    if value is None:
        return {"t": "none"}
    if t in _SCALARS:
        tag, make = _SCALARS[t]
        if t is int and not -2 ** 63 <= value < 2 ** 63:
            raise ValueError(f"{where}: the integer {value} does not fit in 64 bits")
        arrays[path] = np.array(value, dtype=make)
        return {"t": tag}
    if isinstance(value, np.generic):
        if value.dtype.hasobject:
            raise ValueError(f"{where}: a NumPy object scalar cannot be stored")
        arrays[path] = np.array(value)
        return {"t": "scalar", "dtype": _dtype_tag(arrays[path])}
    if t is np.ndarray or t is np.recarray:
        if value.dtype.hasobject:
            raise ValueError(f"{where}: an array of Python objects cannot be stored (give it a numeric "
                             f"or string dtype)")
        arrays[path] = a = np.array(value.view(np.ndarray) if t is np.recarray else value, copy=True)
        return {"t": "recarray" if t is np.recarray else "array", "dtype": _dtype_tag(a), "shape": list(a.shape)}
    if t in (list, tuple):
        return {"t": t.__name__, "items": [_encode(v, _join(path, i), arrays) for i, v in enumerate(value)]}
    if t is dict and all(isinstance(k, str) and _NAME.match(k) for k in value):
        return {"t": "dict", "fields": _fields(value, path, arrays)}
    if t is dict:
        items = [_encode((k, v), _join(path, i), arrays) for i, (k, v) in enumerate(value.items())]
        return {"t": "items", "items": items}
    if t is Bunch:
        return {"t": "bunch", "fields": _fields(value, path, arrays)}
    codec = _codec_of(value)
    if codec is not None:
        if codec.encode is not None:
            data = codec.encode(value)
        else:
            data = {k: v for k, v in value.items() if k not in codec.transient}
        return {"t": "obj", "kind": codec.kind, "fields": _fields(data, path, arrays)}
    raise ValueError(f"{where}: a {t.__module__}.{t.__qualname__} cannot be stored (register its codec with "
                     f"tps_solver.core.archive.register, or declare the field transient)")


def _fields(mapping, path, arrays):
    out = {}
    for key, v in mapping.items():
        if not isinstance(key, str) or not _NAME.match(key):
            raise ValueError(f"{path or 'the result'}: the field name {key!r} cannot be stored "
                             f"(letters, digits and '_' only)")
        if not path and key in _META:
            raise ValueError(f"the field name {key!r} is reserved by the archive")
        out[key] = _encode(v, _join(path, key), arrays)
    return out


def checksum(body):
    """The seal of the bytes ``body`` of an archive: ``b"tps_solver-sha256:" + hex digest``.

    Internal (used by the writer and by tests that rewrite a file on purpose).

    Examples
    --------
    >>> len(checksum(b"abc"))
    82
    """
    return _SEAL + hashlib.sha256(body).hexdigest().encode()


def write_arrays(path, arrays):
    """Write ``arrays`` (a dict of NumPy arrays) as a sealed ``.npz`` at ``path``, atomically.

    Internal: :func:`save` writes through it; a test that damages a field on purpose
    rewrites the file with it, so that the field's own validation is what refuses it.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = write_arrays(os.path.join(d, "a.npz"), {"x": np.arange(2)})
    ...     print(read_arrays(p)["x"])
    [0 1]
    """
    target = npz_path(path)
    buf = BytesIO()
    np.savez_compressed(buf, **arrays)
    raw = buf.getvalue()
    # the end-of-central-directory record (22 bytes, empty comment) ends the zip: put the seal there
    if raw[-22:-18] != b"PK\x05\x06" or raw[-2:] != b"\x00\x00":
        raise RuntimeError("unexpected zip layout from numpy.savez_compressed")
    body = raw[:-2] + _SEAL_LEN.to_bytes(2, "little")
    data = body + checksum(body)
    directory = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(directory):
        raise FileNotFoundError(f"cannot write {target}: the directory {directory} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".npz", dir=directory)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return target


def save(result, path):
    """Write a registered result to ``path`` (``.npz`` appended if missing); returns the path written.

    Parameters
    ----------
    result : object
        An instance of a registered type (:func:`registered`).
    path : str or os.PathLike

    Returns
    -------
    path : str
        The file written (``path``, ending in ``.npz``).

    Raises
    ------
    ValueError
        If ``result`` is not of a registered type, or holds a field that cannot be stored
        (the message names the field).
    FileNotFoundError, PermissionError
        If the directory does not exist or cannot be written; the file is written to a
        temporary name first and renamed, so a failed save leaves no partial file.

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver.core.bunch import Bunch
    >>> class Note(Bunch):
    ...     pass
    >>> register("Note", Note)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     path = save(Note(text="hi"), os.path.join(d, "note"))
    ...     with np.load(path, allow_pickle=False) as f:
    ...         print(os.path.basename(path), f["format"], f["format_version"], f["kind"], f["text"])
    note.npz tps_solver 2 Note hi
    >>> save({"gamma": 1.0}, "roots")
    Traceback (most recent call last):
    ...
    ValueError: result must be a registered result type (see tps_solver.core.archive.registered()), got dict
    """
    codec = _codec_of(result)
    if codec is None:
        raise ValueError(f"result must be a registered result type (see tps_solver.core.archive.registered()), "
                         f"got {type(result).__name__}")
    arrays = {}
    tree = _encode(result, "", arrays)
    meta = {"format": np.array(FORMAT), "format_version": np.array(FORMAT_VERSION),
            "kind": np.array(codec.kind), "tree": np.array(json.dumps(tree, separators=(",", ":")))}
    meta.update(arrays)
    return write_arrays(path, meta)


# ----------------------------------------------------------------------------- reading


class Fields:
    """Typed access to the decoded fields of one object, for a codec's ``validate``.

    Every failure is a ``ValueError`` naming the file, the object's kind and the field.

    Parameters
    ----------
    data : dict
        The decoded fields.
    path : str
        The file (for messages).
    kind : str
    version : int
        Format version of the file.
    prefix : str, optional
        Path of the object inside the file (nested objects).

    Examples
    --------
    >>> f = Fields({"tc": np.zeros(3)}, "x.npz", "Toy", 2)
    >>> f.array("tc", "f", shape=(3,)).shape
    (3,)
    >>> f.array("tc", "f", shape=(4,))
    Traceback (most recent call last):
    ...
    ValueError: x.npz: the field 'tc' must have shape (4,), got (3,) (a Toy file, format version 2)
    """

    def __init__(self, data, path, kind, version, prefix=""):
        self.data, self.path, self.kind, self.version, self.prefix = data, path, kind, version, prefix

    def fail(self, what):
        """Raise the ``ValueError`` ``what`` for this file."""
        where = f" (field {self.prefix!r})" if self.prefix else ""
        raise ValueError(f"{self.path}: {what} (a {self.kind} file{where}, format version {self.version})")

    def has(self, name):
        """Whether the field ``name`` is present."""
        return name in self.data

    def get(self, name):
        """The field ``name`` as decoded (missing: an error)."""
        if name not in self.data:
            self.fail(f"the field {name!r} is missing")
        return self.data[name]

    def scalar(self, name, kinds, finite=False):
        """A number, bool or str of NumPy dtype kind in ``kinds``."""
        a = self.get(name)
        if isinstance(a, (bool, int, float, complex, str, np.generic)):
            a = np.asarray(a)
        if not isinstance(a, np.ndarray) or a.shape != () or a.dtype.kind not in kinds:
            got = f"dtype {a.dtype} shape {a.shape}" if isinstance(a, np.ndarray) else type(a).__name__
            self.fail(f"the field {name!r} must be a scalar of kind {kinds!r}, got {got}")
        value = a.item()
        if finite and not math.isfinite(value):
            self.fail(f"the field {name!r} must be finite, got {value!r}")
        return value

    def float(self, name, finite=True):
        """A real number (finite unless ``finite=False``)."""
        return float(self.scalar(name, "fi", finite))

    def int(self, name, minimum=None):
        """An integer, at least ``minimum``."""
        value = int(self.scalar(name, "iu"))
        if minimum is not None and value < minimum:
            self.fail(f"the field {name!r} must be >= {minimum}, got {value}")
        return value

    def bool(self, name):
        """A bool."""
        return bool(self.scalar(name, "b"))

    def str(self, name, choices=None):
        """A string, one of ``choices`` if given."""
        value = str(self.scalar(name, "U"))
        if choices is not None and value not in choices:
            self.fail(f"the field {name!r} must be one of {', '.join(map(repr, choices))}, got {value!r}")
        return value

    def array(self, name, kinds, shape=None, ndim=None, finite=False):
        """An array of dtype kind in ``kinds``; ``shape`` may hold None for any length."""
        a = self.get(name)
        if not isinstance(a, np.ndarray):
            self.fail(f"the field {name!r} must be an array, got {type(a).__name__}")
        if a.dtype.kind not in kinds:
            self.fail(f"the field {name!r} must be an array of kind {kinds!r}, got dtype {a.dtype}")
        if ndim is not None and a.ndim != ndim:
            self.fail(f"the field {name!r} must have {ndim} dimension(s), got shape {a.shape}")
        if shape is not None and (a.ndim != len(shape) or any(s is not None and s != n
                                                               for s, n in zip(shape, a.shape))):
            want = "(" + ", ".join("k" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            self.fail(f"the field {name!r} must have shape {want}, got {a.shape}")
        if finite and a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
            self.fail(f"the field {name!r} holds non-finite values")
        return a

    def status(self, table, converged_name="converged"):
        """``(status, converged)``: a code of ``table`` and a flag that agrees with it (0 = converged)."""
        status = self.int("status")
        if status not in table:
            self.fail(f"the field 'status' must be a code of tps_solver.STATUS, got {status}")
        converged = self.bool(converged_name)
        if converged != (status == 0):
            self.fail(f"inconsistent: {converged_name} = {converged} but status = {status} ({table[status]})")
        return status, converged

    def instance(self, name, cls, optional=False):
        """A field holding an instance of ``cls`` (or None if ``optional``)."""
        value = self.get(name)
        if value is None and optional:
            return None
        if not isinstance(value, cls):
            self.fail(f"the field {name!r} must be a {cls.__name__}, got {type(value).__name__}")
        return value


def read_arrays(path):
    """All arrays of the archive at ``path`` (seal checked if present); ValueError saying what is wrong.

    Internal: returns the arrays and, as ``"\\x00sealed"``, whether the file was sealed.

    Examples
    --------
    >>> read_arrays(None)
    Traceback (most recent call last):
    ...
    ValueError: path must be a file name (str or os.PathLike), got None
    """
    path = _fspath(path)
    if os.path.isdir(path):
        raise ValueError(f"{path} is a directory, not a tps_solver result file")
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except FileNotFoundError:
        raise MissingFileError(f"no such file: {path}") from None
    except OSError as exc:
        raise ValueError(f"{path} cannot be read: {exc.strerror or exc} [{type(exc).__name__}]") from None
    if not raw:
        raise ValueError(f"{path} cannot be read: the file is empty")
    sealed = False
    if len(raw) > _SEAL_LEN + 22 and raw[-_SEAL_LEN - 22:-_SEAL_LEN - 18] == b"PK\x05\x06":
        tail = raw[-_SEAL_LEN:]
        body = raw[:-_SEAL_LEN]
        declared = int.from_bytes(raw[-_SEAL_LEN - 2:-_SEAL_LEN], "little")
        if declared == _SEAL_LEN and tail.startswith(_SEAL):
            if checksum(body) != tail:
                raise ValueError(f"{path} cannot be read: its checksum does not match (the file is damaged: "
                                 f"bytes were changed after it was written)")
            sealed = True
        elif tail.startswith(_SEAL[:8]) or declared == _SEAL_LEN:
            raise ValueError(f"{path} cannot be read: its checksum seal is damaged")
    _check_declared_sizes(path, raw, sealed)
    try:
        archive = np.load(BytesIO(raw), allow_pickle=False)
        if not isinstance(archive, np.lib.npyio.NpzFile):
            raise ValueError(f"{path} is a single .npy array, not a tps_solver result file (.npz)")
        with archive:
            out = {k: archive[k] for k in archive.files}
    except zipfile.BadZipFile as exc:
        why = ("its data are damaged (CRC check failed)" if "CRC" in str(exc)
               else "it is not a complete .npz (zip) archive: truncated, damaged or another file type")
        raise ValueError(f"{path} cannot be read: {why} [{exc}]") from None
    except (zlib.error, EOFError) as exc:
        raise ValueError(f"{path} cannot be read: its compressed data are damaged or truncated "
                         f"[{type(exc).__name__}: {exc}]") from None
    except ValueError as exc:
        text = str(exc)
        if text.startswith(path):
            raise
        if "pickle" in text and "Object arrays" in text:
            why = "it holds Python objects (pickled arrays), which are never loaded"
        elif "pickle" in text:
            why = "it is not an .npz archive (NumPy took it for pickled data)"
        else:
            why = text
        raise ValueError(f"{path} cannot be read: {why}") from None
    except Exception as exc:        # noqa: BLE001 -- whatever NumPy or zipfile raise on a damaged file
        raise ValueError(f"{path} cannot be read: it is damaged or not an .npz archive "
                         f"[{type(exc).__name__}: {exc}]") from None
    out["\x00sealed"] = sealed
    return out


#: An unsealed file (versions 0 and 1, written by ``numpy.savez_compressed``: float arrays that
#: compress by a few times at most) may declare at most this many times its size, plus
#: :data:`UNSEALED_SLACK` bytes, once decompressed; a larger claim is a zip bomb and is refused
#: before anything is decompressed.
UNSEALED_RATIO = 50
UNSEALED_SLACK = 16e6


def _available_memory():
    """Bytes the OS reports as available, or None (this module imports nothing of the package but
    ``bunch``, so it asks the OS itself)."""
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_declared_sizes(path, raw, sealed):
    """Refuse a file whose members declare more decompressed bytes than it may hold, from the
    zip directory alone (nothing is decompressed; zipfile never yields more than a member declares)."""
    try:
        with zipfile.ZipFile(BytesIO(raw)) as zf:
            declared = sum(info.file_size for info in zf.infolist())
    except (zipfile.BadZipFile, ValueError, OSError, EOFError):
        return                               # not a zip: np.load below says what it is
    if not sealed and declared > UNSEALED_RATIO * len(raw) + UNSEALED_SLACK:
        raise ValueError(f"{path} cannot be read: it has no checksum seal and its members declare "
                         f"{declared / 1e6:.4g} MB once decompressed from {len(raw) / 1e6:.4g} MB (more than "
                         f"{UNSEALED_RATIO} times its size: a zip bomb or a damaged file); nothing was decompressed")
    avail = _available_memory()
    if avail is not None and declared > 0.8 * avail:
        raise ValueError(f"{path} cannot be read: its members declare {declared / 1e6:.4g} MB once decompressed, "
                         f"more than 80 % of the memory available ({avail / 1e6:.4g} MB)")


class _Reader:
    """Decodes the tree of one file against its arrays."""

    def __init__(self, arrays, path, version):
        self.arrays, self.path, self.version = arrays, path, version
        self.used = set()

    def fail(self, where, what):
        raise ValueError(f"{self.path}: {what} (field {where!r}, format version {self.version})"
                         if where else f"{self.path}: {what} (format version {self.version})")

    def leaf(self, path, tag, node):
        if path not in self.arrays:
            self.fail(path, f"the field {path!r} is missing")
        a = self.arrays[path]
        self.used.add(path)
        want = node.get("dtype")
        if want is not None and (not isinstance(a, np.ndarray) or _dtype_tag(a) != want):
            self.fail(path, f"the field {path!r} must have dtype {want}, got "
                            f"{a.dtype.str if isinstance(a, np.ndarray) else type(a).__name__}")
        shape = node.get("shape")
        if shape is not None and (not isinstance(shape, list) or list(a.shape) != shape):
            want_shape = tuple(shape) if isinstance(shape, list) else shape
            self.fail(path, f"the field {path!r} must have shape {want_shape}, got {a.shape}")
        kinds = {"bool": "b", "int": "iu", "float": "f", "complex": "c", "str": "U"}
        if tag in kinds:
            if a.shape != () or a.dtype.kind not in kinds[tag]:
                self.fail(path, f"the field {path!r} must be a scalar of kind {tag}, got dtype {a.dtype} "
                                f"shape {a.shape}")
            return {"bool": bool, "int": int, "float": float, "complex": complex, "str": str}[tag](a.item())
        if tag == "scalar":
            if a.shape != ():
                self.fail(path, f"the field {path!r} must be a scalar, got shape {a.shape}")
            return a[()]
        if tag == "recarray":
            if a.dtype.names is None:
                self.fail(path, f"the field {path!r} must be a record array, got dtype {a.dtype}")
            return a.view(np.recarray)
        return a

    def node(self, node, path):
        if not isinstance(node, dict) or "t" not in node:
            self.fail(path, "the structure entry 'tree' is malformed")
        tag = node["t"]
        if tag == "none":
            return None
        if tag in ("bool", "int", "float", "complex", "str", "scalar", "array", "recarray"):
            return self.leaf(path, tag, node)
        if tag in ("list", "tuple", "items"):
            items = node.get("items")
            if not isinstance(items, list):
                self.fail(path, "the structure entry 'tree' is malformed")
            values = [self.node(n, _join(path, i)) for i, n in enumerate(items)]
            if tag == "list":
                return values
            if tag == "tuple":
                return tuple(values)
            if not all(isinstance(v, tuple) and len(v) == 2 for v in values):
                self.fail(path, "the structure entry 'tree' is malformed")
            try:
                return dict(values)
            except TypeError:
                self.fail(path, "a dict key cannot be rebuilt")
        if tag in ("dict", "bunch", "obj"):
            fields = node.get("fields")
            if not isinstance(fields, dict):
                self.fail(path, "the structure entry 'tree' is malformed")
            data = {k: self.node(n, _join(path, k)) for k, n in fields.items()}
            if tag == "dict":
                return data
            if tag == "bunch":
                return Bunch(data)
            return self.build(node.get("kind"), data, path)
        self.fail(path, f"unknown type {tag!r} in the structure entry 'tree'")

    def build(self, kind, data, path):
        codec = _registry().get(kind)
        if codec is None:
            self.fail(path, f"unknown kind of result {kind!r} (known: {', '.join(_registry())})")
        f = Fields(data, self.path, kind, self.version, prefix=path)
        if codec.validate is not None:
            codec.validate(f)
        if codec.decode is not None:
            try:
                obj = codec.decode(data)
            except (ValueError, TypeError, KeyError) as exc:
                f.fail(f"the stored {kind} cannot be rebuilt: {type(exc).__name__}: {exc}")
        else:
            obj = codec.cls.__new__(codec.cls)
            dict.update(obj, data)
        if codec.restore is not None:
            codec.restore(obj)
        return obj


def load(path, kind=None):
    """Read an object written by :func:`save`, of a kind registered in this process.

    Use :func:`tps_solver.load` (:func:`tps_solver.analyses.files.load`), which registers
    every result type first.

    Parameters
    ----------
    path : str or os.PathLike
        The file, with or without its ``.npz`` ending.
    kind : str, optional
        The kind expected; a file of another kind is an error.

    Returns
    -------
    object
        An instance of the registered class, every stored field bit for bit as saved.

    Raises
    ------
    ValueError
        Every failure, naming the file and saying what is wrong.  If neither ``path`` nor
        ``path + ".npz"`` exists (a :class:`MissingFileError`, also a ``FileNotFoundError``);
        if ``path`` is not a file name, or a directory; if the file cannot be read
        (truncated, damaged, seal broken, pickled, not an ``.npz``), is not a tps_solver
        file, has a newer format version (named), holds an unknown or unexpected kind, or a
        missing, mistyped, inconsistent or unphysical field.

    Examples
    --------
    >>> import os, tempfile
    >>> from tps_solver.core.bunch import Bunch
    >>> class Memo(Bunch):
    ...     pass
    >>> register("Memo", Memo)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     back = load(save(Memo(v=0.1 + 0.2), os.path.join(d, "m")), kind="Memo")
    ...     print(back.v == 0.1 + 0.2)
    ...     with open(os.path.join(d, "junk.npz"), "w") as f:
    ...         _ = f.write("not an archive")
    ...     try:
    ...         load(os.path.join(d, "junk"))
    ...     except ValueError as exc:
    ...         print(str(exc).split(": ", 1)[1])
    True
    it is not an .npz archive (NumPy took it for pickled data)
    >>> load(123)
    Traceback (most recent call last):
    ...
    ValueError: path must be a file name (str or os.PathLike), got 123
    """
    name = _fspath(path)
    if kind is not None and not isinstance(kind, str):
        raise ValueError(f"kind must be a str (a registered kind) or None, got {kind!r}")
    if os.path.isdir(name):
        raise ValueError(f"{name} is a directory, not a tps_solver result file")
    candidates = [name] if name.endswith(".npz") else [name, name + ".npz"]
    found = next((c for c in candidates if os.path.isfile(c)), None)
    if found is None:
        other = next((c for c in candidates if os.path.exists(c)), None)
        if other is not None:
            raise ValueError(f"{other} is not a regular file, not a tps_solver result file")
        raise MissingFileError(f"no such file: {' or '.join(candidates)}")
    try:
        return _load_file(found, kind)
    except ValueError:
        raise
    except Exception as exc:        # noqa: BLE001 -- a reader or a type's codec failed on this file
        raise ValueError(f"{found} cannot be read: a stored field is damaged or inconsistent "
                         f"[{type(exc).__name__}: {exc}]") from None


def _load_file(found, kind):
    """The object stored in the existing file ``found`` (see :func:`load`)."""
    data = read_arrays(found)
    sealed = data.pop("\x00sealed")
    if "format" not in data:
        file_kind, version = "PeriodicSolution", 0        # written before files were versioned
        if "w_hat" not in data or "tc" not in data:
            keys = ", ".join(sorted(data)[:8]) or "none"
            raise ValueError(f"{found} is not a tps_solver result file (no 'format' entry; its arrays: {keys})")
    else:
        fmt = data["format"]
        if fmt.shape != () or fmt.dtype.kind != "U" or str(fmt) != FORMAT:
            raise ValueError(f"{found} is not a tps_solver result file (format {fmt!r}, expected {FORMAT!r})")
        try:
            version = int(data["format_version"])
            file_kind = str(data["kind"])
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{found}: the entries 'format_version' and 'kind' are missing or damaged") from None
        if version > FORMAT_VERSION or version < 0:
            raise ValueError(f"{found} has format version {version}; this tps_solver reads versions "
                             f"0 to {FORMAT_VERSION} (a newer tps_solver wrote it)")
    codec = _registry().get(file_kind)
    if codec is None:
        raise ValueError(f"{found} holds an unknown kind of result {file_kind!r} "
                         f"(known: {', '.join(_registry())})")
    if kind is not None and file_kind != kind:
        raise ValueError(f"{found} holds a {file_kind}, not a {kind}")
    if version < 2:
        if codec.legacy is None:
            raise ValueError(f"{found} has format version {version}, which this tps_solver reads for "
                             f"PeriodicSolution files only; save the {file_kind} again")
        fields = {k: v for k, v in data.items() if k not in _META}
        return codec.legacy(Fields(fields, found, file_kind, version))
    if not sealed:
        raise ValueError(f"{found} cannot be read: its checksum seal is missing (the file is truncated or was "
                         f"rewritten by another program)")
    reader = _Reader(data, found, version)
    try:
        tree = json.loads(str(data["tree"]))
    except (KeyError, ValueError, TypeError):
        raise ValueError(f"{found}: the structure entry 'tree' is missing or damaged") from None
    if not isinstance(tree, dict) or tree.get("t") != "obj":
        raise ValueError(f"{found}: the structure entry 'tree' is malformed")
    if tree.get("kind") != file_kind:
        raise ValueError(f"{found}: inconsistent: the entry 'kind' says {file_kind!r} but the stored object is "
                         f"a {tree.get('kind')!r}")
    return reader.node(tree, "")
