"""``tps-solver kink``: the TPS kink (Sec. 4.3.1)."""
from tps_solver._commands import _tps_common

NAME = "kink"
#: API parameter -> flag, for error messages.
FLAGS = _tps_common.flags("planar")
HELP = "Time-periodic kink by the spectral TPS; prints convergence and the physical checks."


def configure(parser):
    _tps_common.configure(parser, "planar")


def run(args):
    return _tps_common.run(args, "planar")
