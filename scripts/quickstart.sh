#!/usr/bin/env bash
# The quick start's main job: install, build, simulate the built-in office dataset, map it.
#   scripts/quickstart.sh [OUT_DIR]     (default out/quickstart)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/out/quickstart}
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh" "$root/build" -DBUILD_TESTING=OFF
mkdir -p "$out"
"$root/build/examples/hetslam_sim" --out="$out/sim" --seed=1
"$root/build/examples/hetslam_run" --log="$out/sim/log.clf" --truth="$out/sim/truth.txt" --out="$out/slam"
echo "quickstart: map image $out/slam/map.png, trajectory $out/slam/trajectory.txt"
