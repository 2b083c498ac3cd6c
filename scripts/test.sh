#!/usr/bin/env bash
# Runs every test (core, GstHarness unit tests, pytest suites, fuzz
# replays), then the sanitizer and fuzzing stage (scripts/sanitize.sh), after
# setting up what is missing. Extra arguments go to the first `meson test`
# (e.g. --suite unit).
set -euo pipefail
# valgrind for tests/python/test_valgrind.py; x264enc (plugins-ugly) to
# encode the H.264 clip of tests/python/test_recorded_files.py
LANDMARK_EXTRA_APT="${LANDMARK_EXTRA_APT:-} valgrind gstreamer1.0-plugins-ugly"
# the MQTT broker for tests/python/test_publish.py
LANDMARK_EXTRA_APT="${LANDMARK_EXTRA_APT} mosquitto"
# headless Chromium for tests/python/test_console_browser.py
LANDMARK_EXTRA_APT="${LANDMARK_EXTRA_APT} chromium chromium-driver python3-selenium"
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

status=0
meson test -C "$BUILD" --print-errorlogs --num-processes 2 "$@" || status=$?

# the sanitizer and fuzzing stage (scripts/sanitize.sh); LANDMARK_SANITIZE=0
# leaves it out
san_logs=()
if [ "${LANDMARK_SANITIZE:-1}" != 0 ]; then
  bash "$ROOT/scripts/sanitize.sh" || status=$?
  san_build=${LANDMARK_SANITIZE_BUILD_DIR:-$ROOT/build-sanitize}
  san_logs=("$san_build/meson-logs/sanitize-testlog.json"
    --fuzz "$san_build/fuzz-summary.json"
    --skipped "$(cat "$san_build/sanitize-skipped" 2>/dev/null || echo 0)")
fi

# one closing line for people and CI, counting the cases inside each suite
# (pytest cases, gstcheck checks, core checks, fuzz replays; with the
# sanitizer stage, its C tests and each fuzz target): N passed, N failed
"$VENV/bin/python" "$ROOT/scripts/count-tests.py" tests \
  "$BUILD/meson-logs/testlog.json" "${san_logs[@]}"
exit $status
