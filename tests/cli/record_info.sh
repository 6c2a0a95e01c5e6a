#!/usr/bin/env bash
# `autocal record` from the simulator writes a recording that `autocal info` validates;
# with no camera or accelerometer attached, record and devices say so and list what they
# found; usage errors.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$autocal" --help | grep -q '^  record ' || fail "--help lists record"
"$autocal" --help | grep -q '^  devices ' || fail "--help lists devices"

"$autocal" record --input sim:office --seconds 5 --out "$dir/rec" 2>"$dir/progress" >"$dir/out"
cat "$dir/out"
grep -qE '^record: [0-9.]+ s, 150 frames, [0-9]+ accelerometer samples written' "$dir/progress" \
  || fail "progress on stderr ends with the 150 frames: $(cat "$dir/progress")"
grep -q '^recorded 150 frames and [0-9]* accelerometer samples over 4.97 s from simulator' "$dir/out" \
  || fail "summary line: $(cat "$dir/out")"
"$autocal" info "$dir/rec" >"$dir/info" || fail "info refuses the recording: $(cat "$dir/info")"
cat "$dir/info"
grep -qE '^frames +150 frames over 4\.967 s, median rate 30\.00 Hz' "$dir/info" || fail "150 frames at 30 fps"
grep -qE '^accelerometer +[0-9]+ samples over .* median rate 400\.0 Hz' "$dir/info" || fail "accelerometer at 400 Hz"
grep -qE '^overlap .* 100\.0% of the frame span' "$dir/info" || fail "accelerometer covers the frames"
grep -qE '^findings +none' "$dir/info" || fail "no findings"
[[ ! -e "$dir/rec/events.csv" ]] || fail "a recorded source has no device events"
# The recorded frames are the simulator's: the first one is byte-identical to what
# `simulate` writes for the same scenario (both are lossless PNG of the same pixels).
"$autocal" simulate --scenario office --seconds 0.1 --out "$dir/sim" >/dev/null 2>&1
first_sim="$(sed -n 2p "$dir/sim/cam0/data.csv" | cut -d, -f2)"
first_rec="$(sed -n 2p "$dir/rec/cam0/data.csv" | cut -d, -f2)"
[[ "$first_sim" == "$first_rec" ]] || fail "first frame time: $first_rec, simulate says $first_sim"
cmp -s "$dir/sim/cam0/data/$first_sim" "$dir/rec/cam0/data/$first_rec" || fail "first frame differs from simulate's"

# An existing, non-empty folder is refused before anything is written.
set +e
"$autocal" record --input sim:office --seconds 1 --out "$dir/rec" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] || fail "non-empty --out exits $code"
grep -q 'already exists and is not empty' "$dir/err" || fail "non-empty --out message: $(cat "$dir/err")"

# Usage errors exit 2.
set +e
"$autocal" record --input sim:office 2>"$dir/err"; code=$?
set -e
[[ $code -eq 2 ]] || fail "missing --out exits $code"
grep -q -- '--out is required' "$dir/err" || fail "missing --out message"
set +e
"$autocal" record --input sim:office --seconds -3 --out "$dir/x" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 2 ]] || fail "negative --seconds exits $code"

# No hardware here (the checks adapt if this machine has a camera at /dev/video0).
if [[ ! -e /dev/video0 ]]; then
  found="none"
  if compgen -G '/dev/video*' >/dev/null; then found="/dev/video"; fi
  set +e
  "$autocal" record --input camera:0 --seconds 1 --out "$dir/cam" 2>"$dir/err"; code=$?
  set -e
  [[ $code -eq 1 ]] || fail "missing camera exits $code"
  grep -q "^autocal record: no camera at /dev/video0; found: $found" "$dir/err" \
    || fail "missing camera message: $(cat "$dir/err")"
  [[ ! -e "$dir/cam" ]] || fail "nothing is created when the camera is missing"
  set +e
  "$autocal" record --input camera:0 --accel usb:1234:5678 --out "$dir/cam" 2>"$dir/err"; code=$?
  set -e
  [[ $code -eq 1 ]] || fail "missing camera and accelerometer exit $code"
  grep -q "no camera at /dev/video0; found: $found.*; and no USB accelerometer 1234:5678 found; devices seen: " "$dir/err" \
    || fail "both missing devices named: $(cat "$dir/err")"
fi
set +e
"$autocal" devices >"$dir/devices" 2>&1; code=$?
set -e
cat "$dir/devices"
grep -q '^cameras:' "$dir/devices" || fail "devices lists cameras"
grep -q '^accelerometer:' "$dir/devices" || fail "devices looks for an accelerometer"
if [[ ! -e /dev/video0 ]] && ! compgen -G '/dev/video*' >/dev/null; then
  grep -q '^  none (no /dev/video\* device)' "$dir/devices" || fail "no camera said"
fi
if grep -q '^  none: no USB accelerometer found; devices seen: ' "$dir/devices" && \
   grep -q '^  none (no /dev/video\* device)' "$dir/devices"; then
  [[ $code -eq 1 ]] || fail "devices with nothing found exits $code"
fi

# A USB accelerometer cannot be paired with a recorded input (another clock).
set +e
"$autocal" record --input sim:office --accel usb --out "$dir/y" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] || fail "usb accelerometer with sim exits $code"
grep -q 'needs a live camera input' "$dir/err" || fail "clock message: $(cat "$dir/err")"

# The rolling shutter's readout the recording states, as given; a bad one refused.
"$autocal" record --input "sim:office,seconds=0.2,resolution=160x120" --out "$dir/ro" \
  --readout-ms 22 >/dev/null 2>&1 || fail "record --readout-ms"
"$autocal" info "$dir/ro" >"$dir/ro_info"
grep -qE '^shutter +rolling, rows read over 22\.00 ms' "$dir/ro_info" ||
  fail "stated readout: $(grep shutter "$dir/ro_info")"
set +e
"$autocal" record --input sim:office --out "$dir/z" --readout-ms -3 2>"$dir/err"; code=$?
set -e
[[ $code -eq 2 ]] && grep -q -- '--readout-ms takes' "$dir/err" || fail "bad readout exits $code"
echo "record_info: all checks passed"
