#!/usr/bin/env bash
# Scores the map layers of every robot that tests/bench/run_scenarios.sh mapped, against the
# simulator's true layers. NOT a ctest test: run it after run_scenarios.sh, on its output.
#
#   tests/bench/run_layers.sh [BUILD_DIR]
#
#   BUILD_DIR   build folder holding examples/hetslam_layers (default: <repo>/build).
#
# Environment:
#   HETSLAM_BENCH_OUT  run_scenarios.sh's output folder (default: <repo>/out/scenarios), with
#                      one dataset per scenario (<out>/<scenario>/, one seed) or per seed and
#                      scenario (<out>/seed-<seed>/<scenario>/).
#
# For every dataset holding truth_layers/ and every robot of it with a slam/ run folder,
# `hetslam_layers --run_dir=<robot>/slam --truth_layers=<dataset>/truth_layers
# --truth=<robot>/log.txt --seen_layers=<robot>/seen_layers --out_csv=<robot>/slam/layers.csv`
# (cell precision and recall within one cell after the trajectory's ATE alignment; see
# hetslam_layers --help). One row per seed and robot:
#   map_P map_R   map.pgm against walls + furniture: precision, recall
#   walls_P       walls.pgm against walls: precision
#   fo_P fo_R     floor_obstacles.pgm against floor_obstacles: precision, recall
#   fo_seenR      floor_obstacles.pgm: recall of the obstacle cells the robot's laser returned from
#   fo_in_map     map.pgm's cells on a true floor obstacle (not next to walls or furniture): the
#                 localisation map should hold none (the summary gives the largest)
# ("-" where the run has no such layer or the truth no such cell). Then one row per scenario and
# robot over the seeds: worst and mean of each column.
# Exit status: 0 when every robot was scored, 1 otherwise, 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^set -uo pipefail/p' "$0" | sed '$d; s/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
build=""
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    -*) echo "run_layers.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_layers.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
      build=$1 ;;
  esac
  shift
done
build=${build:-$root/build}
out_root=${HETSLAM_BENCH_OUT:-$root/out/scenarios}
if [ ! -x "$build/examples/hetslam_layers" ]; then
  echo "run_layers.sh: $build/examples/hetslam_layers not found; build it first" >&2
  exit 2
fi
if [ ! -d "$out_root" ]; then
  echo "run_layers.sh: '$out_root' does not exist: run tests/bench/run_scenarios.sh first" >&2
  exit 2
fi

status=0
rows=$(mktemp) || exit 1
trap 'rm -f "$rows"' EXIT
printf '%-22s %-6s %4s %7s %7s %7s %7s %7s %8s %9s\n' scenario robot seed map_P map_R walls_P fo_P fo_R fo_seenR fo_in_map
# The CSV's value of a layer's column (precision 4, recall 5, seen_recall 11), "-" when empty or nan.
value() { awk -F, -v layer="$2" -v column="$3" '$1 == layer && $3 == "scored" { v = $column } END {
  if (v == "" || v == "nan") print "-"; else printf "%.3f", v }' "$1"; }
while IFS= read -r truth; do
  dataset=$(dirname "$truth")
  name=$(basename "$dataset")
  seed=1
  [[ $(basename "$(dirname "$dataset")") =~ ^seed-([0-9]+)$ ]] && seed=${BASH_REMATCH[1]}
  for slam in "$dataset"/*/slam; do
    [ -d "$slam" ] || continue
    robot_dir=$(dirname "$slam")
    robot=$(basename "$robot_dir")
    seen=()
    [ -d "$robot_dir/seen_layers" ] && seen=(--seen_layers="$robot_dir/seen_layers")
    if ! "$build/examples/hetslam_layers" --run_dir="$slam" --truth_layers="$truth" --truth="$robot_dir/log.txt" \
        "${seen[@]}" --out_csv="$slam/layers.csv" >"$slam/layers.log" 2>&1; then
      printf '%-22s %-6s %4s FAILED: hetslam_layers, see %s\n' "$name" "$robot" "$seed" "$slam/layers.log"
      status=1
      continue
    fi
    csv=$slam/layers.csv
    in_map=$(awk -F, '$1 == "map_on_floor_obstacles" { v = $7 } END { print (v == "" ? "-" : v) }' "$csv")
    row="$(value "$csv" map 4) $(value "$csv" map 5) $(value "$csv" walls 4) $(value "$csv" floor_obstacles 4) $(value "$csv" floor_obstacles 5) $(value "$csv" floor_obstacles 11) $in_map"
    echo "$name $robot $seed $row" >>"$rows"
    # shellcheck disable=SC2086
    printf '%-22s %-6s %4s %7s %7s %7s %7s %7s %8s %9s\n' "$name" "$robot" "$seed" $row
  done
done < <(find "$out_root" -type d -name truth_layers | sort)

if [ ! -s "$rows" ]; then
  echo "run_layers.sh: no scored run under '$out_root'" >&2
  exit 1
fi
echo
echo "over the seeds: worst / mean of each column"
printf '%-22s %-6s %5s %13s %13s %13s %13s %13s %13s %9s\n' scenario robot runs map_P map_R walls_P fo_P fo_R fo_seenR fo_in_map
sort -k1,1 -k2,2 -k3,3n "$rows" | awk '
  { key = $1 " " $2; if (!(key in runs)) order[++n] = key; runs[key]++
    for (c = 4; c <= 9; ++c) if ($c != "-") {
      if (!((key, c) in worst) || $c < worst[key, c]) worst[key, c] = $c
      sum[key, c] += $c; count[key, c]++ }
    if ($10 != "-" && (!(key in most) || $10 + 0 > most[key])) most[key] = $10 + 0 }
  END { for (i = 1; i <= n; ++i) { key = order[i]; split(key, k, " ")
      line = sprintf("%-22s %-6s %5d", k[1], k[2], runs[key])
      for (c = 4; c <= 9; ++c) {
        cell = "-"
        if ((key, c) in worst) cell = sprintf("%.3f / %.3f", worst[key, c], sum[key, c] / count[key, c])
        line = line sprintf(" %13s", cell)
      }
      print line sprintf(" %9s", (key in most) ? most[key] : "-") } }'
exit $status
