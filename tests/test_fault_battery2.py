"""The second fault battery: unbounded calls refused before any heavy work, raw inputs checked where
they are taken, honest flags, Ctrl-C and hung workers (see validation/fault_battery.py).

Every refusal is decided from an estimate before the work starts: each case here takes well under
2 s.  Interrupts are raised by a callback at a chosen point, never by a timer.
"""
import json
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tps_solver as tps
from tps_solver.core import costs

FLAT = tps.FlatLayer(2.5, e=0.45)


def _flat_state(n):
    t = FLAT.t0 + 1.0
    return np.full(n, FLAT.velocity(t)), np.full(n, FLAT.height(t)), t


def _square(x):
    return x * x


def _exits(x):
    if x == 2:
        sys.exit(3)
    return x * x


# ------------------------------------------------------------------ sweeps
def test_a_sweep_over_a_huge_product_is_refused_before_expanding_it():
    tic = time.perf_counter()
    with pytest.raises(ValueError, match=r"params \(the number of points\) = 100000000 is out of "
                                         r"reach for sweep: estimated memory"):
        tps.sweep(_square, {"x": list(range(10**4)), "y": list(range(10**4))}, executor="serial",
                  progress=False)
    assert time.perf_counter() - tic < 2.0


def test_a_serial_store_of_a_million_points_is_refused_on_its_own_overhead(tmp_path):
    """The sweep's overhead alone (a key, a sealed file, a thread cap per point) is at least
    1e6 x 0.5 ms = 8 min: refused under a 5-minute limit, before any key is computed."""
    params = [{"x": float(i)} for i in range(10**6)]
    old = costs.set_limits(time=300.0)
    try:
        tic = time.perf_counter()
        with pytest.raises(ValueError, match=r"params \(the number of points\) = 1000000 is out of reach for sweep"):
            tps.sweep(_square, params, executor="serial", store=tmp_path, progress=False)
        assert time.perf_counter() - tic < 2.0
    finally:
        costs.set_limits(**old)


@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_sys_exit_in_one_point_is_a_failed_point_not_the_end_of_the_sweep(executor):
    if executor == "pool":
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(max_workers=1) as ex:
            res = tps.sweep(_exits, {"x": [1, 2, 3]}, executor=ex, progress=False, threads=None)
    else:
        res = tps.sweep(_exits, {"x": [1, 2, 3]}, executor="serial", progress=False)
    assert res.failed == [1]
    assert res[0] == 1 and res[2] == 9
    assert "sys.exit(3)" in res[1].error


@pytest.mark.parametrize("damage", [b'{"task": "tests.te', b"", b"\xff\xfe", b"[1, 2]"])
def test_a_damaged_store_index_is_named(tmp_path, damage):
    tps.sweep(_square, {"x": [1.0, 2.0]}, executor="serial", store=tmp_path, progress=False)
    (tmp_path / "sweep.json").write_bytes(damage)
    with pytest.raises(ValueError, match=r"its index .*sweep\.json' is damaged .* delete sweep\.json"):
        tps.sweep(_square, {"x": [1.0, 2.0]}, executor="serial", store=tmp_path, progress=False)


HUNG = r'''
import json, sys, threading, multiprocessing
import tps_solver as tps
from tps_solver.analyses.sweep import SweepInterrupted


def task(x):
    if x == 0:
        threading.Event().wait()          # hangs for ever
    return x * x


if __name__ == "__main__":
    n = 10
    def stop(state):
        if state.iteration == n - 1:      # every point but the hung one is done: Ctrl-C now
            raise KeyboardInterrupt
    try:
        tps.sweep(task, {"x": list(range(n))}, max_workers=2, progress=False, callback=stop)
        out = {"raised": False}
    except SweepInterrupted as exc:
        out = {"raised": True, "done": int(exc.finished.sum()),
               "alive": [p.pid for p in multiprocessing.active_children()]}
    print("RESULT " + json.dumps(out), flush=True)
'''


