"""The shipped pipeline files (docs/pipelines.md): one ``gst-launch`` line
with ``${VAR}`` variables, ``#`` comment lines around it.

They are package data (``gstlandmark/data/pipelines``, the source tree's
``pipelines/``), so an installed ``gst-landmark run`` finds them from any
directory.
"""

import importlib.resources
import os
from typing import List

SUFFIX = ".pipeline"


def pipelines_dir() -> str:
    return str(importlib.resources.files("gstlandmark") / "data"
               / "pipelines")


def names() -> List[str]:
    """The shipped pipeline files, without ``.pipeline``."""
    try:
        entries = os.listdir(pipelines_dir())
    except OSError:
        return []
    return sorted(e[:-len(SUFFIX)] for e in entries if e.endswith(SUFFIX))


def launch_line(path: str) -> str:
    """The launch line of the pipeline file ``path``; ValueError naming
    the file when it cannot be read or holds not exactly one line."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as err:
        raise ValueError(f"{path}: {err.strerror or err}") from None
    found = [line.strip() for line in text.splitlines()
             if line.strip() and not line.strip().startswith("#")]
    if len(found) != 1:
        raise ValueError(f"{path}: one launch line expected, found "
                         f"{len(found)}")
    return found[0]
