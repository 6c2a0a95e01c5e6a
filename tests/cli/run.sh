#!/usr/bin/env bash
# `autocal run` end to end on a short simulated walk: history, summary and export written,
# progress shown, and every kind of bad input refused with a message and the right code.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
pid=""
trap '[[ -n "$pid" ]] && kill -9 "$pid" 2>/dev/null; rm -rf "$dir"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/common.bash"

"$autocal" --help | grep -qE '^  run ' || fail "--help lists run"

"$autocal" run --input "sim:office,seconds=4,resolution=320x240" --history "$dir/h.sqlite" \
  --summary "$dir/summary.json" --export "$dir/final.yaml" --format opencv \
  >"$dir/out" 2>"$dir/progress"
cat "$dir/out"
grep -q '120/120 frames (100%)' "$dir/progress" || fail "progress shown: $(tail -3 "$dir/progress")"
grep -qE '^120 frames \(4\.0 s of recording\)' "$dir/out" || fail "frames reported"
grep -qE '^attempts [1-9]' "$dir/out" || fail "attempts were made"
grep -q '^error against the truth:' "$dir/out" || fail "error against the truth reported"
for key in '"frames": 120' '"seconds":' '"fps":' '"final": {' '"rms_px":' '"updates": {"attempted":' \
  '"alarms": \[' '"timing_ms": {' '"lines": {"median":' '"calibration": {"median":' \
  '"error": {"final": {"fx_percent":'; do
  grep -q "$key" "$dir/summary.json" || fail "summary has $key: $(cat "$dir/summary.json")"
done
grep -q 'camera_matrix' "$dir/final.yaml" || fail "export written"
[[ -s "$dir/h.sqlite" ]] || fail "history written"

# The history exported whole, and as the calibration it ends with.
"$autocal" export --history "$dir/h.sqlite" --format csv --out "$dir/h.csv" >/dev/null
attempts=$(grep -oE '"attempted": [0-9]+' "$dir/summary.json" | grep -oE '[0-9]+$')
[[ $(($(wc -l <"$dir/h.csv") - 1)) -eq $attempts ]] || fail "one CSV row per attempt ($attempts)"
"$autocal" export --history "$dir/h.sqlite" --calibration --format ros --out "$dir/ros.yaml" >/dev/null
grep -q 'distortion_model: plumb_bob' "$dir/ros.yaml" || fail "ROS export"
fx_run=$(grep -oE '"final": \{[^}]*' "$dir/summary.json" | grep -oE '"fx": [0-9.]+' | grep -oE '[0-9.]+$')
fx_ros=$(grep -oE 'data: \[ *[0-9.]+' "$dir/ros.yaml" | head -1 | grep -oE '[0-9.]+$')
[[ "${fx_run:0:7}" == "${fx_ros:0:7}" ]] || fail "exported fx $fx_ros is the run's final $fx_run"
set +e
"$autocal" export --history "$dir/none.sqlite" --format csv --out "$dir/x.csv" 2>"$dir/err"; code=$?
set -e
[[ $code -eq 1 ]] && grep -q 'none.sqlite' "$dir/err" || fail "missing history file: $code $(cat "$dir/err")"
# A format of the other kind is named as such (json is of both).
for args in "--calibration --format csv:history format: it goes without" \
  "--format ros:calibration format: it goes with"; do
  set +e
  "$autocal" export --history "$dir/h.sqlite" ${args%%:*} --out "$dir/x" 2>"$dir/err"; code=$?
  set -e
  [[ $code -eq 2 ]] && grep -q "${args#*:} --calibration" "$dir/err" ||
    fail "export ${args%%:*}: exit $code: $(head -1 "$dir/err")"
done

# The exported calibration is a valid prior for another run.
"$autocal" run --input "sim:office,seconds=2,resolution=320x240" --prior "$dir/final.yaml" \
  >"$dir/out2" 2>/dev/null || fail "a run from the exported prior"
grep -qE '^prior +fx 20[0-9]\.' "$dir/out2" || fail "prior printed: $(cat "$dir/out2")"

# A rolling shutter the recording states is undone, unless the settings say otherwise.
"$autocal" run --input "sim:office,seconds=0.2,resolution=320x240,readout_ms=25" \
  --print-settings >"$dir/rolling.settings" 2>"$dir/rolling"
grep -q '^calibration.readout_ms = 25$' "$dir/rolling.settings" ||
  fail "the recording's readout taken: $(grep readout "$dir/rolling.settings")"
grep -q 'rolling shutter (rows read over 25 ms): undone' "$dir/rolling" ||
  fail "rolling shutter said: $(cat "$dir/rolling")"
"$autocal" run --input "sim:office,seconds=0.2,resolution=320x240,readout_ms=25" \
  --set calibration.readout_ms=0 --print-settings >"$dir/rolling.settings" 2>"$dir/rolling"
grep -q '^calibration.readout_ms = 0$' "$dir/rolling.settings" ||
  fail "--set over the recording: $(grep readout "$dir/rolling.settings")"