@pytest.mark.skipif(sys.platform == "win32", reason="spawned pool and POSIX signals")
def test_an_interrupted_pool_sweep_terminates_a_hung_worker_and_the_process_exits(tmp_path):
    script = tmp_path / "hung.py"
    script.write_text(HUNG)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        out, err = proc.communicate(timeout=120)     # a safety net only: the exit is what is tested
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err[-500:]
    result = json.loads([line for line in out.splitlines() if line.startswith("RESULT ")][-1][7:])
    assert result == {"raised": True, "done": 9, "alive": []}


# ------------------------------------------------------------------ unbounded calls: refused up front
def _front_stub(n):
    """A kink's interface for front_width (nodes, height, period) whose heights are never needed."""
    from tps_solver.core.bunch import Bunch

    return Bunch(nodes=np.linspace(-1.0, 1.0, n), period=4 * np.pi, t_start=0.0,
                 height=lambda t: pytest.fail("front_width evaluated heights before refusing"))


def _thickness(**kw):
    from tps_solver.solvers.thickness import simulate_thickness

    w, z, t = _flat_state(5)
    lat = tps.Lattice.planar(n_nodes=5, length=4.0)
    args = dict(t_start=t, t_end=t + FLAT.period)
    args.update(kw)
    return simulate_thickness(lat, args.pop("Gamma", 2.5), args.pop("e", 0.45), args.pop("w0", w), z,
                              np.ones(5), **args)


def _simulate(method="exact", periods=1.0, w0=None, **kw):
    w, z, t = _flat_state(5)
    return tps.simulate(tps.Lattice.planar(n_nodes=5, length=4.0), 2.5, 0.45, w if w0 is None else w0, z,
                        t_start=t, t_end=t + periods * FLAT.period, method=method, **kw)


def _lat(n, length):
    """A planar lattice, built before the clock starts (its dense operators are the user's own call)."""
    return tps.Lattice.planar(n_nodes=n, length=length)


def _within_limits(call, **limits):
    """``call()`` under lowered cost limits.  The reference basins engine times its first samples: at a
    pace of 0.2-4 ms per sample (measured), 1e6 samples are 200 s to an hour, within the default hour on
    a fast machine (then they run); under 10 s the static bound (0.4 ms per sample) refuses them
    before any sample runs, whatever the machine's load."""
    old = costs.set_limits(**limits)
    try:
        return call()
    finally:
        costs.set_limits(**old)


REFUSED = [
    ("lattice_kink 4001 nodes (dx 0.01, symmetric)",
     lambda lat=(4001, 40.0): tps.lattice_kink(lat, symmetric=True),
     r"lattice.n_nodes = 4001 is out of reach for lattice_kink: estimated run time"),
    ("solve_kink e=0 by shooting, 2001 nodes",
     lambda lat=(2001, 20.0): tps.solve_kink(4.1, e=0.0, lattice=lat),
     r"lattice.n_nodes = 2001 is out of reach for solve_kink: .* settling"),
    ("solve_kink e=0 anticontinuum, 4001 nodes",
     lambda lat=(4001, 40.0): tps.solve_kink(4.1, e=0.0, lattice=lat, start="anticontinuum"),
     r"lattice.n_nodes = 4001 is out of reach for solve_kink: .* discovery"),
    ("solve_stick_lattice 2001 nodes",
     lambda lat=(2001, 20.0): tps.solve_stick_lattice(lat),
     r"lattice.n_nodes = 2001 is out of reach for solve_stick_lattice"),
    ("find_periodic_orbit dense multipliers, 3001 nodes",
     lambda lat=(3001, 30.0): tps.find_periodic_orbit(lat, dense_max=10**4),
     r"lattice.n_nodes = 3001 is out of reach for find_periodic_orbit: .* 6105 period maps"),
    ("check_stability jacobian=True, 4001 nodes",
     lambda: tps.check_stability(FLAT, n_nodes=4001, jacobian=True),
     r"n_nodes \(with jacobian=True\) = 4001 is out of reach for check_stability"),
    ("continue_branch flat layer, steps 1e-12, max_points 1e9",
     lambda: tps.continue_branch(FLAT, "Gamma", (2.3, 2.7), step=1e-12, max_step=1e-12, min_step=1e-13,
                                 max_points=10**9),
     r"max_points = 1000000000 is out of reach for continue_branch: .* about 4e\+11 points"),
    ("continue_branch impact-and-stick solution, max_points 1e9",
     lambda: tps.continue_branch(tps.solve_stick_flat(4.1), "Gamma", (4.0, 4.2), step=1e-12, max_step=1e-12,
                                 min_step=1e-13, max_points=10**9),
     r"max_points = 1000000000 is out of reach for continue_branch"),
    ("flat_basins reference engine, 1e6 samples",
     lambda: _within_limits(lambda: tps.flat_basins(2.5, 0.45, n_samples=10**6, engine="reference"), time=10.0),
     r"n_samples = 1000000 is out of reach for flat_basins: estimated run time"),
    ("simulate method='ode', 1e8 periods", lambda: _simulate("ode", 1e8),
     r"t_end = .* out of reach for simulate: .* method='ode'"),
    ("simulate_thickness 1e9 periods", lambda: _thickness(t_end=1e9 * FLAT.period),
     r"t_end = .* out of reach for simulate_thickness"),
    ("simulate_thickness max_events 1e12 (chattering)",
     lambda: _thickness(Gamma=4.0, e=0.9, stick_velocity=0.0, max_events=10**12),
     r"max_events = 1000000000000 is out of reach for simulate_thickness"),
    ("chatter_tail max_impacts 1e12 (power law)",
     lambda: tps.PowerLawRestitution(0.45, 4.0).chatter_tail(1.0, 1.0, max_impacts=10**12),
     r"max_impacts = 1000000000000 is out of reach for PowerLawRestitution.chatter_tail"),
    ("front_width n_samples 1e10", lambda: tps.front_width(_front_stub(6), n_samples=10**10),
     r"n_samples = 10000000000 is out of reach for front_width: estimated memory"),
    ("FlatLayer M = 1e9", lambda: tps.FlatLayer(2.5, M=10**9, e=0.45),
     r"M = 1000000000 is out of reach for FlatLayer"),
]


