"""``tps-solver validate``: run the validation study and write ``validation/REPORT.md``.

The validation studies live in the source tree (the ``validation`` package next
to ``tps_solver``), not in the installed wheel, so this command needs a source
checkout: it looks for ``validation/run_all.py`` next to the ``tps_solver``
package (an editable install) and then in the current directory, and runs
``python -m validation.run_all`` there in a subprocess.  From a non-editable
install outside a checkout it says so and exits with status 2.
"""
import os
import subprocess
import sys

NAME = "validate"
HELP = "Run the full validation study (python -m validation.run_all) and write validation/REPORT.md; needs a checkout."


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


def command(args):
    """The ``python -m validation...`` command line that ``run`` executes (a list of str)."""
    if args.report_only:
        return [sys.executable, "-m", "validation.report"]
    argv = ["--skip", args.skip] + (["--only", args.only] if args.only is not None else [])
    return [sys.executable, "-m", "validation.run_all"] + argv


def run(args):
    root = find_root()
    if root is None:
        print("tps-solver validate: error: this command needs a source checkout of tps_solver "
              "(validation/run_all.py was not found next to the installed package or in the current "
              "directory); run it from the checkout's root", file=sys.stderr)
        return 2
    return subprocess.call(command(args), cwd=root)
