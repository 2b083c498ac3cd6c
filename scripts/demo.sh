#!/usr/bin/env bash
# The main job: sets up what is missing, then runs the demo pipeline on a
# generated clip and writes its outputs to out/demo (arguments go to
# `gst-landmark demo`, e.g. --frames 300 --size 1280x720).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
cd "$ROOT"
gst-landmark demo --out out/demo "$@"