@pytest.mark.parametrize("name, call, match", REFUSED, ids=[c[0] for c in REFUSED])
def test_unbounded_calls_are_refused_by_their_estimate_within_2_s(name, call, match):
    import inspect

    import tps_solver.analyses.files  # noqa: F401  (the package's modules: their import is not the call's)
    import tps_solver.analyses.localized  # noqa: F401

    default = inspect.signature(call).parameters.get("lat")
    args = {} if default is None else {"lat": _lat(*default.default)}
    tic = time.perf_counter()
    with pytest.raises(ValueError, match=match) as info:
        call(**args)
    assert time.perf_counter() - tic < 2.0
    assert "raise the limits with tps_solver.core.costs.set_limits" in str(info.value)


def test_simulate_segment_record_is_counted_in_the_memory_estimate():
    """1e6 periods with record_segments: at least 1e6 records of 485 bytes on 5 nodes (0.49 GB), within
    the default limits (it runs, for minutes); refused by name under a 0.1 GB limit."""
    nbytes, _ = costs.simulate_cost(5, 2e6, record_segments=True)
    assert nbytes == 1e6 + 8.0 * 8 * 5 + 0.5 * 2e6 * (costs.SEGMENT_BYTES + costs.SEGMENT_BYTES_PER_NODE * 5)
    old = costs.set_limits(memory=1e8)
    try:
        with pytest.raises(ValueError, match=r"t_end = .* out of reach for simulate: estimated memory .* "
                                             r"record_segments=True"):
            _simulate("point", 1e6, record_segments=True)
    finally:
        costs.set_limits(**old)


