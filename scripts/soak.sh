#!/usr/bin/env bash
# The soak run: 100,000 frames of the shipped clip through the whole chain
# with the overlay and landmarklog, sampling the process's RSS; prints a
# JSON report and exits 1 if RSS grew by more than 1 MiB after the warm-up
# or a frame is missing. Arguments go to `gst-landmark soak` (e.g.
# --frames 20000 --size 640x480 --json soak.json). About 3 minutes at
# 320x240 on one core.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
cd "$ROOT"
gst-landmark soak "$@"
