"""The ``tps-solver`` console script (also ``python -m tps_solver``).

Subcommands are discovered from :mod:`tps_solver._commands`: every module there
defines ``NAME`` (str), ``HELP`` (str), ``configure(parser)`` and
``run(args) -> int``, and optionally ``ALIASES`` (list of str) and ``FLAGS`` (a dict
mapping the library's parameter names to the command's flags, used to name the flag
in an error message).  Adding a command therefore never edits this file.

Exit status: 0 success, 1 the computation did not converge or stopped, 2 bad input
(a one-line ``tps-solver COMMAND: error: ...`` on stderr, naming the flag) or a file
that cannot be written.

Examples
--------
$ tps-solver flat --gamma 2.5 --e 0.45 --M 2
$ tps-solver --version
$ python -m tps_solver demo
"""
import argparse
import importlib
import os
import pkgutil
import re
import sys

from tps_solver import __version__, _commands

__all__ = ["main", "build_parser", "flag_error"]


def _command_modules():
    mods = []
    for info in sorted(pkgutil.iter_modules(_commands.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mods.append(importlib.import_module(f"{_commands.__name__}.{info.name}"))
    return mods


def build_parser():
    """Return the argument parser with every discovered subcommand.

    Returns
    -------
    argparse.ArgumentParser
        Parsed arguments carry ``command``, the command's options, ``_run`` (its
        ``run``) and ``_flags`` (parameter name -> flag, for error messages).

    Examples
    --------
    >>> args = build_parser().parse_args(["flat", "--gamma", "3.0"])
    >>> args.command, args.gamma, args.M, args._flags["Gamma"]
    ('flat', 3.0, 2, '--gamma')
    """
    parser = argparse.ArgumentParser(
        prog="tps-solver",
        description="Kinks and oscillons of vibrated granular layers (Goddard & Didwania model). "
                    "Units: lengths by the plate amplitude A (horizontal lengths in viscous lengths, "
                    "nu = 1), time by 1/omega.")
    parser.add_argument("--version", action="version", version=f"tps-solver {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP,
                           aliases=getattr(mod, "ALIASES", []))
        mod.configure(p)
        p.set_defaults(_run=mod.run, _flags=_flag_table(p, getattr(mod, "FLAGS", {})))
    return parser


def _flag_table(parser, extra):
    """Library parameter name -> flag: every option's ``dest`` plus the command's ``FLAGS``."""
    table = {}
    for action in parser._actions:
        longs = [o for o in action.option_strings if o.startswith("--")]
        if longs and action.dest not in ("help",):
            table[action.dest] = longs[0]
    table.update(extra)
    return table


def flag_error(message, flags):
    """Name the flag in a library error that starts with a parameter name.

    ``"r_max must be > 0, got -1"`` becomes ``"r_max (--r-max) must be > 0, got -1"``
    when ``flags`` maps ``r_max`` to ``--r-max``; a message that already starts with a
    flag, or with no known parameter, is returned unchanged.

    Examples
    --------
    >>> flag_error("n_nodes must be an integer >= 3, got 0", {"n_nodes": "--nodes"})
    'n_nodes (--nodes) must be an integer >= 3, got 0'
    >>> flag_error("e and t0 are inconsistent", {"e": "--e", "t0": "--t0"})
    'e and t0 (--e, --t0) are inconsistent'
    """
    m = re.match(r"([A-Za-z_]\w*)(?: and ([A-Za-z_]\w*))?\b", message)
    if not m:
        return message
    names = [n for n in m.groups() if n]
    if not all(n in flags for n in names):
        names = names[:1]
        if names[0] not in flags:
            return message
        end = len(names[0])
    else:
        end = m.end()
    return f"{message[:end]} ({', '.join(flags[n] for n in names)}){message[end:]}"


def main(argv=None):
    """Entry point of the ``tps-solver`` script; returns the exit status.

    The one place that chooses a matplotlib backend: a non-interactive one
    (``Agg``) unless ``MPLBACKEND`` is already set, so figures are written to
    files on machines with no display.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``tps-solver``; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status (0 success, 1 not converged or stopped, 2 bad input).

    Examples
    --------
    >>> main(["flat", "--gamma", "2.5", "--e", "0.45"])
    flat layer: Gamma = 2.5, M = 2, e = 0.45, branch = stable
      launch phase t0      = 0.3067801514
    ...
      |multipliers|        = 0.4500000000, 0.4500000000
      stable?              = True
    0

    Bad input is exit status 2 with one line on stderr that names the flag:

    >>> import contextlib, io
    >>> err = io.StringIO()
    >>> with contextlib.redirect_stderr(err):
    ...     status = main(["flat", "--gamma", "-1"])
    >>> status, err.getvalue().strip()
    (2, 'tps-solver flat: error: Gamma (--gamma) must be a finite number > 0, got -1.0')
    """
    os.environ.setdefault("MPLBACKEND", "Agg")
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except ValueError as exc:
        text = " ".join(str(exc).split())
        print(f"tps-solver {args.command}: error: {flag_error(text, args._flags)}", file=sys.stderr)
        return 2
    except OSError as exc:
        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"tps-solver {args.command}: error: cannot write{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
