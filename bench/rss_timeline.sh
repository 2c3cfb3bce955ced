#!/bin/bash
# Resident memory of a command over time: where a run's peak comes from (settling, the run's
# grids, a frame write, a checkpoint), beside summary.json's peak_rss_bytes.
#
#   bench/rss_timeline.sh OUT COMMAND [ARGS...]
#
# Runs COMMAND (its output to OUT.log) and writes OUT: one line per sample, milliseconds since
# the start and VmRSS in kB, every 20 ms. A peak shorter than that can fall between samples:
# summary.json's peak_rss_bytes is the exact maximum. docs/performance.md, bench/README.md.
set -euo pipefail
out=$1
shift
"$@" > "$out.log" 2>&1 &
pid=$!
start=$(date +%s%N)
: > "$out"
while kill -0 "$pid" 2> /dev/null; do
  rss=$(awk '/^VmRSS/ {print $2}' "/proc/$pid/status" 2> /dev/null || true)
  [ -n "$rss" ] && echo "$((($(date +%s%N) - start) / 1000000)) $rss" >> "$out"
  sleep 0.02
done
wait "$pid"
