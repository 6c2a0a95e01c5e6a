#!/usr/bin/env bash
# `autocal check`, the vest check headless: a short simulated walk with the vest's own lens
# passes (exit 0); a camera at rest is inconclusive (exit 4) and says what was missing; a
# readout given wins over the source's; bad usage exits 2.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

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
echo ok
