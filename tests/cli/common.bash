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
