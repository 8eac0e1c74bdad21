"""The ``tps-solver`` console script.

Subcommands are discovered from :mod:`tps_solver._commands`: every module there
defines ``NAME`` (str), ``HELP`` (str), ``configure(parser)`` and
``run(args) -> int``.  Adding a command therefore never edits this file.

Examples
--------
$ tps-solver flat --gamma 2.5 --e 0.45 --M 2
$ tps-solver demo
"""
import argparse
import importlib
import os
import pkgutil
import sys

from . import _commands

__all__ = ["main", "build_parser"]


def _command_modules():
    mods = []
    for info in sorted(pkgutil.iter_modules(_commands.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mods.append(importlib.import_module(f"{_commands.__name__}.{info.name}"))
    return mods


def build_parser():
    """Return the argument parser with every discovered subcommand."""
    parser = argparse.ArgumentParser(
        prog="tps-solver",
        description="Kinks and oscillons of vibrated granular layers (Goddard & Didwania model).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP,
                           aliases=getattr(mod, "ALIASES", []))
        mod.configure(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv=None):
    """Entry point of the ``tps-solver`` script; returns the exit status.

    The one place that chooses a matplotlib backend: a non-interactive one
    (``Agg``) unless ``MPLBACKEND`` is already set, so figures are written to
    files on machines with no display.
    """
    os.environ.setdefault("MPLBACKEND", "Agg")
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except ValueError as exc:
        print(f"tps-solver {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
