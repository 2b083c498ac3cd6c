#!/usr/bin/env bash
# Runs every test (core, GstHarness unit tests, pytest suites) after setting
# up what is missing. Extra arguments go to `meson test` (e.g. --suite unit).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

status=0
meson test -C "$BUILD" --print-errorlogs --num-processes 2 "$@" || status=$?

# one closing line for people and CI, counting the cases inside each suite
# (pytest cases, gstcheck checks, core checks): N passed, N failed
"$VENV/bin/python" - "$BUILD/meson-logs/testlog.json" <<'PY'
import json
import re
import sys

passed = failed = skipped = 0
for line in open(sys.argv[1]):
    test = json.loads(line)
    out = test.get("stdout", "") or ""
    ok = test["result"] in ("OK", "EXPECTEDFAIL")
    py = re.findall(r"(\d+) (passed|failed|skipped|error)", out)
    check = re.search(r"Checks: (\d+), Failures: (\d+), Errors: (\d+)", out)
    core = re.search(r"^(\d+) passed, (\d+) failed$", out, re.M)
    if check:
        n, f, e = map(int, check.groups())
        passed, failed = passed + n - f - e, failed + f + e
    elif core:
        passed, failed = passed + int(core[1]), failed + int(core[2])
    elif py:
        counts = {k: int(n) for n, k in py}
        passed += counts.get("passed", 0)
        failed += counts.get("failed", 0) + counts.get("error", 0)
        skipped += counts.get("skipped", 0)
    if not ok and test["result"] == "SKIP":
        skipped += 1
    elif not ok and not (check or core or py):
        failed += 1   # crashed or timed out before reporting
    elif not ok and failed == 0:
        failed += 1
print(f"tests: {passed} passed, {failed} failed, {skipped} skipped")
PY
exit $status
