#!/usr/bin/env bash
# How far the real logs' accuracy figures move when nothing but the scan-match refinement's
# stopping rule changes. NOT a ctest test: it maps every log ten times (about 2.5 minutes on
# two cores), so it is run by hand, e.g. before a change that alters results is judged on one
# run of each log.
#
#   tests/bench/run_sensitivity.sh [--logs=NAME,...] [BUILD_DIR] [-- extra hetslam_run flags...]
#
#   BUILD_DIR   build folder holding examples/hetslam_run, hetslam_eval, hetslam_compare
#               (default: <repo>/build).
#   --logs=...  a comma-separated subset of intel, fr079, aces, mit-csail (default: all four;
#               aces alone takes ~15 s).
#   -- ...      everything after `--` is passed to every hetslam_run call (a change under test;
#               the variants below are added after it).
#
# Why: the simulated scenarios are judged on seeds 1-5; a real log has no seed, and a single
# run of it is one draw. The refinement's stopping rule (--refine_max_iterations, default 20,
# and --refine_function_tolerance, default 1e-6) moves a match by well under a millimetre,
# differences of the size a different compiler, CPU or Ceres version can bring; the discrete
# decisions downstream (a loop closure accepted or not, the position along a featureless
# corridor) turn that into the spread this script measures.
#
# Variants (one hetslam_run each, every log): the default; --refine_max_iterations=15, 18,
# 25, 30; --refine_function_tolerance=1e-7, 3e-6, 1e-5, 3e-5, 1e-4.
#
# Logs: intel, fr079, aces, mit-csail (<name>/<name>.clf) in ${HETSLAM_DATA_DIR:-<repo>/../shared/datasets};
# a missing log is reported and skipped. Outputs go to ${HETSLAM_BENCH_OUT:-<repo>/out/sensitivity}/<name>/<variant>/
# (hetslam_run's outputs, run.log, eval.txt). Up to ${HETSLAM_JOBS:-2} runs at a time.
#
# Figures: intel, the ground-truth relations (hetslam_eval --clock_offset=976052857.337284
# --match_tolerance=0.006, mean translation error m); fr079, its relations at the approximate
# offset 1211.41 s (±0.1175 s); aces and mit-csail, the ATE rmse m against GMapping's
# trajectory (a reference, not ground truth). As in tests/bench/run_real_logs.sh.
#
# Output: one row per log and variant, then per log the default's figure, the minimum, median
# and maximum over the variants, and how many variants are more than twice the median ("far").
# Exit status: 0 when every run found was scored, 1 otherwise, 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^# Exit status/p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
build=""
extra=()
logs=(intel fr079 aces mit-csail)
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --logs=*)
      IFS=, read -r -a logs <<<"${1#--logs=}"
      for name in "${logs[@]}"; do
        case $name in
          intel | fr079 | aces | mit-csail) ;;
          *) echo "run_sensitivity.sh: unknown log '$name' in $1 (intel, fr079, aces, mit-csail)" >&2; exit 2 ;;
        esac
      done
      [ ${#logs[@]} -gt 0 ] || { echo "run_sensitivity.sh: --logs names no log" >&2; exit 2; } ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "run_sensitivity.sh: unknown option '$1' (hetslam_run flags go after --; see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_sensitivity.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
      build=$1 ;;
  esac
  shift
done
build=${build:-$root/build}
data=${HETSLAM_DATA_DIR:-$root/../shared/datasets}
out_root=${HETSLAM_BENCH_OUT:-$root/out/sensitivity}
jobs=${HETSLAM_JOBS:-2}
if ! [[ $jobs =~ ^[1-9][0-9]{0,2}$ ]]; then
  echo "run_sensitivity.sh: HETSLAM_JOBS ('$jobs') must be a positive integer" >&2
  exit 2
fi
for tool in hetslam_run hetslam_eval hetslam_compare; do
  if [ ! -x "$build/examples/$tool" ]; then
    echo "run_sensitivity.sh: $build/examples/$tool not found; build it first (cmake --build $build --target $tool)" >&2
    exit 2
  fi
done
if [ ! -d "$data" ]; then
  echo "run_sensitivity.sh: dataset folder '$data' not found (set HETSLAM_DATA_DIR)" >&2
  exit 2
fi

variants=(default
  refine_max_iterations=15 refine_max_iterations=18 refine_max_iterations=25 refine_max_iterations=30
  refine_function_tolerance=1e-7 refine_function_tolerance=3e-6 refine_function_tolerance=1e-5
  refine_function_tolerance=3e-5 refine_function_tolerance=1e-4)

echo "hetslam_run's sensitivity to the refinement's stopping rule: $(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1), $(nproc) cores"
echo "build: $build"
echo "data:  $data"
echo "out:   $out_root"
[ ${#extra[@]} -gt 0 ] && echo "extra hetslam_run flags: ${extra[*]}"
echo

# One run: maps <log> with <variant> and writes its figure (or FAILED ...) to <out>/figure.txt.
run_one() {
  local name=$1 variant=$2 out=$3
  local clf="$data/$name/$name.clf"
  local flags=("${extra[@]}")
  [ "$variant" != default ] && flags+=("--$variant")
  mkdir -p "$out"
  if ! "$build/examples/hetslam_run" --log="$clf" --out="$out" --progress_every=0 "${flags[@]}" >"$out/run.log" 2>&1; then
    echo "FAILED: hetslam_run, see $out/run.log" >"$out/figure.txt"
    return
  fi
  local figure=""
  case $name in
    intel | fr079)
      local offset=976052857.337284 tolerance=0.006
      [ "$name" = fr079 ] && offset=1211.41 tolerance=0.1175
      "$build/examples/hetslam_eval" --trajectory="$out/trajectory.txt" --relations="$data/$name/$name.relations" \
        --clock_offset=$offset --match_tolerance=$tolerance >"$out/eval.txt" 2>&1 &&
        figure=$(sed -n 's/^ *translation error: *\([0-9.]*\) +- .*/\1/p' "$out/eval.txt") ;;
    *)
      "$build/examples/hetslam_compare" --trajectory="$out/trajectory.txt" --reference="$data/$name/$name.gmapping.txt" \
        --match_tolerance=0.001 --rpe_gap=10 >"$out/eval.txt" 2>&1 &&
        figure=$(sed -n 's/^ATE after SE(2) alignment.*translation rmse \([0-9.]*\) m.*/\1/p' "$out/eval.txt") ;;
  esac
  if [ -n "$figure" ]; then echo "$figure" >"$out/figure.txt"; else echo "FAILED: not scored, see $out/eval.txt" >"$out/figure.txt"; fi
}

present=()
for name in "${logs[@]}"; do
  if [ -f "$data/$name/$name.clf" ]; then present+=("$name"); else echo "$name: skipped, $data/$name/$name.clf not found"; fi
done

running=0
for name in "${present[@]}"; do
  for variant in "${variants[@]}"; do
    out="$out_root/$name/${variant//=/_}"
    rm -f "$out/figure.txt"
    echo "== $name ${variant}" >&2
    run_one "$name" "$variant" "$out" &
    running=$((running + 1))
    if [ $running -ge "$jobs" ]; then wait -n; running=$((running - 1)); fi
  done
done
wait

status=0
metric_of() { case $1 in intel) echo "relations m" ;; fr079) echo "relations (approx.) m" ;; *) echo "ATE vs GMapping m" ;; esac; }
printf '%-10s %-32s %s\n' log variant figure
for name in "${present[@]}"; do
  for variant in "${variants[@]}"; do
    printf '%-10s %-32s %s\n' "$name" "$variant" "$(cat "$out_root/$name/${variant//=/_}/figure.txt" 2>/dev/null || echo 'FAILED: no figure')"
  done
done
echo
printf '%-10s %-22s %8s %8s %8s %8s %s\n' log figure default min median max "far (> 2x median)"
for name in "${present[@]}"; do
  figures=()
  default=""
  for variant in "${variants[@]}"; do
    f=$(cat "$out_root/$name/${variant//=/_}/figure.txt" 2>/dev/null)
    if ! [[ $f =~ ^[0-9.]+$ ]]; then status=1; continue; fi
    figures+=("$f")
    [ "$variant" = default ] && default=$f
  done
  if [ ${#figures[@]} -eq 0 ]; then
    printf '%-10s %s\n' "$name" "no run scored"
    continue
  fi
  printf '%s\n' "${figures[@]}" | sort -g | awk -v name="$name" -v metric="$(metric_of "$name")" -v def="${default:--}" '
    { v[NR] = $1 }
    END {
      n = NR; median = (n % 2) ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
      far = 0; for (i = 1; i <= n; ++i) if (v[i] > 2 * median) ++far
      printf "%-10s %-22s %8s %8.4f %8.4f %8.4f %d of %d\n", name, metric, def, v[1], median, v[n], far, n
    }'
done
exit $status
