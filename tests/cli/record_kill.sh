#!/usr/bin/env bash
# A recording killed with SIGKILL mid-way is readable up to its last second: `autocal
# info` accepts it as it is (no --truncate-at-fault), and it holds at least the frames
# and accelerometer samples the last progress line (printed each second, counting only
# rows already flushed) reported before the kill. Ctrl-C (SIGINT) instead stops it cleanly:
# exit 0, a summary naming exactly what the recording holds.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
pid=""
trap '[[ -n "$pid" ]] && kill -9 "$pid" 2>/dev/null; rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$autocal" record --input sim:office --seconds 20 --out "$dir/rec" 2>"$dir/progress" >/dev/null &
pid=$!
# Wait for at least three progress lines with frames written (the machine may be slow).
for _ in $(seq 600); do
  lines=$(grep -cE '^record: .* [1-9][0-9]* frames' "$dir/progress" || true)
  [[ $lines -ge 3 ]] && break
  kill -0 "$pid" 2>/dev/null || fail "record ended before it could be killed: $(cat "$dir/progress")"
  sleep 0.2
done
[[ $lines -ge 3 ]] || fail "no progress after 120 s: $(cat "$dir/progress")"
kill -9 "$pid"
wait "$pid" 2>/dev/null || true
pid=""
last=$(grep -E '^record: ' "$dir/progress" | tail -1)
echo "last progress before the kill: $last"
frames=$(sed -E 's/^record: [0-9.]+ s, ([0-9]+) frames, ([0-9]+) accelerometer samples.*/\1/' <<<"$last")
samples=$(sed -E 's/^record: [0-9.]+ s, ([0-9]+) frames, ([0-9]+) accelerometer samples.*/\2/' <<<"$last")
[[ "$frames" =~ ^[0-9]+$ && "$samples" =~ ^[0-9]+$ ]] || fail "cannot parse: $last"

"$autocal" info "$dir/rec" >"$dir/info" || fail "info refuses the killed recording: $(cat "$dir/info")"
cat "$dir/info"
got_frames=$(sed -nE 's/^frames +([0-9]+) frames.*/\1/p' "$dir/info")
got_samples=$(sed -nE 's/^accelerometer +([0-9]+) samples.*/\1/p' "$dir/info")
[[ $got_frames -ge $frames ]] || fail "$got_frames frames kept, $frames were reported written"
[[ $got_samples -ge $samples ]] || fail "$got_samples samples kept, $samples were reported written"
[[ $got_frames -lt 600 ]] || fail "the kill did not interrupt the recording"
grep -qE '^frame gaps +none' "$dir/info" || fail "frames kept are consecutive"
# Every row of cam0/data.csv names a complete PNG (written under a temporary name, then
# renamed), and the rows are whole lines.
[[ $(tail -c 1 "$dir/rec/cam0/data.csv" | od -An -c | tr -d ' ') == '\n' ]] || fail "cam0/data.csv ends mid-row"
[[ $(tail -c 1 "$dir/rec/accel0/data.csv" | od -An -c | tr -d ' ') == '\n' ]] || fail "accel0/data.csv ends mid-row"
# SIGINT: a clean stop.
"$autocal" record --input sim:office --seconds 20 --out "$dir/int" 2>"$dir/progress2" >"$dir/out2" &
pid=$!
for _ in $(seq 600); do
  grep -qE '^record: .* [1-9][0-9]* frames' "$dir/progress2" && break
  sleep 0.2
done
kill -INT "$pid"
set +e
wait "$pid"; code=$?
set -e
pid=""
[[ $code -eq 0 ]] || fail "record stopped by SIGINT exits $code: $(cat "$dir/progress2")"
summary_frames=$(sed -nE 's/^recorded ([0-9]+) frames and ([0-9]+) accelerometer samples.*/\1/p' "$dir/out2")
summary_samples=$(sed -nE 's/^recorded ([0-9]+) frames and ([0-9]+) accelerometer samples.*/\2/p' "$dir/out2")
[[ -n "$summary_frames" ]] || fail "summary after SIGINT: $(cat "$dir/out2")"
"$autocal" info "$dir/int" >"$dir/info2" || fail "info refuses the stopped recording: $(cat "$dir/info2")"
grep -qE "^frames +$summary_frames frames" "$dir/info2" || fail "summary says $summary_frames frames: $(cat "$dir/info2")"
grep -qE "^accelerometer +$summary_samples samples" "$dir/info2" || fail "summary says $summary_samples samples"
[[ $summary_frames -lt 600 ]] || fail "SIGINT did not stop the recording"

echo "record_kill: all checks passed ($got_frames frames, $got_samples samples after SIGKILL)"
