"""Faults of the file layer (:mod:`tps_solver.core.archive`, ``tps_solver.load``, ``load_branch``).

Every failure to load is a ``ValueError`` that names the file and says what is wrong (never a raw
``zlib.error``, ``KeyError``, ``OSError``, ...), and every successful load gives back the very
object saved: every stored and derived field bit for bit (floats compared by their bits, arrays by
dtype, shape and bytes).  A seeded fuzz damages the files of several result types (truncation, single
bit flips, overwritten bytes) and checks exactly that dichotomy.
"""
import json
import os
import pathlib
import struct
import zipfile

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import archive
from tps_solver.analyses.continuation import load_branch

#: how many damaged files each fuzz test writes per result type (80: 780 damaged files, 1080 loads in all);
#: ``TPS_FILE_FUZZ=3000`` hunts longer (same seeds, more draws)
N_FUZZ = int(os.environ.get("TPS_FILE_FUZZ", 80))
#: filled by the fuzz tests: kind -> {"ValueError": n, "identical": n}; printed with ``pytest -s``
FUZZ_COUNTS = {}


@pytest.fixture(scope="module")
def results():
    fl = tps.FlatLayer(2.5, 2, e=0.45)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    t0 = fl.t0 + 1.0
    run = tps.simulate(lat, 2.5, 0.45, np.full(5, fl.velocity(t0)), np.full(5, fl.height(t0)), t_start=t0,
                       t_end=t0 + fl.period, t_eval=[t0 + 1.0, t0 + 2.0])
    lat3 = tps.Lattice.planar(n_nodes=3, length=140.0)
    cyc3 = tps.solve_lattice_cycle(lat3, Gamma=2.5, M=2, e=0.45, t0=None)
    return {
        "PeriodicSolution": tps.solve_kink(n_harmonics=8),
        "LatticeCycle": tps.solve_lattice_cycle(tps.Lattice.planar(n_nodes=6, length=100.0)),
        "SimulationResult": run,
        "Branch": tps.continue_branch(tps.FlatLayer(2.5, 2, e=0.45), "Gamma", (2.4, 2.6)),
        "BranchPD": tps.continue_branch(tps.FlatLayer(2.5, 2, e=0.45), "Gamma", (2.3, 2.7)),
        "ShootingOrbit": tps.find_periodic_orbit(lat3, Gamma=2.5, M=2, e=0.45, guess=cyc3),
    }


