"""Output paths of the commands (``--plot``, ``--save``), checked before any computation.

One rule for every file a command writes: a name without an extension gets the
default one (``.png`` for figures, ``.npz`` for results, see :func:`tps_solver.core.archive.npz_path`),
an extension of a figure selects the format matplotlib writes, and the directory must
exist.  The path returned is the one written, and the commands print it.
"""
import os

from tps_solver.core.archive import npz_path

#: Figure formats the commands accept (matplotlib's file formats).
FIGURE_FORMATS = (".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff", ".webp")


def _check_directory(path, flag, value):
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise ValueError(f"{flag} {value}: the directory {directory} does not exist")
    if not os.access(directory, os.W_OK):
        raise ValueError(f"{flag} {value}: the directory {directory} is not writable")
    if os.path.isdir(path):
        raise ValueError(f"{flag} {value}: {path} is a directory, expected a file name")


def figure_path(value, flag="--plot"):
    """The figure file written for ``value``: ``.png`` appended when it has no extension.

    Raises ``ValueError`` naming ``flag`` for an unknown extension or a missing directory.
    """
    root, ext = os.path.splitext(value)
    if not ext:
        path = value + ".png"
    elif ext.lower() in FIGURE_FORMATS:
        path = value
    else:
        raise ValueError(f"{flag} {value}: unknown figure format {ext!r} (use one of "
                         f"{', '.join(FIGURE_FORMATS)}, or no extension for .png)")
    _check_directory(path, flag, value)
    return path


def result_path(value, flag="--save"):
    """The result file written for ``value``: ``.npz`` appended when missing; the directory must exist."""
    path = npz_path(value)
    _check_directory(path, flag, value)
    return path


def figure_directory(value, flag="--plot"):
    """A directory for several figures: created if missing, but its parent must exist."""
    path = os.path.abspath(value)
    if os.path.exists(path) and not os.path.isdir(path):
        raise ValueError(f"{flag} {value}: {value} exists and is not a directory")
    parent = os.path.dirname(path)
    if not os.path.isdir(parent):
        raise ValueError(f"{flag} {value}: the directory {parent} does not exist")
    return value
