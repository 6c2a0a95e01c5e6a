#!/usr/bin/env bash
# `autocal run` on a live source (issue 6: live mode with a source faster than the
# pipeline; issue 7: run on live sources): a simulated 640x480 walk played as a live
# source. Four times faster than real time, frames are dropped and counted in the summary
# and nothing blocks (the run ends on time); in real time from a wrong start it converges.
# SIGINT mid-run leaves a complete history and summary. No camera: the message says what
# was found, and nothing is written.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
json_number() {  # json_number FILE KEY: the first number after "KEY":
  grep -oE "\"$2\": -?[0-9.e+-]+" "$1" | head -1 | grep -oE -- '-?[0-9.e+-]+$'
}

# The walk, rendered first: the simulator renders 640x480 slower than real time here.
seconds=16
"$autocal" simulate --scenario office --lens sonnar --seconds "$seconds" --resolution 640x480 \
  --set supersampling=1 --out "$dir/walk" >/dev/null 2>&1 || fail "simulate"
frames_total=$((seconds * 30))

# Four times real time, 120 frames/s asked; the reader decodes some 50-80 frames/s here,
# about as fast as the pipeline runs at 640x480 with the defaults, so the pipeline is
# slowed (Lucas-Kanade windows of 31 px: 8 times the area) to fall behind on any machine,
# loaded or not. Frames are dropped and counted, and nothing blocks: --seconds ends the
# run on time.
start=$(date +%s.%N)
"$autocal" run --input "$dir/walk" --live --speed 4 --seconds 1.5 --summary "$dir/fast.json" \
  --set motion.flow.window_px=31 \
  >"$dir/fast.out" 2>"$dir/fast.progress" || fail "fast run: $(cat "$dir/fast.progress")"
elapsed=$(awk "BEGIN { print $(date +%s.%N) - $start }")
grep -q '"ended_by": "--seconds"' "$dir/fast.json" || fail "ended by --seconds: $(cat "$dir/fast.json")"
received=$(json_number "$dir/fast.json" frames_received)
dropped=$(json_number "$dir/fast.json" frames_dropped)
processed=$(json_number "$dir/fast.json" frames)
echo "4x: $received frames received in 1.5 s, $dropped dropped, $processed processed; $elapsed s"
[[ $dropped -gt 0 ]] || fail "a source faster than the pipeline: frames dropped"
by_pipeline=$(json_number "$dir/fast.json" frames_dropped_by_pipeline)
[[ $((processed + by_pipeline)) -eq $received ]] || fail "each frame received processed or dropped"
grep -qE "^live: $received frames received, $dropped dropped" "$dir/fast.out" || fail "drops reported"
# Start-up (opening the recording, the first frames), then the queued frames and the
# solve in flight: a few seconds, however far behind the pipeline was.
awk "BEGIN { exit !($elapsed < 1.5 + 6) }" || fail "the run took $elapsed s for --seconds 1.5"

# The issue's wrong start: fx, fy +5%, cx +15 px, cy -10 px, no distortion.
read -r fx fy cx cy < <(awk -F, 'NR == 2 { print $2, $3, $4, $5 }' "$dir/walk/ground_truth/intrinsics.csv")
cat >"$dir/wrong.yaml" <<EOF
%YAML:1.0
---
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ $(awk "BEGIN { print $fx * 1.05 }"), 0., $(awk "BEGIN { print $cx + 15 }"), 0., $(awk "BEGIN { print $fy * 1.05 }"), $(awk "BEGIN { print $cy - 10 }"), 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ 0., 0., 0., 0., 0. ]
EOF

# In real time from the wrong start: the run ends with the source, and converges.
start=$(date +%s.%N)
"$autocal" run --input "$dir/walk" --live --prior "$dir/wrong.yaml" --history "$dir/h.sqlite" \
  --summary "$dir/s.json" >"$dir/out" 2>"$dir/progress" || fail "live run: $(cat "$dir/progress")"
elapsed=$(awk "BEGIN { print $(date +%s.%N) - $start }")
cat "$dir/out"
grep -qE '^run: [0-9.]+ s, [0-9]+ frames done of [0-9]+ received, [0-9]+ dropped' "$dir/progress" \
  || fail "progress shown: $(tail -3 "$dir/progress")"
