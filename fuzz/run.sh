#!/usr/bin/env bash
# fuzz/run.sh TARGET SECONDS [libFuzzer options...]
#   TARGET: scene | dem. Builds build-fuzz (clang, libFuzzer + ASan + UBSan) if needed, then fuzzs
#   TARGET for SECONDS under `nice -n 19`, one process, starting from the seed corpus
#   (fuzz/corpus/TARGET, fuzz/regressions/TARGET) and growing fuzz/work/TARGET/corpus (git-ignored).
#   Crash, timeout and OOM reproducers land in fuzz/work/TARGET/artifacts. Prints executions,
#   coverage and the findings at the end; the full log is fuzz/work/TARGET/fuzz-<date>.log.
# FIRN_FUZZ_KEEP_GOING=1 keeps fuzzing after a finding (libFuzzer's -fork=1 -ignore_*).
set -euo pipefail
cd "$(dirname "$0")/.."

target=${1:-}
seconds=${2:-}
if [[ ! "$target" =~ ^(scene|dem)$ || ! "$seconds" =~ ^[0-9]+$ ]]; then
  echo "usage: fuzz/run.sh scene|dem SECONDS [libFuzzer options...]" >&2
  exit 2
fi
shift 2

build=build-fuzz
if [ ! -f "$build/build.ninja" ]; then
  cmake -S . -B "$build" -G Ninja -DFIRN_FUZZ=ON -DFIRN_TESTS=OFF \
        -DCMAKE_CXX_COMPILER=clang++ >/dev/null
fi
nice -n 19 cmake --build "$build" -j1 --target "firn_${target}_fuzz"

work=fuzz/work/$target
mkdir -p "$work/corpus" "$work/artifacts"
log=$work/fuzz-$(date -u +%Y%m%dT%H%M%SZ).log
dict=fuzz/toml.dict
[ "$target" = dem ] && dict=fuzz/dem.dict
options=(-max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -max_len=8192
         -dict="$dict" -artifact_prefix="$work/artifacts/" -print_final_stats=1)
if [ "${FIRN_FUZZ_KEEP_GOING:-0}" = 1 ]; then
  options+=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
fi
seeds=("fuzz/corpus/$target")
[ -d "fuzz/regressions/$target" ] && seeds+=("fuzz/regressions/$target")

# From the checkout's root: scene inputs name DEM files relative to fuzz/ (see scene_fuzz.cc).
echo "fuzzing $target for $seconds s; log: $log"
set +e
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  nice -n 19 "$build/fuzz/firn_${target}_fuzz" "${options[@]}" "$@" \
  "$work/corpus" "${seeds[@]}" >"$log" 2>&1
status=$?
set -e

echo "exit status: $status"
grep -E '^#[0-9]+.*(cov|ft):' "$log" | tail -n 1 || true
grep -E '^stat::|^Done|^INFO: fuzzed for' "$log" || true
echo "corpus: $(find "$work/corpus" -type f | wc -l) files in $work/corpus"
echo "findings (reproducers in $work/artifacts):"
grep -E '^==[0-9]+==ERROR|runtime error:|^SUMMARY|deadly signal|Test unit written to' "$log" \
  | sort | uniq -c || echo "  none"
