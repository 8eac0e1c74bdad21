"""Assemble ``validation/REPORT.md`` from the section files written by the validation scripts.

Every number in the report is written by the script that measured it, into
``validation/sections/<topic>.md``; :func:`build_report` only concatenates
those files (in :data:`SECTION_ORDER`, unknown topics alphabetically at the
end) under a header that records the machine and the date.  The report's
numbers therefore always equal what the scripts printed.

Also provides the small helpers the validation scripts share:
:func:`markdown_table`, :func:`write_section`, :func:`publish`,
:func:`merged_config`, :func:`median_time` and :func:`optional_import`.

Run ``python validation/report.py`` to rebuild the report from the existing
sections (no computation).
"""
import datetime
import os
import platform
import re
import sys
import time

import numpy as np

VALIDATION_DIR = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(VALIDATION_DIR)
SECTIONS_DIR = os.path.join(VALIDATION_DIR, "sections")
FIGURES_DIR = os.path.join(VALIDATION_DIR, "figures")
REPORT_PATH = os.path.join(VALIDATION_DIR, "REPORT.md")

#: Fixed order of the known sections (file stem, title used when the section is missing).
SECTION_ORDER = (
    ("discrepancies", "The paper's three discrepancies"),
    ("flat", "Flat layer (bouncing ball), eqs. (17)-(19)"),
    ("linear_stability", "Linear stability of flat layers, eq. (35)"),
    ("helmholtz", "Helmholtz solver, eqs. (45), (48)-(50)"),
    ("contact", "Contact-time solver, eq. (46)"),
    ("tps", "Time-periodic solver (TPS)"),
    ("flat_tps_fda", "Flat layer: FlatLayer vs TPS vs FDA"),
    ("kink", "Kinks"),
    ("oscillon", "Oscillons"),
    ("fda", "Event-driven FDA, eqs. (51)-(63)"),
    ("lattice", "TPS and FDA on the same lattice"),
    ("cutoff", "Cut-off length (docs/design.md, hazard 8)"),
    ("speed", "Speed against error"),
    ("figures", "The paper's figures"),
    ("flat_sticking", "Flat orbits with sticking, touch-and-go and chatter (e -> 0)"),
    ("tps_stick", "The TPS for impact-and-stick contacts"),
    ("stick_kink", "The e = 0 kink by the front door (solve_kink)"),
    ("kink_pinning", "The e = 0 kink under refinement: both pinned kinks, their pinning strength and width"),
    ("kink_speed", "Speed against error: the e = 0 kink by shooting"),
    ("inelastic_kinks", "The completely inelastic kinks (e = 0): Gamma table, refinement, oscillons"),
    ("inelastic_fronts", "The e = 0 fronts under refinement: why there is no continuum stick TPS yet"),
    ("restitution_flat", "The flat layer with a speed-dependent restitution e(v)"),
    ("restitution_fronts", "Kinks and oscillons with a speed-dependent restitution"),
    ("thickness_oscillons", "Oscillon cores in the thickness model (docs/thickness.md)"),
    ("kink_branch", "The e = 0 kink continued in Gamma"),
    ("kink_ebranch", "The e = 0 kink continued in e"),
    ("stick_discovery", "The TPS finds the e = 0 kink itself: discovery from the anti-continuum limit"),
    ("basins", "Basins of the bouncing ball"),
    ("integrators", "Fast integrators: point impacts and the soft contact"),
    ("compiled", "Compiled kernels (the fast extra)"),
    ("compiled_point", "Compiled kernels: point impacts against heyoka"),
    ("shooting", "Periodic orbits of any contact pattern by shooting"),
    ("soft_kinks", "Soft-contact kinks over lattice spacings"),
    ("continuation", "Continuation: folds and period doublings"),
    ("existence_map", "Where kinks and oscillons exist: the existence-stability map"),
    ("house", "One problem, one Newton"),
    ("faults", "Faults: unbounded calls, loose options, interrupts, damaged files"),
    ("faults2", "Faults, second battery: sizes out of reach, raw inputs, honest flags"),
    ("period_map", "Period map of the e = 0 kink: run modes instead of free-set eigendecompositions"),
    ("mirrored_multipliers", "Kink multipliers from the mirrored half-period map"),
    ("soft_compiled", "The soft integrator compiled (numpy path vs compiled path vs Radau)"),
)


