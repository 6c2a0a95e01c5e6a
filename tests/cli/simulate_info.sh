#!/usr/bin/env bash
# The foundation issue's acceptance run: simulate 10 s of the office through the sonnar
# lens at 640x480, then `autocal info` reports 300 frames at 30 fps, the accelerometer
# at its configured rate, and the ground truth. Also the CLI's errors and exit codes.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$autocal" --version | grep -qE '^autocal [0-9]+\.[0-9]+\.[0-9]+$' || fail "--version"
"$autocal" --help | grep -q simulate || fail "--help lists the commands"
set +e
"$autocal" frobnicate 2>"$dir/err"; code=$?
set -e
[[ $code -eq 2 ]] || fail "unknown command exits $code, expected 2"
grep -q "unknown command 'frobnicate'" "$dir/err" || fail "unknown command message"

"$autocal" simulate --list | grep -q '^drift' || fail "simulate --list names drift"

"$autocal" simulate --scenario office --lens sonnar --seconds 10 --resolution 640x480 \
  --accel-rate 800 --out "$dir/rec" 2>"$dir/progress" >"$dir/out"
grep -q '300/300 frames (100%)' "$dir/progress" || fail "progress shown: $(cat "$dir/progress")"
grep -q 'wrote 300 frames' "$dir/out" || fail "summary line: $(cat "$dir/out")"

"$autocal" info "$dir/rec" >"$dir/info"
cat "$dir/info"
grep -qE '^frames +300 frames over 9\.967 s, median rate 30\.00 Hz' "$dir/info" || fail "300 frames at 30 fps"
grep -qE '^accelerometer +[0-9]+ samples over .* median rate 800\.0 Hz' "$dir/info" || fail "accelerometer at 800 Hz"
grep -qE '^ground truth +yes' "$dir/info" || fail "ground truth reported"
grep -qE '^findings +none' "$dir/info" || fail "no findings on a clean recording"
grep -qE '^shutter +global, or not known' "$dir/info" || fail "shutter reported"
"$autocal" info "sim:office,seconds=0.2,readout_ms=20" >"$dir/info_rolling"
grep -qE '^shutter +rolling, rows read over 20\.00 ms' "$dir/info_rolling" ||
  fail "rolling shutter reported: $(cat "$dir/info_rolling")"
for f in intrinsics.csv poses.csv scene.yaml; do
  [[ -s "$dir/rec/ground_truth/$f" ]] || fail "ground_truth/$f missing"
done
head -1 "$dir/rec/ground_truth/intrinsics.csv" | grep -qx '#timestamp \[ns\],fx,fy,cx,cy,k1,k2,p1,p2,k3' || fail "intrinsics.csv header"
head -1 "$dir/rec/ground_truth/poses.csv" | grep -qx '#timestamp \[ns\],p_x,p_y,p_z,q_w,q_x,q_y,q_z' || fail "poses.csv header"
[[ $(($(wc -l <"$dir/rec/ground_truth/intrinsics.csv") - 1)) -eq 300 ]] || fail "one intrinsics row per frame"
[[ $(ls "$dir/rec/ground_truth/planes" | wc -l) -eq 300 ]] || fail "one plane-label image per frame"

# A damaged recording: the error names the file and the line; --truncate-at-fault reads
# up to the fault.
sed -i '101s/.*/garbage/' "$dir/rec/cam0/data.csv"
set +e
"$autocal" info "$dir/rec" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] || fail "damaged recording exits $code, expected 1"
grep -q 'cam0/data.csv:101:' "$dir/err" || fail "error names file and line: $(cat "$dir/err")"
"$autocal" info --truncate-at-fault "$dir/rec" >"$dir/info" || true
grep -qE '^frames +99 frames' "$dir/info" || fail "truncated read keeps the 99 frames before the fault: $(cat "$dir/info")"

set +e
"$autocal" info "$dir/nowhere" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] || fail "missing recording exits $code"
grep -q "$dir/nowhere" "$dir/err" || fail "missing recording named"
echo "simulate_info: all checks passed"
