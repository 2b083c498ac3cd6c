#!/usr/bin/env bash
# The whole chain under valgrind memcheck (150 frames at 320x240 by
# default, gst-launch-1.0 with G_SLICE=always-malloc, G_DEBUG=gc-friendly,
# GST_REGISTRY_FORK=no and the suppressions of tests/valgrind/gstreamer.supp
# plus GLib's glib.supp). Prints a JSON report of valgrind's records by
# kind, in total and through our code; exits 1 on a definite or indirect
# leak, an invalid access or another memcheck error in our code. Arguments
# go to `python -m gstlandmark.devtools.valgrind` (--frames N, --size WxH,
# --error-after K, --out DIR to keep memcheck.xml). About 40 s.
set -euo pipefail
LANDMARK_EXTRA_APT="${LANDMARK_EXTRA_APT:-} valgrind"
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
cd "$ROOT"
PYTHONPATH="$ROOT/python${PYTHONPATH:+:$PYTHONPATH}" \
  "$VENV/bin/python" -m gstlandmark.devtools.valgrind "$@"