def markdown_table(rows, columns):
    """Format ``rows`` as a GitHub markdown table.

    Parameters
    ----------
    rows : list of dict
    columns : list of (str, str or callable)
        ``(header, key)`` pairs; ``key`` is a dict key, or a callable of the
        row returning the cell text.  Floats are written with ``%.3g``
        (``%.2e`` below 1e-3), ``None`` as an em dash.

    Returns
    -------
    text : str

    Examples
    --------
    >>> print(markdown_table([{"a": 1, "b": 2.5e-12}], [("a", "a"), ("b", "b")]))
    | a | b |
    |---|---|
    | 1 | 2.50e-12 |
    """
    lines = ["| " + " | ".join(h for h, _ in columns) + " |",
             "|" + "---|" * len(columns)]
    for row in rows:
        cells = []
        for _, key in columns:
            value = key(row) if callable(key) else row.get(key)
            cells.append(format_value(value))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def format_value(value):
    """Text of one table cell (see :func:`markdown_table`)."""
    if value is None:
        return "—"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        value = float(value)
        if not np.isfinite(value):
            return str(value)
        if value == 0.0:
            return "0"
        if abs(value) < 1e-3 or abs(value) >= 1e5:
            return f"{value:.2e}"
        return f"{value:.4g}"
    return str(value)


def write_section(name, text, directory=None):
    """Write ``text`` to ``<directory>/<name>.md`` (default ``validation/sections``); return the path."""
    directory = directory or SECTIONS_DIR
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, f"{name}.md")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text.rstrip() + "\n")
    return path


def publish(name, text):
    """Print a section's text and write it to ``validation/sections/<name>.md``; return the path."""
    print(text)
    path = write_section(name, text)
    print(f"\nwrote {path}")
    return path


def merged_config(default, config=None, overrides=None):
    """``config`` (or ``default`` if None) as a new dict, with ``overrides`` applied."""
    cfg = dict(default if config is None else config)
    cfg.update(overrides or {})
    return cfg


def median_time(func, repeats=5):
    """Median wall time (s) of ``func()`` over ``repeats`` calls, and the last return value.

    Returns
    -------
    seconds : float
    value : object
    """
    times, value = [], None
    for _ in range(max(1, int(repeats))):
        start = time.perf_counter()
        value = func()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), value


def one_blas_thread():
    """Context manager limiting BLAS to one thread (threadpoolctl), or doing nothing without it.

    Small dense kernels on a 2-core machine run much slower with two BLAS threads, so every
    timed study runs inside this.

    Examples
    --------
    >>> with one_blas_thread():
    ...     pass
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:                      # pragma: no cover - optional
        import contextlib
        return contextlib.nullcontext()
    return threadpool_limits(1)


def phase_distance(a, b, period):
    """Distance of times ``a`` and ``b`` modulo ``period``, in [0, period/2].

    Examples
    --------
    >>> float(phase_distance(0.1, 9.9, 10.0))
    0.1999999999999993
    """
    import numpy as np

    return np.abs(np.mod(np.asarray(a, float) - np.asarray(b, float) + 0.5 * period, period) - 0.5 * period)


def optional_import(name):
    """Import the module ``name`` if it exists, else return None.

    Only the absence of that module itself is tolerated; an import error
    raised *inside* an existing module propagates.
    """
    import importlib

    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name == name:
            return None
        raise


def machine_info():
    """The machine and library versions, as a dict of strings."""
    import scipy

    info = {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": str(os.cpu_count()),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
    }
    try:
        import mpmath

        info["mpmath"] = mpmath.__version__
    except ImportError:  # pragma: no cover - mpmath is a dependency
        pass
    try:
        import tps_solver

        info["tps_solver"] = tps_solver.__version__
    except ImportError:  # pragma: no cover
        pass
    return info


def _title(text, default):
    for line in text.splitlines():
        m = re.match(r"^#{1,6}\s+(.*\S)\s*$", line)
        if m:
            return m.group(1)
    return default


def _anchor(title):
    """GitHub's heading anchor for ``title``."""
    slug = re.sub(r"[^\w\- ]", "", title.strip().lower())
    return slug.replace(" ", "-")


def ordered_sections(directory=None):
    """The section files in report order.

    Returns
    -------
    present : list of (str, str)
        ``(stem, path)`` of the existing files: the known ones in
        :data:`SECTION_ORDER`, then unknown ones alphabetically.
    missing : list of (str, str)
        ``(stem, title)`` of known sections without a file.
    """
    directory = directory or SECTIONS_DIR
    files = {}
    if os.path.isdir(directory):
        for name in os.listdir(directory):
            if name.endswith(".md"):
                files[name[:-3]] = os.path.join(directory, name)
    known = [stem for stem, _ in SECTION_ORDER]
    present = [(s, files[s]) for s in known if s in files]
    present += [(s, files[s]) for s in sorted(files) if s not in known]
    missing = [(s, t) for s, t in SECTION_ORDER if s not in files]
    return present, missing


