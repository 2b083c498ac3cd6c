"""Read ``landmarklog`` files and other JSON Lines files of the project
(a synthetic clip's ``truth.jsonl``): one JSON object per line."""

import json
from typing import Any, Dict, List


class LogError(Exception):
    """A JSON Lines file is missing or a line is not JSON; the message
    names the file and the line."""


def read_jsonl(path: str) -> List[Dict[str, Any]]:
    """Every non-blank line of ``path`` decoded, in order."""
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except OSError as err:
        raise LogError(f"{path}: {err.strerror}") from None
    frames = []
    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            frames.append(json.loads(line))
        except json.JSONDecodeError as err:
            raise LogError(f"{path}:{n}: not JSON: {err.msg}") from None
    return frames
