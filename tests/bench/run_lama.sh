#!/usr/bin/env bash
# LaMa (iris_lama's lama::Slam2D: likelihood-field Gauss–Newton scan-to-map matching, with the
# log's odometry, no loop closure) on the shared real logs, for the side-by-side table with
# run_real_logs.sh (issue #15). NOT a ctest test: run by hand. It fetches nothing and never builds
# LaMa itself: it runs only when an install of iris_lama is present, and otherwise exits 0 saying so.
#
#   tests/bench/run_lama.sh [--lama PREFIX] [--driver-build DIR] [--quick] [BUILD_DIR] [-- lama_carmen flags...]
#
#   --lama PREFIX  install prefix of iris_lama (the benchmark uses 1.3.1, BSD licence): the folder
#                  holding lib/iris_lama/cmake/iris_lamaConfig.cmake (default: ${LAMA_PREFIX}).
#                  The project ships no script or recipe for building LaMa: any CMake Release
#                  install of iris_lama 1.3.1 will do (it needs Eigen 3.3+, Debian's libeigen3-dev).
#   BUILD_DIR      hetslam build folder holding examples/hetslam_compare (default: <repo>/build).
#   --driver-build DIR  where tests/bench/lama (the lama_carmen driver, our code) is configured
#                  and built, in Release (default: BUILD_DIR/lama).
#   --quick        intel only.
#   -- ...         everything after `--` is passed to every lama_carmen call
#                  (e.g. `-- --max_range_meters=0`; see `lama_carmen --help`).
#
# Settings (lama_carmen's defaults): distance cut-off (Slam2D l2_max) 3.0 m as in
# shared/BENCHMARKS.md; LaMa's ROS node defaults otherwise: readings beyond 16 m dropped, an
# update after 0.01 m or 0.25 rad of odometry motion, 0.05 m cells, Gauss–Newton, at most 100
# iterations; the first scan's pose is the map origin. Every scan gets a pose (a scan below the
# motion thresholds: LaMa's odometry prediction). LaMa is sensitive to these settings on some logs
# (README, Performance: "LaMa side by side").
#
# Logs: intel, fr079, aces, mit-csail (<name>/<name>.clf) in ${HETSLAM_DATA_DIR:-<repo>/../shared/datasets};
# a missing log is reported and skipped. Outputs go to ${HETSLAM_BENCH_OUT:-<repo>/out/bench}/lama/<name>/:
# trajectory.txt, run.log (lama_carmen's stdout and stderr), time.txt (/usr/bin/time -v) and
# compare.txt (hetslam_compare's full output).
#
# One table row per log:
#   scans      scans in the log (each gets a pose)
#   updates    scans LaMa matched and inserted (the others were below its motion thresholds or empty)
#   data s     time span of the log's scans
#   wall s     wall time of the whole lama_carmen process (read log, map, write trajectory), one thread
#   RTF        real-time factor = data s / wall s
#   CPU s      user + system CPU time of the process (less sensitive than wall s to a shared machine)
#   RSS MiB    peak resident memory of the process (/usr/bin/time -v; else VmHWM polled from /proc)
#   ATE        agreement with GMapping's trajectory (<name>.gmapping.txt, a reference, NOT ground
#              truth) via hetslam_compare --match_tolerance=0.001: ATE rmse after SE(2) alignment,
#              translation m / rotation deg
# Then each log's time per stage as lama_carmen reports it (matching and map update from LaMa's
# own timers).
# Exit status: 0 when every log found ran and was scored, or when no LaMa install is present;
# 1 when a run or a score failed (or the driver did not build); 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^# Exit status/p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
quick=0
build=""
lama_prefix=${LAMA_PREFIX:-}
driver_build=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    -h|--help) usage; exit 0 ;;
    --lama|--driver-build)
      if [ $# -lt 2 ] || [ -z "$2" ]; then echo "run_lama.sh: $1 needs a folder (see --help)" >&2; exit 2; fi
      if [ "$1" = --lama ]; then lama_prefix=$2; else driver_build=$2; fi
      shift ;;
    --lama=*) lama_prefix=${1#--lama=} ;;
    --driver-build=*) driver_build=${1#--driver-build=} ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "run_lama.sh: unknown option '$1' (lama_carmen flags go after --; see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_lama.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
      build=$1 ;;
  esac
  shift
done
build=${build:-$root/build}
driver_build=${driver_build:-$build/lama}
data=${HETSLAM_DATA_DIR:-$root/../shared/datasets}
out_root=${HETSLAM_BENCH_OUT:-$root/out/bench}/lama

# LaMa present? Its CMake package config, under lib/ or lib64/ (or a multiarch lib/ folder).
lama_config=""
if [ -n "$lama_prefix" ]; then
  for candidate in "$lama_prefix"/lib/iris_lama/cmake "$lama_prefix"/lib64/iris_lama/cmake \
                   "$lama_prefix"/lib/*/iris_lama/cmake; do
    if [ -f "$candidate/iris_lamaConfig.cmake" ]; then lama_config=$candidate; break; fi
  done
fi
if [ -z "$lama_config" ]; then
  if [ -n "$lama_prefix" ]; then
    echo "run_lama.sh: LaMa not found under '$lama_prefix' (no lib/iris_lama/cmake/iris_lamaConfig.cmake)."
  fi
  echo "LaMa not found (set LAMA_PREFIX or --lama; see the header, or --help, for the build it needs): nothing run."
  exit 0
fi
lama_version=$(sed -n 's/^set(PACKAGE_VERSION "\(.*\)")$/\1/p' "$lama_config/iris_lamaConfigVersion.cmake" 2>/dev/null)

compare="$build/examples/hetslam_compare"
if [ ! -x "$compare" ]; then
  echo "run_lama.sh: $compare not found; build it first (cmake --build $build --target hetslam_compare)" >&2
  exit 2
fi
if [ ! -d "$data" ]; then
  echo "run_lama.sh: dataset folder '$data' not found (set HETSLAM_DATA_DIR)" >&2
  exit 2
fi
if ! command -v cmake >/dev/null; then
  echo "run_lama.sh: cmake not found (needed to build the driver)" >&2
  exit 2
fi

mkdir -p "$driver_build" "$out_root" || { echo "run_lama.sh: cannot create '$driver_build' or '$out_root'" >&2; exit 2; }
echo "== building the driver in $driver_build against $lama_config" >&2
if ! { cmake -S "$root/tests/bench/lama" -B "$driver_build" -DCMAKE_BUILD_TYPE=Release \
         -Diris_lama_DIR="$lama_config" && cmake --build "$driver_build"; } >"$out_root/driver_build.log" 2>&1; then
  echo "run_lama.sh: the lama_carmen driver did not build; see $out_root/driver_build.log" >&2
  tail -20 "$out_root/driver_build.log" >&2
  exit 1
fi
driver="$driver_build/lama_carmen"

logs=(intel fr079 aces mit-csail)
[ "$quick" -eq 1 ] && logs=(intel)

# now, run_timed (peak RSS and CPU time of one run).
source "$root/tests/bench/timed_run.sh"

echo "LaMa (iris_lama ${lama_version:-version unknown} lama::Slam2D, with odometry) on the shared logs:" \
  "$(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1), $(nproc) cores"
echo "lama:  $lama_config"
echo "build: $build"
echo "data:  $data"
echo "out:   $out_root"
[ ${#extra[@]} -gt 0 ] && echo "extra lama_carmen flags: ${extra[*]}"
echo

rows=()
stage_rows=()
options_line=""
status=0
for name in "${logs[@]}"; do
  clf="$data/$name/$name.clf"
  if [ ! -f "$clf" ]; then
    rows+=("$(printf '%-10s %s' "$name" "skipped: $clf not found")")
    continue
  fi
  out="$out_root/$name"
  mkdir -p "$out"
  echo "== $name: lama_carmen --log=$clf --trajectory=$out/trajectory.txt ${extra[*]:-}" >&2
  start=$(now)
  run_timed "$out/time.txt" "$driver" --log="$clf" --trajectory="$out/trajectory.txt" "${extra[@]}" \
    >"$out/run.log" 2>&1
  rc=$?
  end=$(now)
  if [ $rc -ne 0 ]; then
    rows+=("$(printf '%-10s %s' "$name" "FAILED: lama_carmen exit $rc, see $out/run.log")")
    status=1
    continue
  fi
  [ -z "$options_line" ] && options_line=$(sed -n 's/^options: //p' "$out/run.log")
  scans=$(sed -n 's/^scans: \([0-9]*\) processed.*/\1/p' "$out/run.log")
  updates=$(sed -n 's/^scans: .*(\([0-9]*\) updates.*/\1/p' "$out/run.log")
  duration=$(sed -n 's/.*data duration \([-0-9.]*\) s.*/\1/p' "$out/run.log")
  stages=$(sed -n 's/^time per stage (wall s, share of [0-9.]* s): //p' "$out/run.log")
  rss_kib=$(awk '$1 == "peak_rss_kib" {print $2}' "$out/time.txt")
  cpu=$(awk '$1 == "cpu_seconds" {print $2}' "$out/time.txt")
  wall=$(awk -v a="$start" -v b="$end" 'BEGIN {printf "%.2f", b - a}')
  rtf=$(awk -v d="$duration" -v w="$wall" 'BEGIN {printf "%.1f", (w > 0 ? d / w : 0)}')
  rss_mib=$(awk -v k="$rss_kib" 'BEGIN {printf "%.0f", k / 1024}')

  ref="$data/$name/$name.gmapping.txt"
  : >"$out/compare.txt"
  agreement="-"
  if [ -f "$ref" ]; then
    if "$compare" --trajectory="$out/trajectory.txt" --reference="$ref" --match_tolerance=0.001 --rpe_gap=10 \
         >"$out/compare.txt" 2>&1; then
      agreement=$(sed -n 's/^ATE after SE(2) alignment.*translation rmse \([0-9.]*\) m.*rotation rmse \([0-9.]*\) deg.*/\1 m \/ \2°/p' \
        "$out/compare.txt")
      if [ -z "$agreement" ]; then
        agreement="hetslam_compare printed no ATE, see $out/compare.txt"
        status=1
      fi
    else
      agreement="hetslam_compare FAILED, see $out/compare.txt"
      status=1
    fi
  else
    agreement="no $name.gmapping.txt"
  fi
  rows+=("$(printf '%-10s %6s %7s %9s %8s %7s %7s %8s  %s' "$name" "$scans" "$updates" "$duration" "$wall" \
    "${rtf}x" "${cpu:--}" "$rss_mib" "$agreement")")
  stage_rows+=("$(printf '%-10s %s' "$name" "$stages")")
done

echo
[ -n "$options_line" ] && echo "lama_carmen settings: $options_line"
printf '%-10s %6s %7s %9s %8s %7s %7s %8s  %s\n' log scans updates "data s" "wall s" RTF "CPU s" "RSS MiB" \
  "ATE vs GMapping (rmse after SE(2) alignment; a reference, not ground truth)"
for row in "${rows[@]}"; do echo "$row"; done
if [ ${#stage_rows[@]} -gt 0 ]; then
  echo
  echo "time per stage (wall s, share of the stages' sum):"
  for row in "${stage_rows[@]}"; do echo "$row"; done
fi
echo
echo "Full outputs: $out_root/<log>/"
exit $status
