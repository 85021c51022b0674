#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) and fuzzes each parser of a user-supplied
# file for SECONDS (default 30), starting from the seed corpus in fuzz/corpus/<target>. Prints
# the executions run per target, two targets at a time; exits non-zero after any finding (its
# input is kept in build-fuzz/findings/). Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(tum track_folder calibration layout truth trees_csv options cloud)
CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DSTEMMAP_FUZZ=ON -DSTEMMAP_BUILD_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_UNITY_BUILD=ON > /dev/null
cmake --build build-fuzz --target "${targets[@]/%/_fuzzer}"
mkdir -p build-fuzz/findings
# One target's run; prints its executions, or its log's tail and the finding.
fuzz_one() {
  local t="$1" work="build-fuzz/corpus/$1" log="build-fuzz/$1.log" execs
  mkdir -p "$work"
  if ! UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "build-fuzz/fuzz/${t}_fuzzer" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 \
    -rss_limit_mb=2048 -artifact_prefix="build-fuzz/findings/$t-" "$work" "fuzz/corpus/$t" \
    > "$log" 2>&1; then
    tail -40 "$log"
    echo "fuzz: $t: FINDING (input in build-fuzz/findings/)"
    return 1
  fi
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
  echo "fuzz: $t: ${execs:-?} executions in ${seconds} s, no finding"
}
# Two targets at a time (each fuzzer is one process on one core; they all run equally long, so
# waiting for the older one first loses nothing).
status=0
running=()
for t in "${targets[@]}"; do
  fuzz_one "$t" &
  running+=("$!")
  if [ "${#running[@]}" -ge 2 ]; then
    wait "${running[0]}" || status=1
    running=("${running[@]:1}")
  fi
done
for pid in "${running[@]}"; do wait "$pid" || status=1; done
exit "$status"
