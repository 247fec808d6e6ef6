#!/usr/bin/env bash
# End-to-end benchmark of hetslam_run on the shared real logs. NOT a ctest test: it maps every
# log in full (minutes), so it is run by hand, e.g. before quoting figures.
#
#   tests/bench/run_real_logs.sh [--quick] [BUILD_DIR] [-- extra hetslam_run flags...]
#
#   BUILD_DIR   build folder holding examples/hetslam_run, hetslam_eval, hetslam_compare
#               (default: <repo>/build).
#   --quick     intel only.
#   -- ...      everything after `--` is passed to every hetslam_run call
#               (e.g. `-- --use_odometry --linear_window=0.8`).
#
# Logs: intel, fr079, aces, mit-csail (<name>/<name>.clf) in ${HETSLAM_DATA_DIR:-<repo>/../shared/datasets};
# a missing log is reported and skipped. Outputs go to ${HETSLAM_BENCH_OUT:-<repo>/out/bench}/<name>/:
# hetslam_run's map and trajectory, run.log (its stdout and stderr), time.txt (/usr/bin/time -v),
# and eval.txt / compare.txt (the accuracy tools' full output).
#
# One table row per log:
#   scans      scans processed by hetslam_run
#   data s     time span of the log's scans
#   wall s     wall time of the whole hetslam_run process (read log, map, write outputs), one thread
#   RTF        real-time factor = data s / wall s
#   RSS MiB    peak resident memory of the process (/usr/bin/time -v; else VmHWM polled from /proc)
#   fails      scans whose match failed (hetslam_run inserts them at the prediction)
#   loops      loop closures accepted ("-" when hetslam_run prints none, e.g. --no_loop_closure)
#   accuracy   intel: the ground-truth relations metric (Kümmerle et al. 2009) via hetslam_eval
#              --clock_offset=976052857.337284 --match_tolerance=0.006 (scored relations: both ends matched, neither
#              ambiguous, see core/relations.h; then again with exact association through the
#              log's readings, --readings_log; mean ± sample
#              std of translation m and rotation deg). Every log with a <name>.gmapping.txt: AGREEMENT
#              with GMapping's trajectory via hetslam_compare (a reference, NOT ground truth): ATE rmse
#              after SE(2) alignment and the relative pose error over 10 s, mean ± std.
#              fr079 also gets its relations at the approximate offset 1211.41 s with nearest-scan
#              association (±0.1175 s): timing adds a few cm (see the datasets README).
# Exit status: 0 when every log found ran and was scored, 1 otherwise, 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^# Exit status/p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
quick=0
build=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    -h|--help) usage; exit 0 ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "run_real_logs.sh: unknown option '$1' (hetslam_run flags go after --; see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_real_logs.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
      build=$1 ;;
  esac
  shift
done
build=${build:-$root/build}
data=${HETSLAM_DATA_DIR:-$root/../shared/datasets}
out_root=${HETSLAM_BENCH_OUT:-$root/out/bench}

for tool in hetslam_run hetslam_eval hetslam_compare; do
  if [ ! -x "$build/examples/$tool" ]; then
    echo "run_real_logs.sh: $build/examples/$tool not found; build it first (cmake --build $build --target $tool)" >&2
    exit 2
  fi
done
if [ ! -d "$data" ]; then
  echo "run_real_logs.sh: dataset folder '$data' not found (set HETSLAM_DATA_DIR)" >&2
  exit 2
fi

logs=(intel fr079 aces mit-csail)
[ "$quick" -eq 1 ] && logs=(intel)

# now, run_timed (peak RSS and CPU time of one run).
source "$root/tests/bench/timed_run.sh"

