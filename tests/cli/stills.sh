#!/usr/bin/env bash
# `autocal run --stills` end to end: a folder of photographs (OpenCV's sample shots) and a
# simulated recording taken as still shots write the history, summary and export of any
# run (with the error against the truth where there is one); Ctrl-C stops it with those
# files complete; too few shots, an unreadable one and a live input are refused with a
# message naming what is wrong. Accuracy is tested in tests/still_shots_test.cc.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
pid=""
trap '[[ -n "$pid" ]] && kill -9 "$pid" 2>/dev/null; rm -rf "$dir"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/common.bash"
data=/usr/share/doc/opencv-doc/examples/data
[[ -f "$data/left01.jpg" ]] || fail "OpenCV's sample images are missing: apt-get install opencv-doc"

# Real photographs with no prior: a 75 degree start, said so; every step reported.
mkdir "$dir/left"
cp "$data"/left0[1-6].jpg "$dir/left/"
"$autocal" run --input "$dir/left" --stills --history "$dir/left.sqlite" \
  --summary "$dir/left.json" --export "$dir/left.yaml" --format opencv \
  >"$dir/out" 2>"$dir/progress"
cat "$dir/progress" "$dir/out"
grep -q 'no --prior: starting from a 75 degree field of view' "$dir/progress" || fail "the start said"
grep -q 'run: planes (box 6) between 15 pairs of shots' "$dir/progress" || fail "steps shown"
grep -qE '^6 frames' "$dir/out" || fail "shots reported"
grep -qE '^attempts [1-9]' "$dir/out" || fail "attempts were made"
for key in '"frames": 6' '"final": {' '"updates": {"attempted":' '"timing_ms": {' \
  '"features": {"median":' '"planes": {"median":' '"calibration": {"median":'; do
  grep -q "$key" "$dir/left.json" || fail "summary has $key: $(cat "$dir/left.json")"
done
grep -q 'camera_matrix' "$dir/left.yaml" || fail "export written"
"$autocal" export --history "$dir/left.sqlite" --format csv --out "$dir/left.csv" >/dev/null
attempts=$(grep -oE '"attempted": [0-9]+' "$dir/left.json" | grep -oE '[0-9]+$')
[[ $(($(wc -l <"$dir/left.csv") - 1)) -eq $attempts ]] || fail "one history row per attempt"

# A simulated recording as shots: the summary compares with its truth.
"$autocal" run --input "sim:office,seconds=8,fps=1,lens=sonnar,resolution=640x480" --stills \
  --summary "$dir/sim.json" >"$dir/out" 2>/dev/null
grep -q '^error against the truth:' "$dir/out" || fail "error against the truth reported"
grep -q '"error": {"final": {"fx_percent":' "$dir/sim.json" || fail "summary has error"

# Ctrl-C while the keypoints of 16 large shots are found (seconds before box 10): exit
# 130, said on stderr, and the history, summary and export hold the start and no attempt.
"$autocal" run --input "sim:office,seconds=16,fps=1,lens=sonnar,resolution=1280x720" --stills \
  --history "$dir/int.sqlite" --summary "$dir/int.json" --export "$dir/int.yaml" --format opencv \
  >"$dir/out" 2>"$dir/err" &
pid=$!
signal_when INT '^run: keypoints \(box 4\)' "$dir/err"
cat "$dir/err" "$dir/out"
[[ $code -eq 130 ]] || fail "Ctrl-C stops the run (exit $code)"
grep -q '^autocal run: stopped by SIGINT after 0 attempts' "$dir/err" || fail "the stop is said"
grep -q '^stopped after 0 attempts' "$dir/out" || fail "the report says it was stopped"
grep -q '"stopped": true' "$dir/int.json" || fail "the summary says it was stopped"
grep -q 'camera_matrix' "$dir/int.yaml" || fail "export written"
"$autocal" export --history "$dir/int.sqlite" --format csv --out "$dir/int.csv" >/dev/null
[[ $(wc -l <"$dir/int.csv") -eq 1 ]] || fail "the history holds no attempt: $(cat "$dir/int.csv")"
# As a calibration, a history with no attempt is the start the run exported; one with no
# start either has no calibration to give.
"$autocal" export --history "$dir/int.sqlite" --calibration --format opencv \
  --out "$dir/start.yaml" >"$dir/out"
grep -q 'the calibration the run started from' "$dir/out" || fail "the start said: $(cat "$dir/out")"
cmp "$dir/int.yaml" "$dir/start.yaml" || fail "the start exported is the run's export"
cp "$dir/int.sqlite" "$dir/no_start.sqlite"
sqlite3 "$dir/no_start.sqlite" "delete from session"
set +e
"$autocal" export --history "$dir/no_start.sqlite" --calibration --format opencv \
  --out "$dir/x.yaml" 2>"$dir/err"
code=$?
set -e
[[ $code -eq 1 ]] && grep -q 'no_start.sqlite.*holds no start' "$dir/err" ||
  fail "a history with no start: exit $code: $(cat "$dir/err")"

mkdir "$dir/two" "$dir/broken"
cp "$data/graf1.png" "$data/graf3.png" "$dir/two/"
expect_run 1 '2 images; still shots need at least 3' --input "$dir/two" --stills
cp "$data"/left0[1-3].jpg "$dir/broken/"
echo 'not a picture' >"$dir/broken/left04.jpg"
expect_run 1 'left04.jpg: cannot be decoded' --input "$dir/broken" --stills
# OpenCV's left.jpg is of another size than its left01-14.jpg: the file is named.
mkdir "$dir/sizes"
cp "$data/left.jpg" "$data"/left0[1-3].jpg "$dir/sizes/"
expect_run 1 'sizes/left01.jpg is 640x480 and .*sizes/left.jpg, the first shot, is 612x459' \
  --input "$dir/sizes" --stills
expect_run 2 '--stills goes with a recording or an image folder' --input camera:0 --stills
expect_run 2 '--stills goes with a recording or an image folder' --input sim:office --live --stills
echo PASS
