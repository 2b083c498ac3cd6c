"""The files the console writes for an element to read while it runs."""

from __future__ import annotations

import os
from typing import Dict, List


class LiveFiles:
    """Names and clears the files written for the elements (a palette
    for labsegment, a camera file for ipmrange): a new name each time,
    because an element reads its file when the property names a new one,
    and only the newest few of each kind kept, because an element may
    still be reading the one before the newest. Apart because teaching
    and tuning both write such files and share one numbering."""

    KEPT = 3

    def __init__(self, out_dir: str):
        self.out_dir = out_dir
        self._serial = 0
        self._written: Dict[str, List[str]] = {}

    def new_path(self, kind: str, suffix: str) -> str:
        """OUT/KIND-live-N.SUFFIX, N one more than the last file's."""
        self._serial += 1
        return os.path.join(self.out_dir,
                            f"{kind}-live-{self._serial}{suffix}")

    def keep(self, kind: str, path: str) -> None:
        """Records ``path`` as the newest of ``kind`` and removes the
        oldest beyond KEPT."""
        paths = self._written.setdefault(kind, [])
        paths.append(path)
        while len(paths) > self.KEPT:
            try:
                os.remove(paths.pop(0))
            except OSError:
                pass