grep -q '"ended_by": "the source ended"' "$dir/s.json" || fail "ended by the source: $(cat "$dir/s.json")"
received=$(json_number "$dir/s.json" frames_received)
dropped=$(json_number "$dir/s.json" frames_dropped)
processed=$(json_number "$dir/s.json" frames)
[[ $received -eq $frames_total ]] || fail "every frame delivered: $received of $frames_total"
by_pipeline=$(json_number "$dir/s.json" frames_dropped_by_pipeline)
[[ $((processed + by_pipeline)) -eq $received ]] || fail "each frame received processed or dropped"
# Reading the PNGs competes with the pipeline for the cores: allow the source to run late.
awk "BEGIN { exit !($elapsed < 2 * $seconds + 6) }" || fail "the run took $elapsed s for $seconds s"
[[ -s "$dir/h.sqlite" ]] || fail "history written"
"$autocal" export --history "$dir/h.sqlite" --format csv --out "$dir/h.csv" >/dev/null
attempts=$(json_number "$dir/s.json" attempted)
[[ $(($(wc -l <"$dir/h.csv") - 1)) -eq $attempts ]] || fail "one history row per attempt ($attempts)"
fx_error=$(grep -oE '"final": \{"fx_percent": -?[0-9.e+-]+' "$dir/s.json" | grep -oE -- '-?[0-9.e+-]+$')
echo "real time: $processed of $received frames processed, $dropped dropped; fx error $fx_error%"
# Box 10 needs the frames: from the wrong start the walk converges (fx within 1%) when the
# pipeline takes at least 20 of its 30 frames a second, within about 5 s, once an alarm
# and three consistent attempts have replaced the wrong start (16 s leaves room: on 8 s,
# live timing once left the regime unconfirmed at the end). On a machine too loaded for that
# the material is too thin (attempts end "focal length not observable"), and it is said.
if [[ $((processed * 3)) -ge $((received * 2)) ]]; then
  awk "BEGIN { exit !($fx_error < 1 && $fx_error > -1) }" || fail "fx within 1% of the truth: $fx_error%"
else
  echo "NOTE: convergence not checked: the pipeline took $processed of $received frames on this loaded machine"
fi

# SIGINT mid-run: a clean stop with everything written.
"$autocal" run --input "$dir/walk" --live --history "$dir/h2.sqlite" --summary "$dir/s2.json" \
  >"$dir/out2" 2>"$dir/progress2" &
pid=$!
sleep 4
kill -INT $pid
wait $pid || fail "interrupted run exits 0: $(tail -3 "$dir/progress2")"
grep -q '"ended_by": "a stop request"' "$dir/s2.json" || fail "ended by the signal: $(cat "$dir/s2.json")"
grep -q '"timing_ms": {' "$dir/s2.json" || fail "summary complete"
received2=$(json_number "$dir/s2.json" frames_received)
[[ $received2 -lt $frames_total ]] || fail "stopped early: $received2 frames received"
attempts2=$(json_number "$dir/s2.json" attempted)
"$autocal" export --history "$dir/h2.sqlite" --format csv --out "$dir/h2.csv" >/dev/null \
  || fail "the interrupted run's history reads"
[[ $(($(wc -l <"$dir/h2.csv") - 1)) -eq $attempts2 ]] || fail "every attempt in the history ($attempts2)"

# No camera here (or not that one): what was found, exit 1, no files.
if ! ls /dev/video99 >/dev/null 2>&1; then
  set +e
  "$autocal" run --input camera:99 --accel usb:1234:5678 --summary "$dir/none.json" \
    >/dev/null 2>"$dir/err"
  code=$?
  set -e
  [[ $code -eq 1 ]] || fail "no camera: exit $code"
  grep -q 'no camera at /dev/video99; found: ' "$dir/err" || fail "no camera message: $(cat "$dir/err")"
  grep -q 'no USB accelerometer' "$dir/err" || fail "no accelerometer message: $(cat "$dir/err")"
  [[ ! -e "$dir/none.json" ]] || fail "nothing written without a device"
fi
set +e
"$autocal" run --input "$dir/walk" --seconds 2 >/dev/null 2>"$dir/err"; code=$?
set -e
[[ $code -eq 2 ]] && grep -q -- '--seconds goes with a live source' "$dir/err" || fail "--seconds alone: $code"
echo PASS
