#!/usr/bin/env bash
# `autocal bench` (issue #6): the whole pipeline timed on a simulated recording, its figures
# (with each thread's CPU and waits) printed and written as JSON; --loop plays a short
# rendering over and over for a long session's memory; --live plays the frames as a camera
# in real time; --history keeps the attempts; --settings and --set change the pipeline's
# options, reported with the figures; bad arguments are refused with the reason.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
field() { grep -oE "\"$1\": [-0-9.e+]+" "$2" | head -1 | grep -oE '[-0-9.e+]+$'; }

"$autocal" bench --scenario office --resolution 320x240 --seconds 2 --json "$dir/plain.json" \
  >"$dir/plain.txt" 2>/dev/null
[[ $(field frames "$dir/plain.json") == 60 ]] || fail "2 s at 30 fps are 60 frames: $(cat "$dir/plain.json")"
for box in lines flow planes frame; do
  grep -q "\"$box\": {\"median\"" "$dir/plain.json" || fail "no timing of $box in the JSON"
  grep -qE "^$box +[0-9.]+ +[0-9.]+ +60$" "$dir/plain.txt" || fail "no timing of $box printed"
done
awk -v fps="$(field fps "$dir/plain.json")" 'BEGIN { exit !(fps > 0) }' || fail "no frame rate"
grep -q '^settings: the defaults$' "$dir/plain.txt" || fail "the defaults not reported"
# Seconds of the JSON named $1 ("some": more than none), no more than the run's wall-clock time.
wall=$(field wall_seconds "$dir/plain.json")
seconds_within_run() {
  local s
  s=$(grep -oE "\"$1\": [0-9.e+-]+" "$dir/plain.json" | grep -oE '[0-9.e+-]+$')
  awk -v s="$s" -v some="$2" -v w="$wall" \
    'BEGIN { exit !(s != "" && (some == "some" ? s > 0 : s >= 0) && s <= w) }' ||
    fail "$1: '$s' s in $wall s"
}
# Each pipeline thread's CPU time, printed and in the JSON.
for thread in "boxes 1-3" "boxes 4-9" "box 10"; do
  seconds_within_run "$thread" some
  grep -qE "^CPU by thread: .*$thread [0-9.]+ s \([0-9.]+ ms a frame\)" "$dir/plain.txt" ||
    fail "CPU of $thread not printed: $(grep CPU "$dir/plain.txt")"
done
# And what the process used beside them (OpenCV's worker, the thread feeding frames, box 2).
other=$(field other_threads_cpu_s "$dir/plain.json")
awk -v c="$other" 'BEGIN { exit !(c > 0) }' || fail "CPU of the other threads: '$other' s"
grep -qE "^CPU by thread: .*, other threads [0-9.]+ s \([0-9.]+ ms a frame\)$" "$dir/plain.txt" ||
  fail "CPU of the other threads not printed: $(grep CPU "$dir/plain.txt")"
# Where the per-frame threads waited, printed and in the JSON (none at all is possible).
for wait in "boxes 1-3 for frames" "boxes 1-3 for boxes 4-9" "boxes 4-9 for boxes 1-3" \
  "boxes 4-9 for box 10"; do
  seconds_within_run "$wait" any
  grep -qE "^waited: (.*, )?$wait [0-9.]+ s(,|$)" "$dir/plain.txt" ||
    fail "wait of $wait not printed: $(grep waited "$dir/plain.txt")"
done
grep -q '"settings": {}' "$dir/plain.json" || fail "no settings changed in the JSON"

# Box 10 tried twice as often: more attempts than with the defaults, and the change said.
calibrations() { grep -oE '"calibration": \{"median": [0-9.e+-]+, "p95": [0-9.e+-]+, "count": [0-9]+' "$1" | grep -oE '[0-9]+$'; }
printf 'material.attempt_every_s = 0.25\n' >"$dir/often.settings"
"$autocal" bench --scenario office --resolution 320x240 --seconds 2 --settings "$dir/often.settings" \
  --set motion.flow.target_tracks=250 --json "$dir/often.json" >"$dir/often.txt" 2>/dev/null
(( $(calibrations "$dir/often.json") > $(calibrations "$dir/plain.json") )) ||
  fail "attempts every 0.25 s: $(calibrations "$dir/often.json"), defaults: $(calibrations "$dir/plain.json")"
grep -q '^settings: motion.flow.target_tracks = 250, material.attempt_every_s = 0.25$' "$dir/often.txt" ||
  fail "changed settings reported: $(grep settings "$dir/often.txt")"
grep -q '"settings": {"motion.flow.target_tracks": "250", "material.attempt_every_s": "0.25"}' \
  "$dir/often.json" || fail "changed settings in the JSON: $(grep settings "$dir/often.json")"
