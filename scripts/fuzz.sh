#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) and fuzzes each parser of a user-supplied
# file for SECONDS (default 30), starting from the seed corpus in fuzz/corpus/<target>. Prints
# the executions run per target; exits non-zero on the first finding (its input is kept in
# build-fuzz/findings/). Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
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
for t in "${targets[@]}"; do
  work="build-fuzz/corpus/$t"
  mkdir -p "$work"
  log="build-fuzz/$t.log"
  if ! UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "build-fuzz/fuzz/${t}_fuzzer" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 \
    -rss_limit_mb=2048 -artifact_prefix="build-fuzz/findings/$t-" "$work" "fuzz/corpus/$t" \
    > "$log" 2>&1; then
    tail -40 "$log"
    echo "fuzz: $t: FINDING (input in build-fuzz/findings/)"
    exit 1
  fi
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
  echo "fuzz: $t: ${execs:-?} executions in ${seconds} s, no finding"
done