# ------------------------------------------------------------------ bad inputs, where they are taken
BAD_INPUTS = [
    ("Lattice.planar(length=1e-300)", lambda: tps.Lattice.planar(n_nodes=5, length=1e-300),
     r"nodes must be spaced so that the Laplacian ~ 1/spacing\*\*2 is finite"),
    ("Lattice with spacing 1e-300", lambda: tps.Lattice(np.arange(5) * 1e-300),
     r"nodes must be spaced so that the Laplacian"),
    ("simulate w0 = +1e300", lambda: _simulate(w0=np.full(5, 1e300)), r"w0 must hold values of magnitude <= 1e\+100"),
    ("simulate w0 = -1e300", lambda: _simulate(w0=np.full(5, -1e300)), r"w0 must hold values of magnitude <= 1e\+100"),
    ("ViscoelasticRestitution(b=1e300)", lambda: tps.ViscoelasticRestitution(b=1e300)(5.0),
     r"b must be a finite number in \(0.0, 1000000.0\]"),
    ("ViscoelasticRestitution law(1e300)", lambda: tps.ViscoelasticRestitution(b=0.5)(1e300),
     r"v \(impact speed\) must be <= 3.2e\+31 for ViscoelasticRestitution\(b=0.5\)"),
    ("PeriodMap stuck of the wrong shape",
     lambda: __import__("tps_solver.solvers.shooting.period_map", fromlist=["PeriodMap"]).PeriodMap(
         tps.Lattice.planar(n_nodes=5, length=4.0), 2.5, 0.45, FLAT.period, 1.0, stuck=np.zeros(3, bool)),
     r"stuck must have shape \(5,\), got \(3,\)"),
    ("simulate_thickness t_eval with nan",
     lambda: _thickness(t_eval=[FLAT.t0 + 1.1, np.nan, FLAT.t0 + 1.5]), r"t_eval must contain only finite values"),
    ("check_stability perturbation 1e300", lambda: tps.check_stability(FLAT, perturbation=1e300),
     r"perturbation must be < saturation = 0.001"),
    ("check_stability perturbation 1e3 (stable flat layer)", lambda: tps.check_stability(FLAT, perturbation=1e3),
     r"perturbation must be < saturation = 0.001 .* outside|perturbation must be < saturation"),
]


@pytest.mark.parametrize("name, call, match", BAD_INPUTS, ids=[c[0] for c in BAD_INPUTS])
def test_bad_inputs_are_refused_by_name_within_2_s(name, call, match):
    tic = time.perf_counter()
    with pytest.raises(ValueError, match=match):
        call()
    assert time.perf_counter() - tic < 2.0


def test_the_viscoelastic_range_ends_where_e_is_below_1e_10():
    """At the end of the integrated range kappa = 1e6, e is tiny (the collision is inelastic)."""
    from tps_solver.model.restitution import viscoelastic_restitution

    assert 0.0 < viscoelastic_restitution(1e6) < 1.1e-10
    with pytest.raises(ValueError, match=r"kappa must be a finite number in \[0, 1e\+06\]"):
        viscoelastic_restitution(1.0000001e6)


def test_thickness_restitution_of_a_deep_layer_is_its_limit_zero_without_warnings():
    """e(v, h) = e_v min(1, 2/(1 + (h/h_e)^q)) -> 0 as h -> inf; (h/h_e)^q overflows at h = 1e300."""
    from tps_solver.model.restitution import ThicknessRestitution

    law = ThicknessRestitution(0.45, h_e=2.0)
    assert law(3.0, 1e300) == 0.0
    assert law(3.0, 1e150) == 0.45 * 2.0 / (1.0 + (1e150 / 2.0) ** 2)


def test_simulate_thickness_with_an_overflowing_push_stops_with_a_status_not_a_warning():
    run = _thickness(chi=1e300, w0=_flat_state(5)[0] + 0.1 * np.arange(5))
    assert not run.success and run.status == 2
    assert "non-finite" in run.message or "failed" in run.message


# ------------------------------------------------------------------ files
def _bomb(path, n_bytes, entries=()):
    """A zip whose 'tree' member declares ``n_bytes`` of zeros (written in 1 MB chunks: little memory)."""
    import io
    import zipfile

    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, arr in entries:
            with zf.open(name + ".npy", "w") as fh:
                np.lib.format.write_array(fh, np.asarray(arr))
        with zf.open("tree.npy", "w", force_zip64=True) as fh:
            head = io.BytesIO()
            np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False,
                                                        "shape": (n_bytes // 8,)})
            fh.write(head.getvalue())
            chunk = bytes(1 << 20)
            for _ in range(n_bytes >> 20):
                fh.write(chunk)


@pytest.mark.parametrize("versioned", [False, True])
def test_an_unsealed_zip_bomb_is_refused_before_anything_is_decompressed(tmp_path, versioned):
    import tracemalloc

    entries = ((("format", np.array("tps_solver")), ("format_version", np.array(2)), ("kind", np.array("Branch")))
               if versioned else ())
    path = tmp_path / "bomb.npz"
    _bomb(path, 100 << 20, entries)                      # 100 MB of zeros in about 0.1 MB
    assert path.stat().st_size < 0.5e6
    import tps_solver.analyses.files  # noqa: F401  (the result modules, imported before measuring)
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"no checksum seal and its members declare 104.9 MB .* zip bomb"):
            tps.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6


