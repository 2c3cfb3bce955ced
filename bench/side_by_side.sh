#!/bin/bash
# Issue 50's table: two builds of Firn, each with its own shipped scenes, alternating scene by
# scene, two rounds, whole process (/usr/bin/time), 2 threads; then firn_bench of each.
#
#   bench/side_by_side.sh OLD_CHECKOUT NEW_CHECKOUT OUT_DIR
#
# Each checkout holds a Release build in build/ (an old one: git worktree add DIR 1e8d767, then
# cmake -S DIR -B DIR/build -G Ninja -DCMAKE_BUILD_TYPE=Release && cmake --build DIR/build
# --target firn firn_bench). Writes OUT_DIR/times.txt (scene, build, round, wall seconds; the
# bench's result lines) and each run's output folder, whose summary.json has the steps and
# bytes_per_particle. Particle-steps per second: steps x particles / wall. docs/performance.md.
set -euo pipefail
old=$(cd "$1" && pwd) new=$(cd "$2" && pwd) out=$3
mkdir -p "$out"
declare -A end=([slope2d]=0.5 [pst3d]=0.1 [slope3d]=0.1 [path3d]=20)
for round in A B; do
  for scene in slope2d pst3d slope3d path3d; do
    for build in old new; do
      dir=${!build}
      rm -rf "$out/$scene-$build-$round"
      /usr/bin/time -f "$scene $build $round %e" -a -o "$out/times.txt" \
        "$dir/build/firn" run "$dir/scenes/$scene.toml" --threads 2 --quiet \
        --out "$out/$scene-$build-$round" --set simulation.end_time=${end[$scene]} > /dev/null
    done
  done
  for build in old new; do
    dir=${!build}
    for model in elastic snow; do
      echo "bench $build $round $model $("$dir/build/firn_bench" --steps 30 --threads 2 \
        --model $model 2>&1 | grep result)" >> "$out/times.txt"
    done
  done
done
