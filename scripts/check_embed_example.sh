#!/usr/bin/env bash
# Installs the hetslam build in BUILD_DIR to a temporary prefix, then configures, builds and runs
# the stand-alone projects against that installed package (find_package(hetslam)):
#   examples/embed_factors   hetslam::factors in an estimator of its own (a known answer);
#   examples/embed_pipeline  hetslam::frontends, the whole single-robot pipeline on the simulated
#                            office loop (written by BUILD_DIR's hetslam_sim), scored against its
#                            truth.
# Fails if any step fails or an example misses its answer.
#   scripts/check_embed_example.sh BUILD_DIR
set -euo pipefail
if [ $# -ne 1 ]; then
  echo "usage: $0 BUILD_DIR   (a configured hetslam build folder)" >&2
  exit 2
fi
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
if [ ! -f "$build/CMakeCache.txt" ]; then
  echo "$0: $build is not a configured CMake build folder" >&2
  exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cmake --build "$build" -j2 --target hetslam_core hetslam_factors hetslam_frontends hetslam_sim_program
cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log" || { cat "$tmp/install.log"; exit 1; }
for f in include/hetslam/factors/relative_pose_cost.h include/hetslam/core/se2.h \
         include/hetslam/frontends/online_estimator.h \
         lib/cmake/hetslam/hetslamConfig.cmake lib/cmake/hetslam/hetslamConfigVersion.cmake; do
  # GNUInstallDirs may pick lib64 on some systems.
  if [ ! -f "$tmp/prefix/$f" ] && [ ! -f "$tmp/prefix/${f/lib\//lib64/}" ]; then
    echo "$0: the install is missing $f" >&2
    exit 1
  fi
done
cmake -S "$root/examples/embed_factors" -B "$tmp/build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" > "$tmp/configure.log" || { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/build" -j2
"$tmp/build/embed_factors"
cmake -S "$root/examples/embed_pipeline" -B "$tmp/build-pipeline" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" > "$tmp/configure-pipeline.log" || { cat "$tmp/configure-pipeline.log"; exit 1; }
cmake --build "$tmp/build-pipeline" -j2
"$build/examples/hetslam_sim" --out="$tmp/office" --seed=1 > /dev/null
# Office loop, seed 1: ATE 0.028 m with hetslam_run (README, quick start); 0.15 m fails only on a
# broken pipeline.
"$tmp/build-pipeline/embed_pipeline" "$tmp/office/log.clf" "$tmp/office/truth.txt" 0.15
