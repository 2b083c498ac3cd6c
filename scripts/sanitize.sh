#!/usr/bin/env bash
# Sanitizer and fuzzing stage: builds build-sanitize with clang, ASan and
# UBSan (fatal) and the libFuzzer targets of tests/fuzz, then
#  (a) runs the C tests (meson suites core and unit) under ASan + UBSan with
#      LeakSanitizer on (suppressions: tests/sanitize/lsan.supp, third-party
#      one-time allocations only);
#  (b) runs each fuzz target for LANDMARK_FUZZ_SECONDS (default 60), two at
#      a time, from the committed seed corpus (tests/fuzz/corpus/<target>).
# Ends with a summary per target and one count line; exits nonzero on any
# failure. Run by scripts/test.sh after the normal tests; alone:
#   bash scripts/sanitize.sh                     (whole stage)
#   LANDMARK_FUZZ_SECONDS=600 bash scripts/sanitize.sh   (longer fuzzing)
#   LANDMARK_FUZZ_SECONDS=0 bash scripts/sanitize.sh     (sanitizer tests only)
#   LANDMARK_FUZZ_TARGETS="map chain" bash scripts/sanitize.sh
set -euo pipefail
# clang, its ASan/UBSan/libFuzzer runtimes, llvm-symbolizer for reports:
# the distribution's own version (Debian 12: 14, Debian 13: 19)
case "$(. /etc/os-release 2>/dev/null; echo "${ID:-}:${VERSION_ID:-0}")" in
  debian:13*) clang_default=19 ;;
  *) clang_default=14 ;;
esac
CLANG_VERSION=${LANDMARK_CLANG_VERSION:-$clang_default}
LANDMARK_EXTRA_APT="${LANDMARK_EXTRA_APT:-} clang-$CLANG_VERSION libclang-rt-$CLANG_VERSION-dev llvm-$CLANG_VERSION"
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

SAN_BUILD=${LANDMARK_SANITIZE_BUILD_DIR:-$ROOT/build-sanitize}
FUZZ_SECONDS=${LANDMARK_FUZZ_SECONDS:-60}
FUZZ_TARGETS=(${LANDMARK_FUZZ_TARGETS:-palette map calibration chain})
FUZZ_DIR="$SAN_BUILD/fuzz"

slog() { printf '[sanitize] %s\n' "$*" >&2; }

# a stage that stops early (a build error) leaves no results, which the
# count reads as failures; the last run's must not be read in their place
rm -f "$SAN_BUILD/meson-logs/sanitize-testlog.json" \
  "$SAN_BUILD/fuzz-summary.json" "$SAN_BUILD/sanitize-skipped"

# UBSan reports abort (no recovery); vptr and function checks are off
# because their runtime half is C++-only and the C test programs, linked as
# C, would not load the plugin.
san_args="-fno-sanitize-recover=all -fno-sanitize=vptr,function -fno-omit-frame-pointer"
# libstdc++ linked into the C test programs too: ASan resolves its
# __cxa_throw interceptor at start-up, before the C++ plugin is loaded
options=(-Db_sanitize=address,undefined -Db_lundef=false -Dfuzz=enabled
  -Dtests=enabled -Dpython=disabled "-Dc_args=$san_args" "-Dcpp_args=$san_args"
  "-Dc_link_args=-Wl,--no-as-needed -lstdc++" "-Dcpp_link_args=-Wl,--no-as-needed")
if [ ! -f "$SAN_BUILD/build.ninja" ]; then
  slog "configuring $SAN_BUILD (clang-$CLANG_VERSION, ASan + UBSan, libFuzzer)"
  CC=clang-$CLANG_VERSION CXX=clang++-$CLANG_VERSION meson setup "$SAN_BUILD" "$ROOT" "${options[@]}" >/dev/null
else
  meson setup --reconfigure "$SAN_BUILD" "$ROOT" "${options[@]}" >/dev/null
fi
slog "building"
ninja -C "$SAN_BUILD" -j2 >/dev/null

symbolizer=$(command -v "llvm-symbolizer-$CLANG_VERSION" || command -v llvm-symbolizer || true)
export ASAN_OPTIONS="detect_leaks=1:fast_unwind_on_malloc=0:abort_on_error=1:halt_on_error=1:detect_stack_use_after_return=1:check_initialization_order=1${symbolizer:+:external_symbolizer_path=$symbolizer}"
export UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1${symbolizer:+:external_symbolizer_path=$symbolizer}"
export LSAN_OPTIONS="suppressions=$ROOT/tests/sanitize/lsan.supp:print_suppressions=0"
# the registry scan must not run in gst-plugin-scanner: that helper is not
# built with ASan and cannot dlopen the sanitized plugin
export GST_REGISTRY_FORK=no

status=0
start=$(date +%s)
# Build the registry once, leak checks off: with GST_REGISTRY_FORK=no the
# scan loads every system plugin in-process, and several keep memory from
# their class_init (not ours: tests/sanitize/lsan.supp)
reg="$SAN_BUILD/tests/registry.dat"
rm -f "$reg"
ASAN_OPTIONS=detect_leaks=0 GST_REGISTRY_1_0="$reg" \
  GST_PLUGIN_PATH_1_0="$SAN_BUILD/plugins" \
  "$SAN_BUILD/tests/fuzz/replay-chain" /nonexistent >/dev/null 2>&1 || true
