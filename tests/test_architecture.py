"""The package boundary and the layering of ARCHITECTURE.md, checked on the source (AST, no imports).

* no import cycles between the modules of ``tps_solver`` (every import counts, also the
  deferred ones inside functions);
* no module imports from a wing (layer folder) above its own: core < model < operators <
  solvers < analyses < plotting < cli (every import, also ``importlib`` strings); no module
  over 1000 lines;
* no module imports a private name (``_x``) from another module, and nothing outside
  ``tps_solver`` imports one of its private modules (tests may, to test them);
* no ``sys.path`` edits outside ``tests/conftest.py``; no ``matplotlib.use`` in the library or
  the validation package;
* no reference to a "hazard N" or "issue N" that is not in the repository.
"""
import ast
import functools
import pathlib
import re

import numpy as np
import pytest

import tps_solver as tps

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "tps_solver"


def _module_name(path, root=ROOT):
    rel = path.relative_to(root).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _sources(*dirs):
    for d in dirs:
        yield from sorted((ROOT / d).rglob("*.py"))


@functools.lru_cache(maxsize=None)
def _tree(path):
    return ast.parse(path.read_text(), filename=str(path))


def _imports(path, root=ROOT):
    """(target module, imported names, line) for every import in ``path``.

    Every import counts: top-level and deferred (inside functions), ``from . import X`` (whose
    names may be submodules), and ``importlib.import_module(...)`` / ``import_module(...)`` calls
    whose argument is a string literal or an f-string with a literal ``tps_solver.`` prefix
    (the prefix is the target: the call may reach anything below it).
    """
    tree = _tree(path)
    name = _module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                out.append((alias.name, [], node.lineno))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            out.append((target, [a.name for a in node.names], node.lineno))
        elif isinstance(node, ast.Call) and node.args:
            func = node.func
            fname = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
            if fname != "import_module":
                continue
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                out.append((arg.value, [], node.lineno))
            elif isinstance(arg, ast.JoinedStr) and arg.values and isinstance(arg.values[0], ast.Constant):
                prefix = str(arg.values[0].value).rstrip(".")
                if prefix:
                    out.append((prefix, [], node.lineno))
    return out


def _graph():
    modules = {_module_name(p): p for p in _sources("tps_solver")}
    edges = {m: set() for m in modules}
    for m, path in modules.items():
        for target, names, _ in _imports(path):
            if target in modules and target != m:
                edges[m].add(target)
            for n in names:       # "from . import tps" imports a submodule
                sub = f"{target}.{n}"
                if sub in modules and sub != m:
                    edges[m].add(sub)
    return edges


def _parent_packages(module):
    parts = module.split(".")
    return {".".join(parts[:k]) for k in range(1, len(parts))}


def test_no_import_cycles():
    edges = _graph()
    # a package's __init__ importing its own submodules is not a cycle of concepts
    for m in edges:
        edges[m] = {t for t in edges[m] if m not in _parent_packages(t)}
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in edges[m]:
            if state.get(t) == 1:
                cycles.append(stack[stack.index(t):] + [t])
            elif t not in state:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m)
    assert not cycles, cycles


# The wings, bottom to top (ARCHITECTURE.md): a module imports only from its own wing or below.
WINGS = ("core", "model", "operators", "solvers", "analyses", "plotting", "cli")
_TOP = len(WINGS)          # tps_solver/__init__.py: the lazy public names may come from anywhere


def _wing(module):
    """Rank of ``module`` (a dotted name under tps_solver) in :data:`WINGS`; None outside the package."""
    parts = module.split(".")
    if parts[0] != "tps_solver":
        return None
    if len(parts) == 1:
        return _TOP
    head = parts[1]
    if head in ("cli", "__main__", "_commands"):
        return WINGS.index("cli")
    if head in WINGS:
        return WINGS.index(head)
    raise AssertionError(f"{module}: not in a wing of {WINGS} (place it in a layer folder)")


