"""Run the whole validation study and assemble ``validation/REPORT.md`` (``tps-solver validate``).

Each validation module in :data:`MODULES` that exists is imported by name
(``validation.<name>``) and its ``main()`` is run; it prints its tables and
writes its section file ``validation/sections/<topic>.md`` and figures.
Missing modules are skipped with a note; a module whose ``main`` raises is
reported (with the exception) and the others still run.  Finally
:func:`validation.report.build_report` assembles the report, with the run log
(module, status, wall time) in its header.

Run ``python -m validation.run_all [--only a,b] [--skip c]``.
"""
import argparse
import os
import sys
import time
import traceback

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

from validation.report import REPORT_PATH, build_report, optional_import, write_section

#: Validation modules, in the order they run.
MODULES = ("flat_layer_analytics", "linear_stability", "tps_branches", "flat_layer", "kink", "oscillon",
           "cutoff", "fda_benchmark", "lattice_tps", "speed_vs_error", "figures", "flat_sticking",
           "tps_stick", "inelastic_kinks", "inelastic_fronts", "basins", "shooting", "soft_kinks", "continuation",
           "existence_map", "house", "fault_battery")

#: Modules whose ``main()`` prints its tables without writing a section: their printed output is
#: the section (written to ``validation/sections/<name>.md`` after the run).
PRINTED_SECTIONS = ("flat_sticking", "tps_stick", "basins", "shooting")


def run_modules(names=MODULES, stream=None):
    """Run ``main()`` of each named validation module that exists.

    Parameters
    ----------
    names : sequence of str
    stream : file-like, optional
        Where progress notes go (default ``sys.stdout``).

    Returns
    -------
    log : list of dict
        Per module: ``name``, ``status`` (``"ok"``, ``"missing"``, ``"no main"``,
        ``"failed"``), ``seconds``, ``error`` (the exception text, if failed).

    Examples
    --------
    >>> run_modules(["no_such_module"])[0]["status"]            # doctest: +ELLIPSIS
    --- validation.no_such_module: skipped: module does not exist yet (... s)
    'missing'
    """
    stream = stream or sys.stdout
    log = []
    for name in names:
        start = time.perf_counter()
        entry = dict(name=name, status="ok", seconds=0.0, error="")
        try:
            mod = optional_import(f"validation.{name}")
            if mod is None:
                entry["status"] = "missing"
            elif not callable(getattr(mod, "main", None)):
                entry["status"] = "no main"
            else:
                print(f"\n=== validation.{name} ===", file=stream, flush=True)
                if name in PRINTED_SECTIONS:
                    _run_printed(mod, name, stream)
                else:
                    mod.main()
        except SystemExit as exc:  # a main that calls sys.exit: only a non-zero code is a failure
            if exc.code not in (None, 0):
                entry["status"] = "failed"
                entry["error"] = f"SystemExit({exc.code!r})"
        except Exception as exc:  # report and continue with the other modules
            entry["status"] = "failed"
            entry["error"] = f"{type(exc).__name__}: {exc}"
            traceback.print_exc(file=stream)
        entry["seconds"] = time.perf_counter() - start
        note = {"missing": "skipped: module does not exist yet", "no main": "skipped: no main()",
                "failed": f"FAILED: {entry['error']}"}.get(entry["status"], "done")
        print(f"--- validation.{name}: {note} ({entry['seconds']:.1f} s)", file=stream, flush=True)
        log.append(entry)
    return log


def _run_printed(mod, name, stream):
    """Run ``mod.main()``, echo what it prints, and write that text as the module's section."""
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        mod.main()
    text = buffer.getvalue()
    stream.write(text)
    header = (f"Printed by `python -m validation.{name}` (code and tests: see the module's docstring).\n\n")
    write_section(name, header + text)


def log_lines(log):
    """Markdown lines of a :func:`run_modules` log (for the report header)."""
    lines = ["Run log of this report (`validation/run_all.py`):", ""]
    for entry in log:
        text = {"ok": "ran", "missing": "**not run: module does not exist yet**",
                "no main": "**not run: no main()**",
                "failed": f"**FAILED**: `{entry['error']}` (its section may be stale)"}[entry["status"]]
        lines.append(f"- `validation/{entry['name']}.py`: {text} ({entry['seconds']:.1f} s)")
    return lines


def main(argv=None):
    """Run the selected validation modules and write ``validation/REPORT.md``; return the exit status."""
    parser = argparse.ArgumentParser(prog="python -m validation.run_all", description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=None, help="comma-separated module names to run (default: all)")
    parser.add_argument("--skip", default="", help="comma-separated module names not to run")
    parser.add_argument("--report", default=REPORT_PATH, help="output path of the report")
    args = parser.parse_args(argv)
    names = list(MODULES) if args.only is None else [n.strip() for n in args.only.split(",") if n.strip()]
    skip = {n.strip() for n in args.skip.split(",") if n.strip()}
    unknown = [n for n in names + sorted(skip) if n not in MODULES]
    if unknown:
        parser.error(f"unknown module(s) {unknown}; choose from {', '.join(MODULES)}")
    names = [n for n in names if n not in skip]
    start = time.perf_counter()
    log = run_modules(names)
    path = build_report(args.report, notes=log_lines(log))
    print(f"\nwrote {path} ({time.perf_counter() - start:.1f} s in total)")
    failed = [e["name"] for e in log if e["status"] == "failed"]
    if failed:
        print(f"validation modules that failed: {', '.join(failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
