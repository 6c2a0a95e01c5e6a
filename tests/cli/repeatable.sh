#!/usr/bin/env bash
# Two offline runs of the same recording with the same settings give the same results to
# the last digit (issue #6): the summary, apart from how long things took, and every
# attempt of the history.
set -euo pipefail
autocal="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# The summary without its wall-clock parts.
results() {
  awk '/^  "timing_ms": \{/ {skip = 1; next} skip && /^  \}/ {skip = 0; next} !skip' "$1" |
    grep -vE '^  "(wall_seconds|fps)":'
}

for run in 1 2; do
  "$autocal" run --input "sim:office,seconds=5,resolution=320x240" --history "$dir/$run.sqlite" \
    --summary "$dir/$run.json" >/dev/null 2>&1
  "$autocal" export --history "$dir/$run.sqlite" --format csv --out "$dir/$run.csv" >/dev/null
  results "$dir/$run.json" >"$dir/$run.results"
done
grep -q '"final": {' "$dir/1.results" || fail "the summary has results: $(cat "$dir/1.results")"
accepted=$(grep -oE '"accepted": [0-9]+' "$dir/1.json" | grep -oE '[0-9]+$')
[[ $accepted -ge 1 ]] || fail "the runs accepted an attempt (else there is little to compare)"
diff "$dir/1.results" "$dir/2.results" || fail "the summaries differ"
diff "$dir/1.csv" "$dir/2.csv" || fail "the histories differ"
echo "two runs agree: $(wc -l <"$dir/1.csv") history lines, $accepted accepted"