def layer_violations(root=ROOT, package="tps_solver"):
    """``"file:line: source (wing) imports target (wing)"`` for every import that points up."""
    bad = []
    for path in sorted((root / package).rglob("*.py")):
        source = _module_name(path, root)
        rank = _wing(source)
        for target, names, line in _imports(path, root):
            # a name is a target of its own when it is a submodule ("from . import tps")
            subs = [f"{target}.{n}" for n in names if target and (
                (root / target.replace(".", "/") / f"{n}.py").exists()
                or (root / target.replace(".", "/") / n / "__init__.py").exists())]
            targets = [target] + subs
            for t in targets:
                if not t or not t.startswith(package):
                    continue
                r = _wing(t)
                if r == _TOP and rank == WINGS.index("cli"):
                    continue         # the CLI may use the public names of the package
                if r is not None and r > rank:
                    bad.append(f"{path.relative_to(root)}:{line}: {source} ({WINGS[rank] if rank < _TOP else 'top'}) "
                               f"imports {t} ({WINGS[r] if r < _TOP else 'the package top'})")
                    break
    return bad


def size_violations(root=ROOT, package="tps_solver", limit=1000):
    """Modules over ``limit`` lines."""
    return [f"{p.relative_to(root)}: {n} lines" for p in sorted((root / package).rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > limit]


def test_no_module_imports_from_a_layer_above_its_own():
    bad = layer_violations()
    assert not bad, "\n".join(bad)


def test_no_module_is_over_1000_lines():
    bad = size_violations()
    assert not bad, bad


def test_the_layer_rules_catch_violations(tmp_path):
    """The checker on a synthetic tree: each planted violation is reported, the clean module is not."""
    pkg = tmp_path / "tps_solver"
    for d in ("core", "model", "solvers", "analyses"):
        (pkg / d).mkdir(parents=True)
        (pkg / d / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("from importlib import import_module\n")
    (pkg / "core" / "up.py").write_text("def f():\n    from tps_solver.model import flat\n")
    (pkg / "core" / "by_string.py").write_text("import importlib\nM = importlib.import_module('tps_solver.analyses.x')\n")
    (pkg / "core" / "by_fstring.py").write_text("from importlib import import_module\n"
                                                "def g(n):\n    return import_module(f'tps_solver.solvers.{n}')\n")
    (pkg / "model" / "relative.py").write_text("from ..solvers import fda\n")
    (pkg / "model" / "flat.py").write_text("from tps_solver.core import up\n")        # downward: fine
    (pkg / "analyses" / "long.py").write_text("x = 1\n" * 1001)
    bad = layer_violations(tmp_path)
    assert [b.split(":")[0] for b in bad] == ["tps_solver/core/by_fstring.py", "tps_solver/core/by_string.py",
                                              "tps_solver/core/up.py", "tps_solver/model/relative.py"]
    assert "core/up.py:2:" in bad[2] and "imports tps_solver.model" in bad[2]
    assert size_violations(tmp_path) == ["tps_solver/analyses/long.py: 1001 lines"]
    (pkg / "operators").mkdir()
    (pkg / "operators" / "__init__.py").write_text("")
    (pkg / "stray.py").write_text("")
    with pytest.raises(AssertionError, match="not in a wing"):
        layer_violations(tmp_path)


def test_no_private_names_imported_across_modules():
    bad = []
    for path in _sources("tps_solver", "validation"):
        inside = _module_name(path).startswith("tps_solver")
        for target, names, _ in _imports(path):
            # a private submodule imported by a module of its own package is fine ("from . import _x")
            private = [n for n in names if n.startswith("_") and not n.startswith("__")
                       and not ((ROOT / target.replace(".", "/") / f"{n}.py").exists()
                                or (ROOT / target.replace(".", "/") / n).is_dir())]
            if private:
                bad.append((str(path.relative_to(ROOT)), target, private))
            if not inside and target and target.startswith("tps_solver.") and any(
                    part.startswith("_") for part in target.split(".")[1:]):
                bad.append((str(path.relative_to(ROOT)), target, "private module"))
    assert not bad, bad


def _calls(path, owner, attr):
    tree = _tree(path)
    hits = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr == attr:
            value = node.value
            text = ast.unparse(value)
            if text == owner or text.endswith(f".{owner}"):
                hits.append(node.lineno)
    return hits


def test_no_sys_path_edits_outside_conftest():
    bad = []
    for path in _sources("tps_solver", "validation", "tests", "benchmarks"):
        if path.name == "conftest.py" and path.parent.name == "tests":
            continue
        if _calls(path, "sys", "path"):
            bad.append(str(path.relative_to(ROOT)))
    assert not bad, bad


def test_no_matplotlib_use_in_library_or_validation():
    bad = [str(p.relative_to(ROOT)) for p in _sources("tps_solver", "validation", "benchmarks")
           if _calls(p, "matplotlib", "use")]
    assert not bad, bad


def test_every_cited_hazard_exists_in_docs_design():
    design = (ROOT / "docs" / "design.md").read_text()
    numbers = {int(n) for n in re.findall(r"^(\d+)\. \*\*", design, flags=re.M)}
    assert numbers >= set(range(1, 12))
    dangling = []
    for path in _sources("tps_solver", "validation", "tests"):
        for i, line in enumerate(path.read_text().splitlines(), 1):
            for m in re.finditer(r"\b(hazard|issue)s? (\d+)", line):
                if m.group(1) == "issue" or "docs/" not in line or int(m.group(2)) not in numbers:
                    if path.name != "test_architecture.py":
                        dangling.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not dangling, dangling


def _ok_simulation():
    fl = tps.FlatLayer(2.5, 2, e=0.45)
    lat = tps.Lattice.planar(n_nodes=3, length=4.0)
    t = fl.t0 + 1.0
    return lat, dict(Gamma=2.5, e=0.45, w0=np.full(3, fl.velocity(t)), zeta0=np.full(3, fl.height(t)),
                     t_start=t, t_end=t + 0.1)


@pytest.mark.parametrize("method", sorted(tps.METHODS))
def test_an_option_that_does_not_apply_is_an_error(method):
    lat, kw = _ok_simulation()
    extra = {"cutoff": 0.3} if method.startswith("soft") else {}
    with pytest.raises(ValueError, match="bad_option"):
        tps.simulate(lat, method=method, bad_option=1, **extra, **kw)


@pytest.mark.parametrize("method, option", [
    ("exact", dict(rtol=1e-9)), ("exact", dict(ode_solver="RK45")), ("exact", dict(cutoff=0.3)),
    ("ode", dict(max_steps=10)), ("ode", dict(cutoff=0.3)),
    ("soft-radau", dict(time_tol=3.0, cutoff=0.3)), ("soft", dict(ode_solver="nonsense", cutoff=0.3)),
    ("soft", dict(samples_per_step=8, cutoff=0.3)),
    ("soft", dict(stick_velocity=1e-3, cutoff=0.3)), ("soft", dict(rho_c=0.5, cutoff=0.3)),
])
def test_options_of_another_method_are_refused(method, option):
    lat, kw = _ok_simulation()
    name = next(k for k in option if k != "cutoff") if len(option) > 1 else next(iter(option))
    with pytest.raises(ValueError, match=name):
        tps.simulate(lat, method=method, **option, **kw)


def test_validate_command_runs_the_study_as_a_module_of_the_checkout():
    from tps_solver._commands import validate

    class Args:
        report_only, skip, only = False, "", "flat_layer"

    cmd = validate.command(Args)
    assert cmd[1:4] == ["-m", "validation.run_all", "--skip"] and cmd[-2:] == ["--only", "flat_layer"]
    assert validate.find_root() is not None and (pathlib.Path(validate.find_root()) / "validation" /
                                                 "__init__.py").is_file()
