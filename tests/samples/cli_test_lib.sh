# Shared by the command-line tests (sourced, POSIX sh): failure counting and the check every
# tool's error paths must pass. Expects WORK (the test's scratch directory) to be set.
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect_failure TOOL OUTPUT EXPECTED ARGS...: TOOL ARGS exits with EXPECTED, writes exactly
# one line on stderr and leaves no OUTPUT file.
expect_failure() {
  tool=$1 output=$2 expected=$3
  shift 3
  rm -f "$output"
  "$tool" "$@" 2>"$WORK/stderr" >/dev/null
  code=$?
  lines=$(wc -l <"$WORK/stderr")
  if [ "$code" -ne "$expected" ] || [ "$lines" -ne 1 ]; then
    fail "'$*': exit $code (expected $expected), $lines stderr lines: $(cat "$WORK/stderr")"
  fi
  [ ! -e "$output" ] || fail "'$*' left an output file"
}