def build_report(path=REPORT_PATH, sections_dir=None, date=None, notes=None):
    """Write the validation report: header, table of contents, every section file.

    Parameters
    ----------
    path : str
        Output file (default ``validation/REPORT.md``).
    sections_dir : str, optional
        Folder of the section files (default ``validation/sections``).
    date : datetime.datetime, optional
        Time stamp (default: now, UTC).
    notes : list of str, optional
        Extra markdown lines for the header (e.g. the run log of ``run_all``).

    Returns
    -------
    path : str
        The file is left untouched (date included) when only its date, machine and versions
        lines would change, so re-assembling an unchanged report does not modify a tracked file.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> _ = write_section("speed", "## Speed\\n\\n| a |\\n|---|\\n| 1 |", d)
    >>> out = build_report(os.path.join(tempfile.mkdtemp(), "R.md"), sections_dir=d)
    >>> "| 1 |" in open(out).read()
    True
    >>> before = os.stat(out).st_mtime_ns
    >>> _ = build_report(out, sections_dir=d, date=datetime.datetime(2030, 1, 1))
    >>> os.stat(out).st_mtime_ns == before, "2030" in open(out).read()
    (True, False)
    """
    present, missing = ordered_sections(sections_dir)
    date = date or datetime.datetime.now(datetime.timezone.utc)
    info = machine_info()
    bodies = []
    for stem, file in present:
        with open(file, encoding="utf-8") as fh:
            bodies.append((stem, fh.read()))
    out = [
        "# tps_solver validation report",
        "",
        "Generated by `python -m validation.run_all` (`tps-solver validate`), or re-assembled from the",
        "existing section files by `python validation/report.py`. Every section below is the file",
        "`validation/sections/<topic>.md` written by the script named in it; this report only",
        "concatenates them, so its numbers are the numbers the scripts printed.",
        "",
        f"- date: {date.strftime('%Y-%m-%d %H:%M %Z')}",
        f"- machine: {info['platform']} ({info['processor']}), {info['cpu_count']} CPUs",
        "- versions: " + ", ".join(f"{k} {info[k]}" for k in ("python", "numpy", "scipy", "mpmath", "tps_solver")
                                   if k in info),
        "",
    ]
    if notes:
        out += list(notes) + [""]
    out += [
        "## Contents",
        "",
    ]
    known = dict(SECTION_ORDER)
    # a section without a heading of its own gets its registered title as one
    bodies = [(stem, text if _title(text, None) else f"## {known.get(stem, stem)}\n\n{text}")
              for stem, text in bodies]
    for stem, text in bodies:
        title = _title(text, stem)
        out.append(f"- [{title}](#{_anchor(title)}) (`sections/{stem}.md`)")
    for stem, title in missing:
        out.append(f"- {title}: *not yet measured* (no `sections/{stem}.md`)")
    out.append("")
    for stem, text in bodies:
        out.append(f"<!-- section: sections/{stem}.md -->")
        out.append(text.rstrip())
        out.append("")
    if missing:
        out.append("## Not yet measured")
        out.append("")
        for stem, title in missing:
            out.append(f"- {title} (`validation/sections/{stem}.md` does not exist)")
        out.append("")
    text = "\n".join(out)
    if _same_but_header(path, text):
        return path                 # the sections are unchanged: keep the file (and its date) as it is
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return path


_HEADER_STAMPS = ("- date: ", "- machine: ", "- versions: ")


def _same_but_header(path, text):
    """True if ``path`` holds ``text`` up to the date, machine and versions lines of the header."""
    if not os.path.isfile(path):
        return False
    with open(path, encoding="utf-8") as fh:
        old = fh.read()

    def strip(t):
        return [line for line in t.splitlines() if not line.startswith(_HEADER_STAMPS)]

    return strip(old) == strip(text)


def main():
    """Re-assemble ``validation/REPORT.md`` from the existing section files."""
    path = build_report()
    present, missing = ordered_sections()
    print(f"wrote {path}: {len(present)} section(s), {len(missing)} not yet measured")
    return 0


if __name__ == "__main__":
    sys.exit(main())
