#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang with ASan + UBSan) into ./build-fuzz, writes
# their seed corpora (generated inputs, plus ../shared/data frames when present) and runs
# each target for SECONDS (default 60) on one core, one after the other.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]     e.g. scripts/fuzz.sh 600 fuzz_map
#
# Each target's corpus grows in build-fuzz/corpus/<target>; a crash is written to
# build-fuzz/findings/<target>/ (reproduce: build-fuzz/fuzz/<target> FILE) and makes the
# script exit 1 after the other targets have run. Prints executions, exec/s and the corpus
# size per target.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
((${#targets[@]})) || targets=(fuzz_request fuzz_jpeg fuzz_map fuzz_handler fuzz_session)

bash scripts/setup.sh --fuzz
if [[ ! -f build-fuzz/CMakeCache.txt ]]; then
  generator=()
  command -v ninja >/dev/null && generator=(-G Ninja)
  CC=clang CXX=clang++ cmake -S . -B build-fuzz "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DSCENELOC_FUZZ=ON -DSCENELOC_BUILD_TESTS=OFF -DSCENELOC_BUILD_BENCHMARKS=OFF
fi
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]}" sceneloc-fuzz-seeds

seeds=build-fuzz/seeds
if [[ ! -d $seeds/session ]]; then  # the newest target's seeds: older folders are redone
  data=../shared/data
  [[ -d $data ]] || data=""
  build-fuzz/fuzz/sceneloc-fuzz-seeds "$seeds" tests/data/v1_map.scnl $data
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
failed=()
summary=()
for target in "${targets[@]}"; do
  case $target in
    fuzz_request | fuzz_handler) seed=$seeds/request ;;
    fuzz_jpeg) seed=$seeds/jpeg ;;
    fuzz_map) seed=$seeds/map ;;
    fuzz_session) seed=$seeds/session ;;
    *) echo "fuzz.sh: unknown target '$target'" >&2; exit 2 ;;
  esac
  corpus=build-fuzz/corpus/$target
  findings=build-fuzz/findings/$target
  log=build-fuzz/logs/$target.log
  mkdir -p "$corpus" "$findings" "$(dirname "$log")"
  echo "fuzz.sh: $target for ${seconds}s (log: $log)"
  status=0
  # -rss_limit_mb: the server's own limits keep every input far below this; -timeout: a
  # single input taking longer is a finding (a request that would hold a worker).
  "build-fuzz/fuzz/$target" "$corpus" "$seed" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$findings/" \
    >"$log" 2>&1 || status=$?
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  units=$(find "$corpus" -type f | wc -l)
  line="$target: ${runs:-0} executions, ${rate:-0}/s, corpus $units, exit $status"
  summary+=("$line")
  if ((status != 0)); then
    failed+=("$target")
    tail -n 40 "$log" >&2
  fi
done
printf '%s\n' "${summary[@]}"
if ((${#failed[@]})); then
  echo "fuzz.sh: findings in: ${failed[*]} (see build-fuzz/findings/)" >&2
  exit 1
fi
