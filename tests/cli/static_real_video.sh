#!/usr/bin/env bash
# `autocal run` on real footage from a camera that does not move: OpenCV's vtest.avi
# (768x576, 10 fps, 80 s of people walking before a fixed camera; no accelerometer). No
# attempt may update the calibration, and every one must name the physical cause with the
# motion measured over its window, not what the solver tripped on after it; the summary
# counts the causes.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/common.bash"
video=/usr/share/doc/opencv-doc/examples/data/vtest.avi
[[ -f "$video" ]] || fail "OpenCV's sample video is missing: apt-get install opencv-doc"

write_calibration "$dir/prior.yaml" 768 576 600 600 383.5 287.5
"$autocal" run --input "$video" --accel none --prior "$dir/prior.yaml" \
  --summary "$dir/summary.json" >"$dir/out" 2>/dev/null
cat "$dir/out"
attempts=$(grep -oE '^attempts [0-9]+' "$dir/out" | grep -oE '[0-9]+$')
((attempts >= 50)) || fail "attempts were made over the recording: $attempts"
grep -qE "^attempts $attempts: accepted 0, rejected 0, no update $attempts," "$dir/out" ||
  fail "no attempt updates the calibration"
# One cause for every attempt, with the image motion measured (well under a pixel: the
# people walking are a small part of the tracks).
grep -qE "^  $attempts x no update: the camera barely moved \(its image moved at most 0\.[0-9] px over [0-9.]+ s; 20\.0 px needed\): " \
  "$dir/out" || fail "the cause and its figure are named for every attempt"
grep -q "\"no_update_causes\": \[{\"cause\": \"the camera barely moved\", \"count\": $attempts, \"latest\": \"no update: the camera barely moved (its image moved at most 0." \
  "$dir/summary.json" || fail "the summary counts the cause: $(grep no_update_causes "$dir/summary.json")"
grep -q '"fx": 600,' "$dir/summary.json" || fail "the calibration stays the prior"
echo "PASS"
