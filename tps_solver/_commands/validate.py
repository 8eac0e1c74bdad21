"""``tps-solver validate``: run the validation study and write ``validation/REPORT.md``.

The validation scripts live in the source tree (``validation/``), not in the
installed package, so this command needs a checkout: it looks for
``validation/run_all.py`` next to the ``tps_solver`` package (editable
install) and then in the current directory.
"""
import importlib
import os
import sys

NAME = "validate"
HELP = "Run the full validation study (validation/run_all.py) and write validation/REPORT.md."


def configure(parser):
    parser.add_argument("--only", default=None, help="comma-separated validation modules to run (default: all)")
    parser.add_argument("--skip", default="", help="comma-separated validation modules not to run")
    parser.add_argument("--report-only", action="store_true",
                        help="only re-assemble REPORT.md from the existing section files")


def find_root():
    """The source-tree root holding ``validation/run_all.py``, or None."""
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for root in (here, os.getcwd()):
        if os.path.isfile(os.path.join(root, "validation", "run_all.py")):
            return root
    return None


def run(args):
    root = find_root()
    if root is None:
        print("tps-solver validate: error: validation/run_all.py not found; run this command from a "
              "source checkout of tps_solver (or install it with `pip install -e .`)", file=sys.stderr)
        return 2
    if root not in sys.path:
        sys.path.insert(0, root)
    if args.report_only:
        return importlib.import_module("validation.report").main()
    argv = ["--skip", args.skip] + (["--only", args.only] if args.only is not None else [])
    return importlib.import_module("validation.run_all").main(argv)