# Refused before the rendering, naming the option.
if "$autocal" bench --seconds 600 --set material.window_s=-1 >/dev/null 2>"$dir/err.txt"; then
  fail "a bad --set was accepted"
fi
grep -q "material.window_s" "$dir/err.txt" || fail "the refusal names the option: $(cat "$dir/err.txt")"
grep -q "rendering" "$dir/err.txt" && fail "rendered before checking the settings"
if "$autocal" bench --set material.window_s >/dev/null 2>"$dir/err.txt"; then
  fail "a --set without a value was accepted"
else
  [[ $? == 2 ]] || fail "a --set without a value is bad usage (exit 2)"
fi

# 1 s rendered, played 4 times: 120 frames with times running on, memory sampled.
"$autocal" bench --scenario office --resolution 320x240 --seconds 4 --loop 1 \
  --json "$dir/loop.json" >"$dir/loop.txt" 2>/dev/null
[[ $(field frames "$dir/loop.json") == 120 ]] || fail "4 s looped are 120 frames: $(cat "$dir/loop.json")"
awk -v s="$(field seconds "$dir/loop.json")" 'BEGIN { exit !(s > 3.9 && s < 4.1) }' ||
  fail "the passes follow each other in time: $(field seconds "$dir/loop.json") s"
[[ $(field loop_seconds "$dir/loop.json") == 1 ]] || fail "loop_seconds in the JSON"
[[ $(grep -o '"mb":' "$dir/loop.json" | wc -l) -ge 9 ]] || fail "resident size sampled every 10%"
grep -q "looped" "$dir/loop.txt" || fail "the report says the recording was looped"

# Played as a 30 fps camera: paced, not as fast as it can; every frame processed or counted
# as dropped; attempts judged, their latency timed from the camera's delivery.
# The history kept where --history says: one attempt for each judged update.
"$autocal" bench --scenario office --resolution 160x120 --seconds 5 --live \
  --history "$dir/live.sqlite" --json "$dir/live.json" >"$dir/live.txt" 2>/dev/null
grep -q '"live": true' "$dir/live.json" || fail "live in the JSON: $(cat "$dir/live.json")"
awk -v s="$(field wall_seconds "$dir/live.json")" 'BEGIN { exit !(s > 4.8) }' ||
  fail "5 s at 30 fps take 5 s when paced: $(field wall_seconds "$dir/live.json") s"
[[ $(( $(field frames "$dir/live.json") + $(field frames_dropped "$dir/live.json") )) == 150 ]] ||
  fail "150 frames processed or dropped: $(cat "$dir/live.json")"
grep -qE '"update_latency_ms": \{"median": [0-9.]+, "p95": [0-9.]+, "count": [1-9]' "$dir/live.json" ||
  fail "live attempts judged and timed: $(grep update_latency "$dir/live.json")"
awk -v c="$(field cores_busy "$dir/live.json")" 'BEGIN { exit !(c > 0) }' || fail "cores busy"
"$autocal" export --history "$dir/live.sqlite" --format csv --out "$dir/live.csv" >/dev/null
judged=$(grep -oE '"update_latency_ms": \{"median": [0-9.]+, "p95": [0-9.]+, "count": [0-9]+' "$dir/live.json" | grep -oE '[0-9]+$')
[[ $(( $(wc -l <"$dir/live.csv") - 1 )) == "$judged" ]] ||
  fail "$judged updates judged, the history kept $(( $(wc -l <"$dir/live.csv") - 1 )) attempts"
# A history holds one run: a file that already holds one is refused before the rendering.
if "$autocal" bench --seconds 2 --history "$dir/live.sqlite" >/dev/null 2>"$dir/err.txt"; then
  fail "a --history already holding attempts was accepted"
fi
grep -q "already holds" "$dir/err.txt" || fail "the refusal says why: $(cat "$dir/err.txt")"
grep -q "rendering" "$dir/err.txt" && fail "rendered before checking the history"
grep -q "paced by the camera" "$dir/live.txt" || fail "the report says the run was paced"
if "$autocal" bench --seconds 2 --loop 1 --live >/dev/null 2>"$dir/err.txt"; then
  fail "--live with --loop was accepted"
fi
grep -q -- "--live" "$dir/err.txt" || fail "the refusal names --live: $(cat "$dir/err.txt")"

if "$autocal" bench --seconds 2 --loop 5 >/dev/null 2>"$dir/err.txt"; then
  fail "a loop longer than the session was accepted"
fi
grep -q -- "--loop" "$dir/err.txt" || fail "the refusal names --loop: $(cat "$dir/err.txt")"
echo "bench: $(field fps "$dir/plain.json") fps at 320x240; looped run of $(field frames "$dir/loop.json") frames"