echo "hetslam_run on the shared logs: $(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1), $(nproc) cores"
echo "build: $build"
echo "data:  $data"
echo "out:   $out_root"
[ ${#extra[@]} -gt 0 ] && echo "extra hetslam_run flags: ${extra[*]}"
echo

rows=()
status=0
for name in "${logs[@]}"; do
  clf="$data/$name/$name.clf"
  if [ ! -f "$clf" ]; then
    rows+=("$(printf '%-10s %s' "$name" "skipped: $clf not found")")
    continue
  fi
  out="$out_root/$name"
  mkdir -p "$out"
  echo "== $name: hetslam_run --log=$clf --out=$out ${extra[*]:-}" >&2
  start=$(now)
  run_timed "$out/time.txt" "$build/examples/hetslam_run" --log="$clf" --out="$out" --progress_every=0 \
    "${extra[@]}" >"$out/run.log" 2>&1
  rc=$?
  end=$(now)
  if [ $rc -ne 0 ]; then
    rows+=("$(printf '%-10s %s' "$name" "FAILED: hetslam_run exit $rc, see $out/run.log")")
    status=1
    continue
  fi
  scans=$(sed -n 's/^scans: \([0-9]*\) processed.*/\1/p' "$out/run.log")
  duration=$(sed -n 's/.*data duration \([0-9.]*\) s.*/\1/p' "$out/run.log")
  failures=$(sed -n 's/.* \([0-9]*\) match failures.*/\1/p' "$out/run.log" | head -1)
  loops=$(sed -n 's/.* \([0-9]*\) loop closures accepted.*/\1/p' "$out/run.log")
  rss_kib=$(awk '$1 == "peak_rss_kib" {print $2}' "$out/time.txt")
  wall=$(awk -v a="$start" -v b="$end" 'BEGIN {printf "%.2f", b - a}')
  rtf=$(awk -v d="$duration" -v w="$wall" 'BEGIN {printf "%.1f", (w > 0 ? d / w : 0)}')
  rss_mib=$(awk -v k="$rss_kib" 'BEGIN {printf "%.0f", k / 1024}')

  accuracy=""
  : >"$out/eval.txt"
  if [ -f "$data/$name/$name.relations" ] && { [ "$name" = intel ] || [ "$name" = fr079 ]; }; then
    if [ "$name" = intel ]; then
      offset=976052857.337284 tolerance=0.006 label="relations (ground truth)"
    else
      offset=1211.41 tolerance=0.1175 label="relations at approx. offset 1211.41 s, nearest scan ±0.1175 s"
    fi
    if "$build/examples/hetslam_eval" --trajectory="$out/trajectory.txt" --relations="$data/$name/$name.relations" \
         --clock_offset=$offset --match_tolerance=$tolerance >"$out/eval.txt" 2>&1; then
      matched=$(sed -n 's/^matched: \([0-9]*\) \/ \([0-9]*\) relations.*/\1\/\2/p' "$out/eval.txt")
      trans=$(sed -n 's/^ *translation error: *\([0-9.]*\) +- \([0-9.]*\) m.*/\1 ± \2 m/p' "$out/eval.txt")
      rot=$(sed -n 's/^ *rotation error: *\([0-9.]*\) +- \([0-9.]*\) deg.*/\1 ± \2°/p' "$out/eval.txt")
      accuracy="$label: $matched matched, $trans, $rot"
      if [ "$name" = intel ]; then
        # Exact association through the log's readings (its ODOM lines), see core/relations.h.
        if "$build/examples/hetslam_eval" --trajectory="$out/trajectory.txt" --relations="$data/$name/$name.relations" \
             --clock_offset=$offset --match_tolerance=$tolerance --readings_log="$data/$name/$name.clf" \
             >"$out/eval_exact.txt" 2>&1; then
          matched=$(sed -n 's/^matched: \([0-9]*\) \/ \([0-9]*\) relations.*/\1\/\2/p' "$out/eval_exact.txt")
          trans=$(sed -n 's/^ *translation error: *\([0-9.]*\) +- \([0-9.]*\) m.*/\1 ± \2 m/p' "$out/eval_exact.txt")
          rot=$(sed -n 's/^ *rotation error: *\([0-9.]*\) +- \([0-9.]*\) deg.*/\1 ± \2°/p' "$out/eval_exact.txt")
          accuracy="$accuracy; exact association through the readings: $matched matched, $trans, $rot"
        else
          accuracy="$accuracy; exact association: hetslam_eval FAILED, see $out/eval_exact.txt"
          status=1
        fi
      fi
    else
      accuracy="$label: hetslam_eval FAILED, see $out/eval.txt"
      status=1
    fi
  fi
  ref="$data/$name/$name.gmapping.txt"
  : >"$out/compare.txt"
  if [ -f "$ref" ]; then
    if "$build/examples/hetslam_compare" --trajectory="$out/trajectory.txt" --reference="$ref" \
         --match_tolerance=0.001 --rpe_gap=10 >"$out/compare.txt" 2>&1; then
      ate=$(sed -n 's/^ATE after SE(2) alignment.*translation rmse \([0-9.]*\) m.*rotation rmse \([0-9.]*\) deg.*/ATE rmse \1 m \/ \2°/p' \
        "$out/compare.txt")
      rpe=$(sed -n 's/^RPE over >= 10 s ([0-9]* pairs): translation \([0-9.]*\) +- \([0-9.]*\) m.*rotation \([0-9.]*\) +- \([0-9.]*\) deg.*/RPE(10 s) \1 ± \2 m, \3 ± \4°/p' \
        "$out/compare.txt")
      agreement="agreement with GMapping (not ground truth): $ate, $rpe"
    else
      agreement="hetslam_compare FAILED, see $out/compare.txt"
      status=1
    fi
    accuracy=${accuracy:+$accuracy; }$agreement
  fi
  rows+=("$(printf '%-10s %6s %9s %8s %7s %8s %5s %5s  %s' "$name" "$scans" "$duration" "$wall" "${rtf}x" "$rss_mib" \
    "$failures" "${loops:--}" "$accuracy")")
done

echo
printf '%-10s %6s %9s %8s %7s %8s %5s %5s  %s\n' log scans "data s" "wall s" RTF "RSS MiB" fails loops accuracy
for row in "${rows[@]}"; do echo "$row"; done
echo
echo "fails = scans whose match failed (inserted at the prediction); loops = loop closures accepted (- without"
echo "the loop-closing pipeline). Full outputs: $out_root/<log>/"
exit $status
