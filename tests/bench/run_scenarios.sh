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
# Environment:
#   HETSLAM_SEEDS      the simulator seeds to run, separated by spaces or commas
#                      (e.g. HETSLAM_SEEDS="1 2 3 4 5"); default: $HETSLAM_SEED, else 1.
#   HETSLAM_SEED       the single seed used when HETSLAM_SEEDS is unset or empty.
#   HETSLAM_BENCH_OUT  output folder (default: <repo>/out/scenarios).
#   HETSLAM_MIRROR     1: simulate every scenario mirrored (hetslam_sim --mirror: the world, tags,
#                      starts and routes mirrored about the middle of the walls), to see whether a
#                      figure depends on the handedness of the building; default 0.
#
# For each seed, every datasets/scenarios/*.scenario with robot blocks is generated with
# `hetslam_sim --scenario=... --seed=<seed> --noimages` into <out>/<scenario>/ (one seed) or
# <out>/seed-<seed>/<scenario>/ (several seeds), then each robot's log.txt is mapped with
# `hetslam_run --log=<robot>/log.txt --out=<robot>/slam` (default flags: the robot log's
# attitude, command prediction and degenerate-direction handling; see hetslam_run --help).
# One row per seed and robot: scans, the log's duration, wall time of hetslam_run, real-time
# factor, and the error against the simulator's TRUTH (ATE after SE(2) alignment: rmse and max
# translation, rmse rotation) as hetslam_run prints it, then the largest drift from the start
# frame (no alignment: how far the map's frame moved and turned from the robot's start, what a
# team's relative pose between robot frames inherits).
# With several seeds a summary table follows, one row per scenario and robot over the seeds:
# how many runs were scored, the worst ATE rmse and its seed, the mean ATE rmse, the worst
# rotation rmse and its seed, the mean real-time factor, and the worst start-frame drift in
# metres and degrees, and the worst ATE rmse of the front end alone (before loop closure,
# frontend_trajectory.txt: whether the closures helped; - without loop closure) (worst and means
# over the scored runs only; a run that failed shows as fewer scored runs than seeds, and in the
# exit status).
# Exit status: 0 when every robot was mapped and scored for every seed, 1 otherwise, 2 on a
# usage error (including a HETSLAM_SEEDS entry that is not a non-negative integer, or repeated).
set -uo pipefail

usage() { sed -n '2,/^set -uo pipefail/p' "$0" | sed '$d; s/^# \{0,1\}//'; }

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
mirror_flag=()
case "${HETSLAM_MIRROR:-0}" in
  0|"") ;;
  1) mirror_flag=(--mirror) ;;
  *) echo "$(basename "$0"): HETSLAM_MIRROR must be 0 or 1, got '${HETSLAM_MIRROR}'" >&2; exit 2 ;;
esac
out_root=${HETSLAM_BENCH_OUT:-$root/out/scenarios}
seed_list=${HETSLAM_SEEDS:-${HETSLAM_SEED:-1}}
read -r -a seed_words <<<"${seed_list//,/ }"
seeds=()
for seed in "${seed_words[@]}"; do
  if ! [[ $seed =~ ^[0-9]{1,19}$ ]]; then
    echo "run_scenarios.sh: seed '$seed' in HETSLAM_SEEDS/HETSLAM_SEED is not a non-negative integer" >&2
    exit 2
  fi
  for known in "${seeds[@]}"; do
    if [ "$known" = "$seed" ]; then echo "run_scenarios.sh: seed $seed given twice" >&2; exit 2; fi
  done
  seeds+=("$seed")
