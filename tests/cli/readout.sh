#!/usr/bin/env bash
# `autocal readout`: bad input refused with a message and code 2; a recording too short to
# measure from says why, with code 1.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/common.bash"

"$autocal" --help | grep -qE '^  readout ' || fail "--help lists readout"
code=0
"$autocal" readout >/dev/null 2>"$dir/err" || code=$?
[[ $code -eq 2 ]] && grep -q -- '--input is required' "$dir/err" || fail "no input: $code"
code=0
"$autocal" readout --input "sim:office" --step-ms 0 >/dev/null 2>"$dir/err" || code=$?
[[ $code -eq 2 ]] && grep -q -- '--step-ms takes positive' "$dir/err" || fail "step 0: $code"
code=0
"$autocal" readout --input "sim:office" --max-ms x >/dev/null 2>"$dir/err" || code=$?
[[ $code -eq 2 ]] && grep -q -- '--max-ms takes' "$dir/err" || fail "max x: $code"

# Half a second: no attempt at any readout.
code=0
"$autocal" readout --input "sim:office,seconds=0.5,resolution=320x240,readout_ms=20" \
  --step-ms 20 --json "$dir/r.json" >"$dir/out" 2>"$dir/err" || code=$?
[[ $code -eq 1 ]] || fail "too short: code $code"
grep -q 'not measured: fewer than three readouts' "$dir/err" || fail "why: $(cat "$dir/err")"
grep -q '^stated by the recording: 20 ms' "$dir/out" || fail "the stated readout: $(cat "$dir/out")"
grep -q '"readout_ms": null' "$dir/r.json" || fail "json: $(cat "$dir/r.json")"
[[ $(grep -c '"median_rms_px"' "$dir/r.json") -eq 3 ]] || fail "three trials in the json"
echo "readout: ok"
