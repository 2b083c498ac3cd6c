"""The source tree the developer tools read (shipped clips, goldens,
valgrind suppressions): LANDMARK_SOURCE_ROOT (set by ``meson test``), else
the tree this package is in (an editable install)."""

import os

ROOT = os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir,
                                 os.pardir, os.pardir)))


def missing(path: str) -> str:
    """The message for a file of the source tree that is not there (an
    installed package has no source tree)."""
    return (f"{path}: not found; this developer tool reads the gst-landmark "
            f"source tree (set LANDMARK_SOURCE_ROOT to its checkout)")
