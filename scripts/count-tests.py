"""Counts the cases inside meson test logs (pytest cases, gstcheck checks,
core checks and fuzz replays) for the one closing line of scripts/test.sh
and scripts/sanitize.sh: "<label>: N passed, N failed, N skipped".

usage: count-tests.py LABEL TESTLOG.json [TESTLOG.json ...]
       [--fuzz SUMMARY.json]   (per-target results of scripts/sanitize.sh)
       [--skipped N]           (test programs the stage left out)
A log that does not exist counts as one failure (its stage did not run).
"""
import json
import re
import sys


def count(path):
    passed = failed = skipped = 0
    for line in open(path):
        test = json.loads(line)
        out = test.get("stdout", "") or ""
        ok = test["result"] in ("OK", "EXPECTEDFAIL")
        py = re.findall(r"(\d+) (passed|failed|skipped|error)", out)
        check = re.search(r"Checks: (\d+), Failures: (\d+), Errors: (\d+)",
                          out)
        core = re.search(r"^(\d+) passed, (\d+) failed$", out, re.M)
        # this test's own failures: a failing test whose output reports
        # none still counts one, whatever the tests before it reported
        f_here = 0
        if check:
            n, f, e = map(int, check.groups())
            passed, f_here = passed + n - f - e, f + e
        elif core:
            passed, f_here = passed + int(core[1]), int(core[2])
        elif py:
            counts = {k: int(n) for n, k in py}
            passed += counts.get("passed", 0)
            f_here = counts.get("failed", 0) + counts.get("error", 0)
            skipped += counts.get("skipped", 0)
        if not ok and test["result"] == "SKIP":
            skipped += 1
        elif not ok and f_here == 0:
            f_here = 1   # crashed, timed out or failed without saying so
        failed += f_here
    return passed, failed, skipped


def main(argv):
    label, rest = argv[0], argv[1:]
    fuzz = None
    if "--fuzz" in rest:
        i = rest.index("--fuzz")
        fuzz, rest = rest[i + 1], rest[:i] + rest[i + 2:]
    passed = failed = skipped = 0
    if "--skipped" in rest:
        i = rest.index("--skipped")
        skipped, rest = int(rest[i + 1]), rest[:i] + rest[i + 2:]
    for path in rest:
        try:
            p, f, s = count(path)
        except OSError:
            p, f, s = 0, 1, 0
        passed, failed, skipped = passed + p, failed + f, skipped + s
    extra = ""
    if fuzz:
        # each fuzz target counts as one case: passed when it ran its time
        # without a crash, leak, timeout or out-of-memory
        try:
            targets = json.load(open(fuzz))["targets"]
        except OSError:
            targets = [{"ok": False}]
        ok = sum(1 for t in targets if t["ok"])
        passed, failed = passed + ok, failed + len(targets) - ok
        extra = (f" (fuzz targets: {ok} of {len(targets)} without a crash)")
    print(f"{label}: {passed} passed, {failed} failed, {skipped} skipped"
          + extra)


if __name__ == "__main__":
    main(sys.argv[1:])