done
if [ ${#seeds[@]} -eq 0 ]; then
  echo "run_scenarios.sh: HETSLAM_SEEDS/HETSLAM_SEED ('$seed_list') names no seed" >&2
  exit 2
fi
for tool in hetslam_sim hetslam_run; do
  if [ ! -x "$build/examples/$tool" ]; then
    echo "run_scenarios.sh: $build/examples/$tool not found; build it first" >&2
    exit 2
  fi
done

now() { date +%s.%N; }
[ ${#seeds[@]} -gt 1 ] && seed_word=seeds || seed_word=seed
echo "hetslam_run on the simulated scenarios ($seed_word ${seeds[*]}): $(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1), $(nproc) cores"
[ ${#extra[@]} -gt 0 ] && echo "extra hetslam_run flags: ${extra[*]}"
echo
printf '%-22s %-6s %4s %6s %7s %7s %8s  %s\n' scenario robot seed scans data_s wall_s RTF "error vs TRUTH"
status=0
# One line per run for the summary: scenario robot seed ate_rmse_m rotation_rmse_deg rtf (the
# last three "-" when the run was not scored), or "scenario - seed sim" when hetslam_sim failed.
runs=$(mktemp) || exit 1
trap 'rm -f "$runs"' EXIT
for seed in "${seeds[@]}"; do
  seed_root=$out_root
  [ ${#seeds[@]} -gt 1 ] && seed_root=$out_root/seed-$seed
  mkdir -p "$(dirname "$seed_root")"
  for scenario in "$root"/datasets/scenarios/*.scenario; do
    name=$(basename "$scenario" .scenario)
    grep -q '^robot_begin' "$scenario" || continue  # the 2D office loop writes CARMEN, see the quick start
    dir="$seed_root/$name"
    rm -rf "$dir"
    if ! "$build/examples/hetslam_sim" --scenario="$scenario" --out="$dir" --seed="$seed" --noimages "${mirror_flag[@]}" >"$seed_root.$name.sim.log" 2>&1; then
      printf '%-22s %-6s %4s FAILED: hetslam_sim, see %s\n' "$name" "" "$seed" "$seed_root.$name.sim.log"
      echo "$name - $seed sim" >>"$runs"
      status=1
      continue
    fi
    for log in "$dir"/*/log.txt; do
      robot=$(basename "$(dirname "$log")")
      out="$dir/$robot/slam"
      start=$(now)
      if ! "$build/examples/hetslam_run" --log="$log" --out="$out" --progress_every=0 "${extra[@]}" >"$out.log" 2>&1; then
        printf '%-22s %-6s %4s FAILED: hetslam_run, see %s\n' "$name" "$robot" "$seed" "$out.log"
        echo "$name $robot $seed - - - - - -" >>"$runs"
        status=1
        continue
      fi
      end=$(now)
      scans=$(sed -n 's/^scans: \([0-9]*\) processed.*/\1/p' "$out.log")
      duration=$(sed -n 's/.*data duration \([0-9.]*\) s.*/\1/p' "$out.log")
      wall=$(awk -v a="$start" -v b="$end" 'BEGIN {printf "%.2f", b - a}')
      rtf=$(awk -v d="${duration:-0}" -v w="$wall" 'BEGIN {printf "%.1f", (w > 0 ? d / w : 0)}')
      error=$(sed -n 's/.*(TRUTH): [0-9]* poses matched, \(ATE.*\)/\1/p' "$out.log")
      # "ATE rmse 0.113 m (max 0.356 m), rotation rmse 0.98 deg (max ...)"
      ate=$(sed -n 's/^ATE rmse \([0-9.]*\) m.*/\1/p' <<<"$error")
      rotation=$(sed -n 's/.*rotation rmse \([0-9.]*\) deg.*/\1/p' <<<"$error")
      # "drift from the start frame ...: at the end ...; largest 0.228 m (t = 38.2 s), 0.88 deg (t = 39.2 s)"
      drift=$(sed -n 's/^drift from the start frame .*; largest \([0-9.]*\) m (t = [-0-9.]* s), \([0-9.]*\) deg .*/\1 \2/p' "$out.log")
      # "  the front end alone, before loop closure (frontend_trajectory.txt): rmse 0.017 m (max ...": only
      # with loop closure
      frontend=$(sed -n 's/^  the front end alone, before loop closure .*: rmse \([0-9.]*\) m .*/\1/p' "$out.log")
      if [ -z "$error" ] || [ -z "$ate" ] || [ -z "$rotation" ] || [ -z "$drift" ]; then
        error="not scored, see $out.log"
        echo "$name $robot $seed - - - - - -" >>"$runs"
        status=1
      else
        echo "$name $robot $seed $ate $rotation $rtf $drift ${frontend:--}" >>"$runs"
        error="$error; start-frame drift at most $(awk '{print $1 " m, " $2 " deg"}' <<<"$drift")"
        [ -n "$frontend" ] && error="$error; front end alone $frontend m"
      fi
      printf '%-22s %-6s %4s %6s %7s %7s %7sx  %s\n' "$name" "$robot" "$seed" "$scans" "$duration" "$wall" "$rtf" "$error"
    done
  done
done

if [ ${#seeds[@]} -gt 1 ]; then
  echo
  echo "summary over ${#seeds[@]} seeds (worst and mean over the scored runs):"
  printf '%-22s %-6s %6s %11s %5s %10s %13s %5s %8s %13s %15s %17s\n' scenario robot scored worst_ATE_m seed \
    mean_ATE_m worst_rot_deg seed mean_RTF worst_drift_m worst_drift_deg worst_front_end_m
  awk -v num_seeds=${#seeds[@]} '
    $4 == "sim" { not_generated = not_generated " " $1 " (seed " $3 ")"; next }
    {
      key = $1 " " $2
      if (!(key in runs)) { order[++num_keys] = key; scenario[key] = $1; robot[key] = $2 }
      ++runs[key]
      if ($4 == "-") next
      ++scored[key]
      if (scored[key] == 1 || $4 > worst_ate[key]) { worst_ate[key] = $4; worst_ate_seed[key] = $3 }
      if (scored[key] == 1 || $5 > worst_rot[key]) { worst_rot[key] = $5; worst_rot_seed[key] = $3 }
      sum_ate[key] += $4
      sum_rtf[key] += $6
      if (scored[key] == 1 || $7 > worst_drift_m[key]) worst_drift_m[key] = $7
      if (scored[key] == 1 || $8 > worst_drift_deg[key]) worst_drift_deg[key] = $8
      if ($9 != "-" && (!(key in worst_front) || $9 > worst_front[key])) worst_front[key] = $9
    }
    END {
      for (i = 1; i <= num_keys; ++i) {
        key = order[i]
        n = scored[key] + 0
        if (n == 0) {
          printf "%-22s %-6s %6s  no scored run\n", scenario[key], robot[key], "0/" num_seeds
          continue
        }
        printf "%-22s %-6s %6s %11.3f %5s %10.3f %13.2f %5s %7.1fx %13.3f %15.2f %17s\n", scenario[key],
               robot[key], n "/" num_seeds, worst_ate[key], worst_ate_seed[key],
               sum_ate[key] / n, worst_rot[key], worst_rot_seed[key], sum_rtf[key] / n,
               worst_drift_m[key], worst_drift_deg[key], (key in worst_front ? sprintf("%.3f", worst_front[key]) : "-")
      }
      if (not_generated != "") print "hetslam_sim failed for:" not_generated
    }' "$runs"
fi
exit $status
