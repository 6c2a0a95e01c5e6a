#!/usr/bin/env bash
# autocal-workbench --prior: the pipeline starts from the calibration file given (its
# numbers in the log); a file that cannot be read is refused with exit 2 and the reader's
# message. Runs under the test command's Xvfb, with settings kept out of the user's.
set -euo pipefail
autocal="$1"
workbench="$(dirname "$autocal")/autocal-workbench"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
source "$(dirname "$0")/common.bash"
if [[ ! -x $workbench ]]; then
  echo "autocal-workbench is not built (AUTOCAL_BUILD_GUI off): nothing to test"
  exit 0
fi
[[ -n ${DISPLAY:-} ]] || fail "needs a display: the test command runs under Xvfb"
export XDG_CONFIG_HOME="$dir/config"
source_spec="sim:office,seconds=1,resolution=160x120"

code=0
"$workbench" --prior "$dir/none.yaml" --quit-after 100 "$source_spec" 2>"$dir/err" || code=$?
[[ $code -eq 2 ]] || fail "an unreadable --prior exits $code, expected 2: $(cat "$dir/err")"
grep -q "none.yaml: no such calibration file" "$dir/err" || fail "the reader's message: $(cat "$dir/err")"

write_calibration "$dir/vest.yaml" 160 120 110 111 80 60
"$workbench" --prior "$dir/vest.yaml" --quit-after 4000 "$source_spec" 2>"$dir/err" ||
  fail "a readable --prior: $(cat "$dir/err")"
grep -q "Pre-mission calibration from $dir/vest.yaml: 160x120, fx 110.0 fy 111.0 cx 80.0 cy 60.0 px" \
  "$dir/err" || fail "the calibration's numbers in the log: $(cat "$dir/err")"
grep -q "Pipeline started" "$dir/err" || fail "the pipeline runs from it: $(cat "$dir/err")"
echo "ok"
