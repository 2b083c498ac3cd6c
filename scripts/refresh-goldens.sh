#!/usr/bin/env bash
# Rewrites the regression goldens from the current build, on purpose: run it
# after a change that is meant to change results, then review the diff
# (git diff tests/golden) before committing it with the change.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
cd "$ROOT"
# this checkout's package, whichever one the venv was installed from
PYTHONPATH="$ROOT/python${PYTHONPATH:+:$PYTHONPATH}" "$VENV/bin/python" -m gstlandmark.devtools.goldens refresh "$@"
git --no-pager diff --stat -- tests/golden || true
