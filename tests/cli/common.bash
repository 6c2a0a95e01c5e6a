# Sourced by the command-line tests (after setting $autocal and $dir); not a test itself
# (the test glob takes *.sh only).
fail() { echo "FAIL: $*" >&2; exit 1; }

# expect_run CODE PATTERN ARGS...: `autocal run ARGS` exits with CODE and says PATTERN on
# stderr.
expect_run() {
  local code=$1 pattern=$2
  shift 2
  set +e
  "$autocal" run "$@" >/dev/null 2>"$dir/err"
  local got=$?
  set -e
  [[ $got -eq $code ]] || fail "run $* exits $got, expected $code: $(cat "$dir/err")"
  grep -q -- "$pattern" "$dir/err" || fail "run $*: expected '$pattern' in: $(cat "$dir/err")"
}

# write_calibration FILE WIDTH HEIGHT FX FY CX CY: an OpenCV YAML calibration without
# distortion, as `autocal run --export --format opencv` writes one.
write_calibration() {
  cat >"$1" <<YAML
%YAML:1.0
---
image_width: $2
image_height: $3
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ $4, 0., $6, 0., $5, $7, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ 0., 0., 0., 0., 0. ]
YAML
}

# signal_when SIGNAL PATTERN FILE [DELAY]: once FILE (where the background job $pid writes)
# has a line matching PATTERN (extended), waits DELAY seconds, sends SIGNAL to $pid and
# waits for it to end; its exit code is left in $code and $pid is cleared. Fails when the
# job ends first or no such line comes within 120 s.
signal_when() {
  local tries
  for ((tries = 0; tries < 6000; ++tries)); do
    grep -qE -- "$2" "$3" && break
    kill -0 "$pid" 2>/dev/null || fail "ended before it could be stopped: $(tail -3 "$3")"
    sleep 0.02
  done
  ((tries < 6000)) || fail "no '$2' within 120 s: $(tail -3 "$3")"
  sleep "${4:-0}"
  kill "-$1" "$pid"
  code=0
  wait "$pid" || code=$?
  pid=""
}