# ----------------------------------------------------------------------------- bit for bit
def _bits(a, b, where="result"):
    """Assert that ``b`` is ``a`` bit for bit: same types, arrays of the same dtype, shape and bytes,
    floats of the same bits, and every attribute of value objects (FlatLayer, Lattice, SpecialPoint)."""
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, (where, a.dtype, b.dtype, a.shape, b.shape)
        assert a.tobytes() == b.tobytes(), where
        if a.dtype.names:
            assert a.dtype.names == b.dtype.names, where
        return
    if isinstance(a, np.generic):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), where
        return
    if isinstance(a, float):
        assert struct.pack("<d", a) == struct.pack("<d", b), (where, a, b)
        return
    if isinstance(a, complex):
        assert struct.pack("<dd", a.real, a.imag) == struct.pack("<dd", b.real, b.imag), (where, a, b)
        return
    if isinstance(a, dict):
        assert list(a) == list(b), (where, list(a), list(b))
        for k in a:
            _bits(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _bits(x, y, f"{where}[{i}]")
    elif callable(a):
        return                     # rebuilt live objects are checked through what they compute
    elif not hasattr(a, "__dict__"):
        assert a == b, (where, a, b)
        return
    if hasattr(a, "__dict__"):     # the attributes of a value object (all of them, private ones too)
        _bits(vars(a), vars(b), f"{where}.__dict__")


def test_bits_comparator_sees_the_last_bit():
    with pytest.raises(AssertionError):
        _bits(0.45, 0.4499999999999999)
    with pytest.raises(AssertionError):
        _bits(np.zeros(2), np.zeros(2, dtype=np.float32))
    with pytest.raises(AssertionError):
        _bits(tps.FlatLayer(2.5, 2, e=0.45), tps.FlatLayer(2.5, 2, e=0.4499999999999999))
    _bits(tps.FlatLayer(2.5, 2, e=0.45), tps.FlatLayer(2.5, 2, e=0.45))


@pytest.mark.parametrize("make", [
    lambda: tps.FlatLayer(2.5, 2, e=0.45),
    lambda: tps.FlatLayer(2.5, 2, t0=tps.FlatLayer(2.5, 2, e=0.45).t0),
    lambda: tps.FlatLayer(2.5, 2, e=0.45, branch="unstable"),
    lambda: tps.FlatLayer(2.0, 1, e=0.3),
], ids=["e", "t0", "unstable", "M1"])
def test_a_flat_layer_comes_back_bit_for_bit(make, tmp_path):
    fl = make()
    back = tps.load(archive.save(fl, tmp_path / "f"))
    _bits(fl, back, "FlatLayer")
    assert back.e == fl.e and back.t0 == fl.t0 and back.period == fl.period and back.W0 == fl.W0
    t = np.linspace(0.0, 2 * fl.period, 11)
    assert back.height(t).tobytes() == fl.height(t).tobytes()


def test_flat_layer_e_045_is_exactly_045(results, tmp_path):
    # the known failure: e = 0.45 came back as 0.4499999999999999 (recomputed from t0)
    for kind in ("PeriodicSolution", "LatticeCycle"):
        back = tps.load(results[kind].save(tmp_path / kind))
        assert back.flat.e == 0.45 and back.e == results[kind].e
        _bits(results[kind].flat, back.flat, f"{kind}.flat")


@pytest.mark.parametrize("make", [
    lambda: tps.Lattice.planar(n_nodes=6, length=100.0),
    lambda: tps.Lattice.planar(n_nodes=7, length=0.3, boundary="pinned", center=1.7),
    lambda: tps.Lattice.axisymmetric(n_nodes=12, r_max=30.0),
    lambda: tps.Lattice.axisymmetric(n_nodes=9, r_max=7.5, grid="uniform"),
], ids=["planar-20", "planar-pinned", "axisymmetric", "axisymmetric-uniform"])
def test_a_lattice_comes_back_bit_for_bit(make, tmp_path):
    lat = make()
    back = tps.load(archive.save(lat, tmp_path / "l"))
    _bits(lat, back, "Lattice")


def test_lattice_spacing_20_is_exactly_20_inside_results(results, tmp_path):
    # the known failure: spacing 20 came back as 19.99999999999999 (recomputed from the nodes)
    cyc = results["LatticeCycle"]
    assert cyc.lattice.spacing == 20.0
    back = tps.load(cyc.save(tmp_path / "c"))
    assert back.lattice.spacing == 20.0
    _bits(cyc.lattice, back.lattice, "LatticeCycle.lattice")
    orbit = results["ShootingOrbit"]
    back = tps.load(orbit.save(tmp_path / "o"))
    _bits(orbit.lattice, back.lattice, "ShootingOrbit.lattice")


@pytest.mark.parametrize("kind", ["PeriodicSolution", "LatticeCycle", "SimulationResult", "Branch", "BranchPD",
                                  "ShootingOrbit"])
def test_every_field_comes_back_bit_for_bit(results, kind, tmp_path):
    res = results[kind]
    back = tps.load(res.save(tmp_path / "r"))
    _bits(res, back, kind)


def test_a_branch_keeps_time_and_special_details(results, tmp_path):
    br = results["BranchPD"]            # crosses the period doubling: one special point
    assert br.special_details and br.special_points
    for back in (tps.load(br.save(tmp_path / "b")), load_branch(tmp_path / "b.npz")):
        _bits(br, back, "Branch")
        assert back.time == br.time
        for sp, sq in zip(br.special_points, back.special_points):
            assert type(sq) is type(sp) and vars(sq).keys() == vars(sp).keys()
            _bits(vars(sp), vars(sq), "special_point")


# ----------------------------------------------------------------------------- every error is named
def _rewrite(path, **changes):
    """Change entries of a result file on purpose and seal it again (the reader's checks must refuse it)."""
    with np.load(path, allow_pickle=False) as d:
        data = {k: d[k] for k in d.files}
    for k, v in changes.items():
        if v is None:
            del data[k]
        else:
            data[k] = np.asarray(v)
    archive.write_arrays(path, data)


def _refused(path, match, reader=tps.load):
    with pytest.raises(ValueError, match=match) as info:
        reader(path)
    assert type(info.value) is ValueError or isinstance(info.value, archive.MissingFileError)
    return str(info.value)


def test_not_a_path(tmp_path):
    for bad in (None, 123, 1.5, b"bytes.npz", ["a.npz"], ""):
        for reader in (tps.load, load_branch):
            with pytest.raises(ValueError, match="file name"):
                reader(bad)
    with pytest.raises(ValueError, match=r"str or os.PathLike"):
        tps.load(123)
    with pytest.raises(ValueError, match="NUL"):
        tps.load("a\x00b.npz")


def test_a_directory_is_named(tmp_path):
    for reader in (tps.load, load_branch):
        text = _refused(tmp_path, "is a directory", reader)
        assert str(tmp_path) in text
    (tmp_path / "d.npz").mkdir()
    assert str(tmp_path / "d.npz") in _refused(tmp_path / "d", "is a directory|not a regular file")


def test_a_missing_file_is_a_value_error_naming_it(tmp_path):
    for reader in (tps.load, load_branch):
        with pytest.raises(ValueError, match="no such file") as info:
            reader(tmp_path / "nothere")
        assert "nothere" in str(info.value)
    with pytest.raises(FileNotFoundError):               # still a FileNotFoundError, too
        tps.load(tmp_path / "nothere.npz")


def test_a_file_that_is_not_an_npz_is_named(results, tmp_path):
    path = tmp_path / "text.npz"
    path.write_text("no archive here\n")
    assert str(path) in _refused(path, "not an .npz archive")
    np.save(tmp_path / "one.npy", np.arange(3.0))
    _refused(tmp_path / "one.npy", "single .npy array")
    with zipfile.ZipFile(tmp_path / "zip.npz", "w") as z:
        z.writestr("readme.txt", "hello")
    _refused(tmp_path / "zip.npz", "not a tps_solver result file|cannot be read")
    (tmp_path / "empty.npz").write_bytes(b"")
    _refused(tmp_path / "empty.npz", "empty")
    _refused(tmp_path / "text.npz", "not a tps_solver branch file", load_branch)


@pytest.mark.parametrize("kind", ["PeriodicSolution", "Branch"])
def test_a_truncated_file_is_named(results, kind, tmp_path):
    path = results[kind].save(tmp_path / "r")
    raw = pathlib.Path(path).read_bytes()
    for keep in (1, 4, 30, len(raw) // 4, len(raw) // 2, len(raw) - 83, len(raw) - 82, len(raw) - 2):
        pathlib.Path(path).write_bytes(raw[:keep])
        assert path in _refused(path, "cannot be read")
        if kind == "Branch":
            _refused(path, "cannot be read", load_branch)


def test_a_flipped_bit_breaks_the_checksum(results, tmp_path):
    path = results["LatticeCycle"].save(tmp_path / "c")
    raw = bytearray(pathlib.Path(path).read_bytes())
    for pos in (100, len(raw) // 2, len(raw) - 200):
        damaged = bytearray(raw)
        damaged[pos] ^= 0x04
        pathlib.Path(path).write_bytes(bytes(damaged))
        assert path in _refused(path, "checksum does not match")
    damaged = bytearray(raw)
    damaged[-1] ^= 0x01                                   # in the seal itself
    pathlib.Path(path).write_bytes(bytes(damaged))
    _refused(path, "checksum")


def test_unknown_kind_and_wrong_version_are_named(results, tmp_path):
    path = results["Branch"].save(tmp_path / "b")
    _rewrite(path, kind="Teapot")
    assert path in _refused(path, "unknown kind of result 'Teapot'")
    _refused(path, "unknown kind of result 'Teapot'", load_branch)
    path = results["Branch"].save(tmp_path / "b")
    with np.load(path) as d:
        tree = str(d["tree"])
    _rewrite(path, tree=tree.replace('"kind":"Branch"', '"kind":"Teapot"', 1))
    _refused(path, "inconsistent: the entry 'kind' says 'Branch'")
    path = results["Branch"].save(tmp_path / "b")
    _rewrite(path, tree=tree[: len(tree) // 2])
    _refused(path, "'tree' is missing or damaged")
    for version, why in ((3, "format version 3"), (-1, "format version -1"), (1, "format version 1"),
                         ("two", "'format_version' and 'kind' are missing or damaged")):
        path = results["Branch"].save(tmp_path / "b")
        _rewrite(path, format_version=version)
        assert path in _refused(path, why)
        _refused(path, why, load_branch)
    path = results["LatticeCycle"].save(tmp_path / "c")
    _refused(path, "holds a LatticeCycle, not a Branch", load_branch)


@pytest.mark.parametrize("field, value, why", [
    ("parameter_values", np.zeros(2, dtype=np.int64), "'parameter_values' must (have dtype <f8|be an array of kind 'f')"),
    ("stable", np.zeros(3, dtype=bool), "'stable' must have shape"),
    ("states", np.zeros(4), "'states' must have shape"),
    ("parameter", np.array(3.0), "'parameter' must be a scalar of kind int|'parameter' must be a scalar"),
    ("time", np.array([1.0, 2.0]), "'time' must be a scalar"),
    ("status", np.array(1.5), "'status' must be a scalar"),
])
def test_a_mistyped_branch_field_is_named(results, field, value, why, tmp_path):
    br = results["Branch"]
    k = br.parameter_values.size
    path = br.save(tmp_path / "b")
    if field == "parameter_values":
        value = np.zeros(k, dtype=np.int64)
    _rewrite(path, **{field: value})
    text = _refused(path, why)
    assert path in text
    _refused(path, why, load_branch)


def test_a_mistyped_periodic_solution_field_is_named(results, tmp_path):
    sol = results["PeriodicSolution"]
    for field, value, why in (("tc", sol.tc.astype(np.float32), "'tc' must have dtype <f8, got <f4"),
                              ("tc", np.zeros(sol.tc.size + 1), "'tc' must have shape"),
                              ("w_hat", np.array("x"), "'w_hat' must have dtype <c16, got <U1"),
                              ("nodes", sol.nodes[:-1], r"'nodes' must have shape \(\d+,\), got"),
                              ("M", np.array([2, 2]), "'M' must be a scalar")):
        path = sol.save(tmp_path / "s")
        _rewrite(path, **{field: value})
        assert path in _refused(path, why)


@pytest.mark.parametrize("field", ["w", "zeta", "t", "t_eval", "w_eval", "zeta_eval"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf], ids=["nan", "inf", "-inf"])
def test_non_finite_simulation_values_are_refused(results, field, bad, tmp_path):
    run = results["SimulationResult"]
    path = run.save(tmp_path / "sim")
    value = np.array(run[field], dtype=float)
    value.flat[value.size // 2] = bad
    _rewrite(path, **{field: value})
    text = _refused(path, f"'{field}' (holds non-finite values|must be finite)")
    assert path in text


def test_unsealed_damaged_branch_files_never_leak_a_raw_exception(results, tmp_path):
    # the files NumPy itself writes (no seal): damaged compressed streams raised zlib.error, a missing
    # entry KeyError; both readers must say ValueError, and never accept an unsealed version 2 file
    path = results["Branch"].save(tmp_path / "b")
    with np.load(path, allow_pickle=False) as d:
        data = {k: d[k] for k in d.files}
    plain = tmp_path / "plain.npz"
    np.savez_compressed(plain, **data)
    _refused(plain, "seal is missing")
    raw = plain.read_bytes()
    rng = np.random.default_rng(7)
    counts = {"ValueError": 0}
    for _ in range(60):
        damaged = bytearray(raw)
        pos = int(rng.integers(len(raw)))
        damaged[pos] ^= 1 << int(rng.integers(8))
        plain.write_bytes(bytes(damaged))
        for reader in (tps.load, load_branch):
            with pytest.raises(ValueError) as info:
                reader(plain)
            assert str(plain) in str(info.value)
            counts["ValueError"] += 1
    FUZZ_COUNTS["Branch (unsealed)"] = counts
    del data["kind"]
    np.savez_compressed(plain, **data)
    _refused(plain, "'format_version' and 'kind' are missing or damaged", load_branch)


# ----------------------------------------------------------------------------- the fuzz
def _damage(raw, rng):
    """One random corruption of the bytes ``raw``: a truncation, a flipped bit or an overwritten byte."""
    how = int(rng.integers(3))
    if how == 0:
        return raw[:int(rng.integers(len(raw)))], "truncate"
    damaged = bytearray(raw)
    pos = int(rng.integers(len(raw)))
    if how == 1:
        damaged[pos] ^= 1 << int(rng.integers(8))
        return bytes(damaged), "bit"
    damaged[pos] = int(rng.integers(256))
    return bytes(damaged), "byte"


@pytest.mark.parametrize("kind", ["PeriodicSolution", "LatticeCycle", "SimulationResult", "Branch", "BranchPD"])
def test_fuzz_every_damaged_file_is_a_value_error_or_the_same_object(results, kind, tmp_path):
    res = results[kind]
    path = res.save(tmp_path / "r")
    raw = pathlib.Path(path).read_bytes()
    rng = np.random.default_rng(20240917 + len(kind))
    readers = (tps.load, load_branch) if kind.startswith("Branch") else (tps.load,)
    counts = {"ValueError": 0, "identical": 0}
    for i in range(N_FUZZ):
        damaged, how = _damage(raw, rng)
        pathlib.Path(path).write_bytes(damaged)
        for reader in readers:
            try:
                back = reader(path)
            except ValueError as exc:
                assert path in str(exc), (i, how, str(exc))
                counts["ValueError"] += 1
                continue
            # only a corruption that changed nothing (a byte overwritten with itself) may load
            assert damaged == raw, (i, how, "a damaged file loaded")
            _bits(res, back, kind)
            counts["identical"] += 1
    FUZZ_COUNTS[kind] = counts
    assert counts["ValueError"] >= N_FUZZ * len(readers) * 0.9
    pathlib.Path(path).write_bytes(raw)                    # and the intact file still loads, identical
    _bits(res, tps.load(path), kind)


def test_load_is_still_exact_for_files_copied_elsewhere(results, tmp_path):
    # the seal is of the bytes, not of the file name: a renamed copy loads identically
    path = results["Branch"].save(tmp_path / "b")
    other = tmp_path / "sub"
    other.mkdir()
    os.replace(path, other / "renamed.npz")
    _bits(results["Branch"], tps.load(other / "renamed"), "Branch")


@pytest.mark.parametrize("kind", ["PeriodicSolution", "LatticeCycle", "SimulationResult", "BranchPD"])
def test_fuzz_damage_sealed_again_is_a_value_error_or_the_same_object(results, kind, tmp_path):
    # the seal recomputed over the damaged bytes (as a careless tool would): now the zip, NumPy and
    # the type's validation see the damage; still only a ValueError or the same object
    res = results[kind]
    path = res.save(tmp_path / "r")
    raw = pathlib.Path(path).read_bytes()
    seal = len(archive.checksum(b""))
    body = raw[:-seal]
    rng = np.random.default_rng(1789 + len(kind))
    readers = (tps.load, load_branch) if kind.startswith("Branch") else (tps.load,)
    counts = {"ValueError": 0, "identical": 0}
    for i in range(N_FUZZ):
        damaged, how = _damage(body, rng)
        pathlib.Path(path).write_bytes(damaged + archive.checksum(damaged))
        for reader in readers:
            try:
                back = reader(path)
            except ValueError as exc:
                assert path in str(exc), (i, how, str(exc))
                counts["ValueError"] += 1
                continue
            _bits(res, back, kind)          # a flip in a time stamp or another unread zip byte
            counts["identical"] += 1
    FUZZ_COUNTS[kind + " (sealed again)"] = counts
    assert counts["ValueError"] >= N_FUZZ * len(readers) // 2


def test_fuzz_counts_are_reported(capsys):
    # runs after the fuzz in the same process (it reports what it saw when run with -p no:xdist -s)
    if FUZZ_COUNTS:
        with capsys.disabled():
            print("\nfile fuzz:", json.dumps(FUZZ_COUNTS))
    assert all(set(c) <= {"ValueError", "identical"} for c in FUZZ_COUNTS.values())


def test_files_without_dtype_records_in_the_tree_still_load(results, tmp_path):
    # version 2 files written before the tree recorded each array's dtype and shape
    res = results["BranchPD"]
    path = res.save(tmp_path / "b")
    with np.load(path) as d:
        tree = json.loads(str(d["tree"]))

    def strip(node):
        if isinstance(node, dict):
            node.pop("dtype", None)
            node.pop("shape", None)
            for v in node.values():
                strip(v)
        elif isinstance(node, list):
            for v in node:
                strip(v)

    strip(tree)
    _rewrite(path, tree=json.dumps(tree, separators=(",", ":")))
    _bits(res, tps.load(path), "Branch")
