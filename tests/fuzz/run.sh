#!/usr/bin/env bash
# Builds the fuzzers (clang, ASan + UBSan + libFuzzer) in build-fuzz, makes the seed corpora
# and runs every target for SECONDS:
#
#   tests/fuzz/run.sh [SECONDS (default 120)] [TARGET...]
#
# Prints, per target, the executions, libFuzzer's coverage (cov: edges, ft: features), the
# corpus size and any artifact; exits non-zero on any crash, leak, timeout or OOM. The corpus
# grows in build-fuzz/corpus/TARGET across runs (seeds: build-fuzz/seeds/TARGET, remade when
# absent or with SKELFORM_FUZZ_RESEED=1); findings go to build-fuzz/artifacts/TARGET/, logs
# to build-fuzz/logs/. Replay one: build-fuzz/tests/fuzz/TARGET FILE.
# Everything runs under `nice -n 19` on at most two jobs: other measurements may share the
# machine. Environment: SKELFORM_FUZZ_BUILD_DIR (default build-fuzz), SKELFORM_DATA_DIR,
# CC/CXX (default clang-14/clang++-14).
set -euo pipefail

seconds=${1:-120}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_asset fuzz_bake_input fuzz_handles)
case $seconds in '' | *[!0-9]*) echo "usage: $0 [SECONDS] [TARGET...]" >&2; exit 1 ;; esac

root=$(cd "$(dirname "$0")/../.." && pwd)
build=${SKELFORM_FUZZ_BUILD_DIR:-$root/build-fuzz}
export SKELFORM_FUZZ_BUILD_DIR=$build

echo "==> configuring $build"
CC=${CC:-clang-14} CXX=${CXX:-clang++-14} nice -n 19 cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSKELFORM_SANITIZE=address,undefined -DSKELFORM_FUZZ=ON -DSKELFORM_BUILD_BENCH=OFF > "$build.configure.log" 2>&1 ||
  { cat "$build.configure.log" >&2; exit 1; }
rm -f "$build.configure.log"
echo "==> building the fuzzers and the seed tools"
# Only what the fuzzers and make_seeds.sh need: runtime and baker libraries, the fuzzers,
# skelform-bake, skelform-character and the capsule writer of the tests.
nice -n 19 cmake --build "$build" -j 2 --target "${targets[@]}" skelform-bake skelform-character skelform_c_engine_capsule

if [ ! -d "$build/seeds" ] || [ "${SKELFORM_FUZZ_RESEED:-0}" = 1 ]; then
  echo "==> making the seed corpora"
  rm -rf "$build/seeds"
  nice -n 19 "$root/tests/fuzz/make_seeds.sh" "$build/seeds.tmp"
  mv "$build/seeds.tmp" "$build/seeds"
fi

export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
mkdir -p "$build/logs"
status=0
summary=()
for target in "${targets[@]}"; do
  corpus=$build/corpus/$target
  artifacts=$build/artifacts/$target
  log=$build/logs/$target.log
  mkdir -p "$corpus" "$artifacts" "$build/seeds/$target"
  echo "==> $target for ${seconds} s (log: $log)"
  # Artifacts of earlier runs stay (until triaged) but only this run's count here.
  touch "$build/logs/$target.start"
  rc=0
  # New units go to the first directory (the growing corpus); the seeds are read only.
  nice -n 19 "$build/tests/fuzz/$target" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$artifacts/" "$corpus" "$build/seeds/$target" > "$log" 2>&1 || rc=$?
  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  coverage=$(grep -E '^#[0-9]+.*cov: ' "$log" | tail -n 1 | sed -E 's/.*(cov: [0-9]+ ft: [0-9]+ corp: [^ ]+).*/\1/')
  found=$(find "$artifacts" -type f -newer "$build/logs/$target.start" | wc -l)
  line="$target: exit $rc, ${executions:-?} executions, ${coverage:-no coverage line}, corpus dir $(find "$corpus" -type f | wc -l) files, $found artifact(s)"
  echo "$line"
  summary+=("$line")
  if [ "$rc" -ne 0 ] || [ "$found" -ne 0 ]; then
    status=1
    grep -E '^(==[0-9]+==ERROR|SUMMARY|.*runtime error|skelform fuzz finding|ERROR: libFuzzer)' "$log" | head -n 5 || true
    find "$artifacts" -type f -newer "$build/logs/$target.start" | head -n 5
  fi
done

echo "==> summary"
printf '%s\n' "${summary[@]}"
exit $status