grep -q 'rolling shutter (rows read over 25 ms), but calibration.readout_ms is set to 0' \
  "$dir/rolling" || fail "rolling shutter warned: $(cat "$dir/rolling")"
"$autocal" run --input "sim:office,seconds=0.2,resolution=320x240" --print-settings \
  >"$dir/global.settings" 2>"$dir/global"
grep -q '^calibration.readout_ms = 0$' "$dir/global.settings" || fail "a global shutter's readout"
! grep -q 'rolling shutter' "$dir/global" || fail "nothing said of a global shutter"

# To a file first: grep -q stops reading at the first match, and under pipefail the
# writer's broken pipe would fail the line.
"$autocal" run --print-settings >"$dir/s.settings"
grep -q '^material.window_s = ' "$dir/s.settings" || fail "--print-settings"
sed -i 's/^material.window_s = .*/material.window_s = 3/' "$dir/s.settings"
"$autocal" run --settings "$dir/s.settings" --set material.max_lines=10 --print-settings \
  >"$dir/s2.settings"
grep -qx 'material.window_s = 3' "$dir/s2.settings" || fail "--settings read"
grep -qx 'material.max_lines = 10' "$dir/s2.settings" || fail "--set applied after --settings"

# Stopped by a signal mid-run: the frames done are finished and their files whole, and the
# exit code says the input was not run through. Rendered as it runs, 900 frames take longer
# than the wait on any machine.
interrupted_run() {  # interrupted_run SIGNAL NAME: stops a run once 20% is done
  "$autocal" run --input "sim:office,seconds=30,resolution=320x240" --history "$dir/$2.sqlite" \
    --summary "$dir/$2.json" --export "$dir/$2.yaml" --format opencv >"$dir/$2.out" \
    2>"$dir/$2.progress" &
  pid=$!
  signal_when "$1" '^run: 180/900 frames' "$dir/$2.progress"
}
interrupted_run INT int
[[ $code -eq 130 ]] || fail "SIGINT: exit $code: $(tail -3 "$dir/int.progress")"
grep -qE '^autocal run: stopped by SIGINT after [0-9]+ of 900 frames' "$dir/int.progress" ||
  fail "stop said: $(tail -2 "$dir/int.progress")"
grep -q '"stopped": true' "$dir/int.json" || fail "summary says stopped: $(head -5 "$dir/int.json")"
grep -q '"frames_in_input": 900' "$dir/int.json" || fail "summary has the input's frames"
grep -q '"error": {"final": {"fx_percent":' "$dir/int.json" || fail "truth compared when stopped"
done_frames=$(grep -oE '"frames": [0-9]+' "$dir/int.json" | grep -oE '[0-9]+$')
[[ $done_frames -ge 180 && $done_frames -lt 900 ]] || fail "frames done: $done_frames"
grep -qE "^stopped after $done_frames of the input's 900 frames" "$dir/int.out" ||
  fail "report says stopped: $(cat "$dir/int.out")"
grep -q 'camera_matrix' "$dir/int.yaml" || fail "export written when stopped"
"$autocal" export --history "$dir/int.sqlite" --format csv --out "$dir/int.csv" >/dev/null
attempts=$(grep -oE '"attempted": [0-9]+' "$dir/int.json" | grep -oE '[0-9]+$')
[[ $attempts -gt 0 && $(($(wc -l <"$dir/int.csv") - 1)) -eq $attempts ]] ||
  fail "every attempt judged is in the history ($attempts)"
grep -q '"stopped": false' "$dir/summary.json" || fail "a whole run says it was not stopped"
interrupted_run TERM term
[[ $code -eq 143 ]] && grep -q 'stopped by SIGTERM' "$dir/term.progress" ||
  fail "SIGTERM: exit $code: $(tail -2 "$dir/term.progress")"

expect_run 2 '--input is required'
expect_run 2 '--export and --format go together' --input sim:static --export "$dir/x.yaml"
expect_run 1 'no-such-dir' --input "$dir/no-such-dir"
expect_run 2 "--set takes name=value" --input sim:static --set material.window_s
expect_run 1 "unknown option 'material.windw_s'" --input sim:static --set material.windw_s=3
expect_run 1 'must be in' --input sim:static --set material.window_s=-1
expect_run 1 'unknown calibration format' --input sim:static --export "$dir/x" --format matlab
expect_run 1 'already holds a calibration history' --input sim:static --history "$dir/h.sqlite"
printf 'material.window_s 3\n' >"$dir/bad.settings"
expect_run 1 'bad.settings:1:' --input sim:static --settings "$dir/bad.settings"
# A 320x240 calibration for 640x480 frames.
"$autocal" run --input "sim:static,seconds=1,resolution=640x480" --prior "$dir/final.yaml" \
  >/dev/null 2>"$dir/err" && fail "a 320x240 prior accepted for 640x480 frames"
grep -q 'is for 320x240 images' "$dir/err" || fail "size mismatch message: $(cat "$dir/err")"
echo PASS