# programs that cannot run under the sanitizers (none today)
SKIPPED_UNDER_ASAN=()
mapfile -t san_tests < <(meson test -C "$SAN_BUILD" --suite core --suite unit \
  --list 2>/dev/null | sed -n 's/^gst-landmark:[^ ]* \/ //p' \
  | grep -vxF -f <(printf '%s\n' "${SKIPPED_UNDER_ASAN[@]}"))
slog "C tests under ASan + UBSan + LSan (suites core, unit; ${#san_tests[@]} programs; not run: ${SKIPPED_UNDER_ASAN[*]:-none})"
meson test -C "$SAN_BUILD" --print-errorlogs --num-processes 2 \
  --timeout-multiplier 3 "${san_tests[@]}" || status=$?
tests_s=$(( $(date +%s) - start ))
echo "${#SKIPPED_UNDER_ASAN[@]}" >"$SAN_BUILD/sanitize-skipped"
cp "$SAN_BUILD/meson-logs/testlog.json" "$SAN_BUILD/meson-logs/sanitize-testlog.json"

# (b) fuzzing: two targets at a time on the 2 cores
run_target() {
  local t=$1 dir="$FUZZ_DIR/$1" dict=()
  rm -rf "$dir/artifacts" && mkdir -p "$dir/corpus" "$dir/artifacts"
  case $t in
    palette|map) dict=(-dict="$ROOT/tests/fuzz/json.dict") ;;
    calibration) dict=(-dict="$ROOT/tests/fuzz/calibration.dict") ;;
  esac
  local regressions="$ROOT/tests/fuzz/regressions/$t"
  [ -d "$regressions" ] || regressions=
  # the first corpus directory collects new inputs; the committed ones
  # are only read
  local rc=0
  (cd "$dir" && "$SAN_BUILD/tests/fuzz/fuzz-$t" -max_total_time="$FUZZ_SECONDS" \
    -print_final_stats=1 -timeout=30 -rss_limit_mb=2048 -max_len=4096 \
    -artifact_prefix="$dir/artifacts/" "${dict[@]}" \
    "$dir/corpus" "$ROOT/tests/fuzz/corpus/$t" ${regressions:+"$regressions"}) \
    >"$dir/log.txt" 2>&1 || rc=$?
  echo $rc >"$dir/rc"
}

fuzz_start=$(date +%s)
if [ "$FUZZ_SECONDS" -gt 0 ]; then
  slog "fuzzing ${FUZZ_TARGETS[*]}, ${FUZZ_SECONDS} s each, two at a time"
  for ((i = 0; i < ${#FUZZ_TARGETS[@]}; i += 2)); do
    pids=()
    for t in "${FUZZ_TARGETS[@]:i:2}"; do
      run_target "$t" & pids+=($!)
    done
    wait "${pids[@]}"
  done
fi
fuzz_s=$(( $(date +%s) - fuzz_start ))

# summary per target, from libFuzzer's final statistics
"$VENV/bin/python" - "$FUZZ_DIR" "$FUZZ_SECONDS" "$SAN_BUILD/fuzz-summary.json" "${FUZZ_TARGETS[@]}" <<'PY'
import json
import os
import re
import sys

fuzz_dir, seconds, out, targets = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
rows = []
for t in targets if seconds > 0 else []:
    d = os.path.join(fuzz_dir, t)
    log = open(os.path.join(d, "log.txt"), errors="replace").read()
    rc = int(open(os.path.join(d, "rc")).read())
    stat = dict(re.findall(r"^stat::(\w+):\s+(\d+)", log, re.M))
    corp = re.findall(r"corp: (\d+)/(\S+)", log)
    arts = sorted(os.listdir(os.path.join(d, "artifacts")))
    rows.append({
        "target": t, "ok": rc == 0 and not arts,
        "executions": int(stat.get("number_of_executed_units", 0)),
        "execs_per_s": int(stat.get("average_exec_per_sec", 0)),
        "seconds": seconds,
        "corpus": int(corp[-1][0]) if corp else 0,
        "corpus_size": corp[-1][1] if corp else "0b",
        "new_units": int(stat.get("new_units_added", 0)),
        "peak_rss_mb": int(stat.get("peak_rss_mb", 0)),
        "artifacts": [os.path.join(d, "artifacts", a) for a in arts],
    })
json.dump({"targets": rows}, open(out, "w"), indent=1)
if rows:
    print(f"{'target':<12} {'executions':>10} {'execs/s':>8} {'corpus':>14} {'new':>5} {'rss MB':>7}  result")
for r in rows:
    result = "ok" if r["ok"] else "FAILED: " + (", ".join(r["artifacts"]) or "see " + os.path.join(fuzz_dir, r["target"], "log.txt"))
    print(f"{r['target']:<12} {r['executions']:>10} {r['execs_per_s']:>8} "
          f"{str(r['corpus']) + ' / ' + r['corpus_size']:>14} {r['new_units']:>5} {r['peak_rss_mb']:>7}  {result}")
PY
fuzz_failed=$("$VENV/bin/python" -c 'import json,sys; print(sum(not t["ok"] for t in json.load(open(sys.argv[1]))["targets"]))' "$SAN_BUILD/fuzz-summary.json")
[ "$fuzz_failed" -eq 0 ] || status=1
slog "C tests ${tests_s} s, fuzzing ${fuzz_s} s"
"$VENV/bin/python" "$ROOT/scripts/count-tests.py" sanitize \
  "$SAN_BUILD/meson-logs/sanitize-testlog.json" --fuzz "$SAN_BUILD/fuzz-summary.json" \
  --skipped "${#SKIPPED_UNDER_ASAN[@]}"
exit $status
