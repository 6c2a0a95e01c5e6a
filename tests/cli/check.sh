#!/usr/bin/env bash
# `autocal check`, the vest check headless: a short simulated walk with the vest's own lens
# passes (exit 0); a camera at rest is inconclusive (exit 4) and says what was missing; a
# readout given wins over the source's; bad usage exits 2.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
pid=""
trap '[[ -n "$pid" ]] && kill -9 "$pid" 2>/dev/null; rm -rf "$dir"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/common.bash"

code=0
"$autocal" check --input "sim:office,resolution=320x240,seconds=8" >"$dir/out" 2>"$dir/err" || code=$?
cat "$dir/out"
[ "$code" = 0 ] || fail "a walk with the pre-mission lens passes (exit $code)"
[ "$(head -1 "$dir/out")" = PASS ] || fail "the verdict comes first"
grep -q '^fx .* pass$' "$dir/out" || fail "the fx row"
grep -q 'Turn slowly left and right' "$dir/err" || fail "guidance while walking"

code=0
"$autocal" check --input "sim:static,resolution=320x240,seconds=3" >"$dir/out" 2>"$dir/err" || code=$?
cat "$dir/out"
[ "$code" = 4 ] || fail "a camera at rest is inconclusive (exit $code)"
[ "$(head -1 "$dir/out")" = INCONCLUSIVE ] || fail "the inconclusive verdict"
grep -q 'missing: Turning' "$dir/out" || fail "what was missing"

# The readout given wins over the source's: the walk's rows read over 30 ms, checked as a
# global shutter, comes out wrong (a jump) and too few updates are accepted.
code=0
"$autocal" check --input "sim:office,resolution=320x240,seconds=8,readout_ms=30" --readout-ms 0 \
  >"$dir/out" 2>"$dir/err" || code=$?
[ "$code" = 4 ] || fail "a rolling shutter checked as a global one is inconclusive (exit $code)"
grep -q '^missing Calibration updates accepted' "$dir/out" || fail "too few updates accepted"
grep -q '^alarm at .*: jump' "$dir/out" || fail "the jump is said"
grep -q '^measured with a global shutter' "$dir/out" || fail "the shutter measured with is said"

code=0
"$autocal" check --input sim:office --readout-ms -3 >/dev/null 2>"$dir/err" || code=$?
[ "$code" = 2 ] || fail "a negative readout is bad usage (exit $code)"
grep -q 'readout-ms' "$dir/err" || fail "the bad option is named"
code=0
"$autocal" check --input sim:office --seconds -1 >/dev/null 2>&1 || code=$?
[ "$code" = 2 ] || fail "a negative walk is bad usage (exit $code)"
code=0
"$autocal" check --input sim:office --prior "$dir/none.yaml" >/dev/null 2>&1 || code=$?
[ "$code" = 1 ] || fail "a missing calibration file is a failure to run (exit $code)"

# Ctrl-C ends the walk early: the verdict on what was seen, then the signal's exit code.
"$autocal" check --input "sim:office,resolution=320x240,seconds=60" --seconds 600 \
  >"$dir/out" 2>"$dir/err" &
pid=$!
signal_when INT '^ *[0-9.]+ s +[0-9]+%' "$dir/err" 1  # A second into the walk's guidance.
cat "$dir/out"
[ "$code" = 130 ] || fail "Ctrl-C stops the check (exit $code)"
grep -qE '^(PASS|FAIL|INCONCLUSIVE)$' <(head -1 "$dir/out") || fail "the verdict comes first"
grep -q 'stopped by SIGINT after .* of the 600 s walk' "$dir/err" || fail "the stop is said"
walked=$(sed -nE 's/^([0-9.]+) s walked.*/\1/p' "$dir/out")
awk -v s="$walked" 'BEGIN { exit !(s > 0 && s < 600) }' || fail "part of the walk ($walked s)"
echo ok