# ------------------------------------------------------------------ honest flags
def test_solve_stick_flat_does_not_report_the_period_one_orbit_as_f2():
    """At Gamma = 3 the e = 0 flat layer has a period-2 pi orbit and none of period 4 pi (the one-node
    orbits of model.sticking, an independent closed-form search)."""
    from tps_solver.model.sticking import sticking_orbit

    assert sticking_orbit(3.0, 0.0, 2)[0] is None and sticking_orbit(3.0, 0.0, 1)[0] is not None
    sol = tps.solve_stick_flat(3.0)
    assert not sol.converged and not sol.success and sol.status == 9
    assert "repeated 2 times; pass M = 1" in sol.message
    one = tps.solve_stick_flat(3.0, M=1)
    assert one.converged and one.status == 0
    assert sticking_orbit(4.1, 0.0, 2)[0] is not None and tps.solve_stick_flat(4.1).converged


def test_flat_basins_takes_a_valid_callable_restitution():
    """A callable constant law gives what the constant law gives (independently coded: ConstantRestitution)."""
    law = tps.CallableRestitution(lambda v: 0.45 + 0.0 * np.asarray(v))
    got = tps.flat_basins(2.5, law, n_samples=8, periods=50)
    ref = tps.flat_basins(2.5, tps.ConstantRestitution(0.45), n_samples=8, periods=50, engine="reference")
    assert got.status == 0
    assert [(a.label, a.fraction) for a in got.attractors] == [(a.label, a.fraction) for a in ref.attractors]
    with pytest.raises(ValueError, match=r"store cannot be used with e = CallableRestitution"):
        tps.flat_basins(2.5, law, n_samples=8, periods=50, store="unused")


# ------------------------------------------------------------------ Ctrl-C in the thickness model
def test_simulate_thickness_returns_status_5_with_its_state_on_ctrl_c():
    seen = []

    def stop(state):
        seen.append((state.stage, state.iteration))
        if state.iteration >= 3:
            raise KeyboardInterrupt

    run = _thickness(t_end=FLAT.t0 + 1.0 + 20 * FLAT.period, callback=stop)
    assert run.status == 5 and not run.success and "interrupted" in run.message
    assert seen[-1] == ("simulate_thickness", run.n_events) and run.n_events >= 3
    assert FLAT.t0 + 1.0 < run.t < FLAT.t0 + 1.0 + 20 * FLAT.period
    assert np.all(np.isfinite(run.w)) and np.all(run.h > 0)
    full = _thickness(t_end=run.t)                     # the state kept is the run's state at run.t
    assert full.status == 0 and np.allclose(full.h, run.h, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_the_second_battery_is_all_good():
    """validation/fault_battery.py battery2: every case in its own process (about 2 minutes)."""
    from validation.fault_battery import battery2

    rows = battery2()
    assert [r[0] for r in rows if r[1] != "good"] == []


@pytest.mark.slow
@pytest.mark.parametrize("Gamma, n_nodes, length", [(3.9, 6, 20.0), (4.1, 7, 21.0)])
def test_the_anticontinuum_start_answers_with_flags_not_an_internal_error(Gamma, n_nodes, length):
    """These lattices raised 'pattern.tau must be finite and > t' from inside the discovery."""
    sol = tps.solve_kink(Gamma, e=0.0, lattice=tps.Lattice.planar(n_nodes=n_nodes, length=length),
                         start="anticontinuum")
    assert sol.status in tps.STATUS and bool(sol.converged) == (sol.status == 0)
    if sol.converged:
        assert sol.residual <= 1e-9 and sol.fda_check.passed
