#!/usr/bin/env bash
# End-to-end benchmark of hetslam_run on the simulator's team scenarios. NOT a ctest test: it
# generates every scenario and maps every robot (a few minutes), so it is run by hand, e.g.
# before quoting figures.
#
#   tests/bench/run_scenarios.sh [BUILD_DIR] [-- extra hetslam_run flags...]
#
#   BUILD_DIR   build folder holding examples/hetslam_sim and examples/hetslam_run
#               (default: <repo>/build).
#   -- ...      everything after `--` is passed to every hetslam_run call
#               (e.g. `-- --nouse_commands --degenerate_ratio=0`).
#
# Every datasets/scenarios/*.scenario with robot blocks is generated with
# `hetslam_sim --scenario=... --seed=${HETSLAM_SEED:-1} --noimages` into
# ${HETSLAM_BENCH_OUT:-<repo>/out/scenarios}/<scenario>/, then each robot's log.txt is mapped
# with `hetslam_run --log=<robot>/log.txt --out=<robot>/slam` (default flags: the robot log's
# attitude, command prediction and degenerate-direction handling; see hetslam_run --help).
# One row per robot: scans, the log's duration, wall time of hetslam_run, real-time factor, and
# the error against the simulator's TRUTH (ATE after SE(2) alignment: rmse and max translation,
# rmse rotation) as hetslam_run prints it.
# Exit status: 0 when every robot was mapped and scored, 1 otherwise, 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^# Exit status/p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
build=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "run_scenarios.sh: unknown option '$1' (hetslam_run flags go after --; see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_scenarios.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
      build=$1 ;;
  esac
  shift
done
build=${build:-$root/build}
out_root=${HETSLAM_BENCH_OUT:-$root/out/scenarios}
seed=${HETSLAM_SEED:-1}
for tool in hetslam_sim hetslam_run; do
  if [ ! -x "$build/examples/$tool" ]; then
    echo "run_scenarios.sh: $build/examples/$tool not found; build it first" >&2
    exit 2
  fi
done

now() { date +%s.%N; }
echo "hetslam_run on the simulated scenarios (seed $seed): $(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1), $(nproc) cores"
[ ${#extra[@]} -gt 0 ] && echo "extra hetslam_run flags: ${extra[*]}"
echo
printf '%-22s %-6s %6s %7s %7s %8s  %s\n' scenario robot scans data_s wall_s RTF "error vs TRUTH"
status=0
for scenario in "$root"/datasets/scenarios/*.scenario; do
  name=$(basename "$scenario" .scenario)
  grep -q '^robot_begin' "$scenario" || continue  # the 2D office loop writes CARMEN, see the quick start
  dir="$out_root/$name"
  rm -rf "$dir"
  if ! "$build/examples/hetslam_sim" --scenario="$scenario" --out="$dir" --seed="$seed" --noimages >"$out_root.$name.sim.log" 2>&1; then
    printf '%-22s FAILED: hetslam_sim, see %s\n' "$name" "$out_root.$name.sim.log"
    status=1
    continue
  fi
  for log in "$dir"/*/log.txt; do
    robot=$(basename "$(dirname "$log")")
    out="$dir/$robot/slam"
    start=$(now)
    if ! "$build/examples/hetslam_run" --log="$log" --out="$out" --progress_every=0 "${extra[@]}" >"$out.log" 2>&1; then
      printf '%-22s %-6s FAILED: hetslam_run, see %s\n' "$name" "$robot" "$out.log"
      status=1
      continue
    fi
    end=$(now)
    scans=$(sed -n 's/^scans: \([0-9]*\) processed.*/\1/p' "$out.log")
    duration=$(sed -n 's/.*data duration \([0-9.]*\) s.*/\1/p' "$out.log")
    wall=$(awk -v a="$start" -v b="$end" 'BEGIN {printf "%.2f", b - a}')
    rtf=$(awk -v d="${duration:-0}" -v w="$wall" 'BEGIN {printf "%.1f", (w > 0 ? d / w : 0)}')
    error=$(sed -n 's/.*(TRUTH): [0-9]* poses matched, \(ATE.*\)/\1/p' "$out.log")
    if [ -z "$error" ]; then
      error="not scored, see $out.log"
      status=1
    fi
    printf '%-22s %-6s %6s %7s %7s %7sx  %s\n' "$name" "$robot" "$scans" "$duration" "$wall" "$rtf" "$error"
  done
done
exit $status
