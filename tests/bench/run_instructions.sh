#!/usr/bin/env bash
# Instructions hetslam_run executes on a real log, by stage, counted by valgrind's callgrind.
# Wall time on this project's shared VM moves by tens of percent from hour to hour, and not
# alike for every program (README, "Where Intel's time goes"); an instruction count does not:
# the same binary on the same input executes the same instructions. NOT a ctest test (Intel
# takes about 3 minutes under callgrind, a comparison twice that); run it by hand to judge a
# change meant to make a run faster, against the build before it (--base).
#
#   tests/bench/run_instructions.sh [--log=NAME|FILE] [--scans=N] [--base=BUILD_DIR] [BUILD_DIR]
#                                   [-- extra hetslam_run flags...]
#
#   BUILD_DIR     build folder holding examples/hetslam_run (default: <repo>/build). A
#                 RelWithDebInfo build (the default) names every function; without symbols the
#                 stages cannot be told apart and read 0.
#   --log=...     intel, fr079, aces or mit-csail (<name>/<name>.clf in
#                 ${HETSLAM_DATA_DIR:-<repo>/../shared/datasets}), or a log file (default: intel).
#   --scans=N     the first N scans only (hetslam_run --max_scans; default: all).
#   --base=DIR    also count a second build (the one before a change) and print both, with the
#                 change in percent, and whether the two runs' trajectories are byte-identical.
#   -- ...        everything after `--` is passed to every hetslam_run call.
#
# Stages (inclusive counts: a function's own instructions and those of everything it calls):
#   the whole process; reading the log (MeasurementStream::Open and ::Next); the front end's
#   matching (LocalSlam::Match); map insertion (LocalSlam::Insert); loop search
#   (LoopCloser::Search); solves (OnlineEstimator::Solve); the maps and files written at the
#   end and the rest (the process less OnlineEstimator::Add and the reading). Then every scan
#   match of the front end and the loop closer together (ScanMatcher::MatchOnce) and what it
#   calls: the branch-and-bound tables (BuildPyramid), the refinement (ceres::Solve), the
#   branch and bound (BranchAndBound), the score profile (BilinearScoresAt), the discretised
#   scan (Discretize) and the top level's scores (ScoreFour called by MatchOnce).
#
# Outputs go to ${HETSLAM_BENCH_OUT:-<repo>/out/instructions}/<label>/ (hetslam_run's outputs,
# run.log, callgrind.out, annotate.txt). Exit status: 0 when every run finished (or valgrind is
# not installed: said, nothing run), 1 when a run failed, 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^# not installed/p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
build=""
base=""
log=intel
scans=0
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --log=*) log=${1#--log=} ;;
    --scans=*)
      scans=${1#--scans=}
      if ! [[ $scans =~ ^[0-9]{1,9}$ ]]; then
        echo "run_instructions.sh: --scans wants a number of scans (got '$scans')" >&2
        exit 2
      fi ;;
    --base=*) base=${1#--base=} ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "run_instructions.sh: unknown option '$1' (hetslam_run flags go after --; see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_instructions.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
      build=$1 ;;
  esac
  shift
done
build=${build:-$root/build}
data=${HETSLAM_DATA_DIR:-$root/../shared/datasets}
out_root=${HETSLAM_BENCH_OUT:-$root/out/instructions}

if ! command -v valgrind >/dev/null 2>&1 || ! command -v callgrind_annotate >/dev/null 2>&1; then
  echo "run_instructions.sh: valgrind (with callgrind_annotate) is not installed: nothing counted (apt-get install valgrind)"
  exit 0
fi
for dir in "$build" ${base:+"$base"}; do
  if [ ! -x "$dir/examples/hetslam_run" ]; then
    echo "run_instructions.sh: $dir/examples/hetslam_run not found (build it first, or give the build folder)" >&2
    exit 2
  fi
done
case "$log" in
  intel | fr079 | aces | mit-csail) clf="$data/$log/$log.clf" ;;
  *) clf=$log ;;
esac
if [ ! -f "$clf" ]; then
  echo "run_instructions.sh: log '$clf' not found" >&2
  exit 2
fi

# count LABEL BUILD: one hetslam_run under callgrind; the stages into $out_root/LABEL/stages.txt,
# one "key instructions" line each.
count() {
  local label=$1 dir=$2
  local out="$out_root/$label"
  rm -rf "$out"
  mkdir -p "$out"
  # glibc's own malloc thresholds (hetslam_run's are 1024 / 512 KiB): with those, under callgrind
  # (only there), runs of Intel aborted part way, every time in a row at one point, after
  # valgrind's "brk segment overflow" (its heap segment is a fixed 8 MB; see its manual,
  # Limitations): a 0.5 MB realloc of a grid's tiles or an operator new failed. With glibc's
  # defaults every run completed. They change the count by under 0.01%, alike for both builds.
  local args=(--log="$clf" --out="$out" --progress_every=0 --malloc_mmap_threshold_kib=0 --malloc_trim_threshold_kib=0)
  [ "$scans" -gt 0 ] && args+=(--max_scans="$scans")
  echo "== $label: valgrind --tool=callgrind $dir/examples/hetslam_run ${args[*]} ${extra[*]:-}" >&2
  # A run that still aborts is tried again, up to three times in all.
  local attempt
  for attempt in 1 2 3; do
    if valgrind --tool=callgrind --callgrind-out-file="$out/callgrind.out" \
         "$dir/examples/hetslam_run" "${args[@]}" "${extra[@]}" >"$out/run.log" 2>&1; then
      break
    fi
    if [ $attempt -eq 3 ]; then
      echo "run_instructions.sh: hetslam_run failed under callgrind three times, see $out/run.log" >&2
      return 1
    fi
    echo "run_instructions.sh: hetslam_run failed under callgrind ($(grep -v '^==' "$out/run.log" | grep -m1 -E 'terminate|what|Error|error' || echo 'see run.log')); once more" >&2
  done
  callgrind_annotate --inclusive=yes --tree=calling --threshold=100 "$out/callgrind.out" >"$out/annotate.txt" 2>/dev/null
  # A function can be listed once per source file its instructions come from (inlined code):
  # its inclusive count is its largest entry (the one holding its calls). Calls are the "  >"
  # lines under a function's "*" line in the tree; MatchOnce's from its largest "*" block.
  awk '
    function count_of(line) { gsub(/,/, "", line); split(line, f, " "); return f[1] + 0 }
    function keep(key, n) { if (n > best[key]) best[key] = n }
    /PROGRAM TOTALS/ { keep("total", count_of($0)); next }
    /^ *[0-9,]+ \([ 0-9.]+%\)  \* / {
      n = count_of($0)
      in_match = 0
      if ($0 ~ /hetslam::ScanMatcher::MatchOnce\(/ && n > match_block) { match_block = n; in_match = 1; delete callee }
      if ($0 ~ /hetslam::\(anonymous namespace\)::Run\(\)/) keep("run", n)
      else if ($0 ~ /hetslam::OnlineEstimator::Add\(/) keep("add", n)
      else if ($0 ~ /hetslam::MeasurementStream::Open\(/) keep("open", n)
      else if ($0 ~ /hetslam::MeasurementStream::Next\(/) keep("next", n)
      else if ($0 ~ /hetslam::LocalSlam::Match\(/) keep("front_end", n)
      else if ($0 ~ /hetslam::LocalSlam::Insert\(/) keep("insertion", n)
      else if ($0 ~ /hetslam::LoopCloser::Search\(/) keep("loop_search", n)
      else if ($0 ~ /hetslam::OnlineEstimator::Solve\(/) keep("solves", n)
      else if ($0 ~ /hetslam::ScanMatcher::MatchOnce\(/) keep("matches", n)
      next
    }
    /^ *[0-9,]+ \([ 0-9.]+%\)  >  / {
      if (!in_match) next
      n = count_of($0)
      if ($0 ~ /BuildPyramid\(/) callee["tables"] += n
      else if ($0 ~ /ceres::Solve\(/) callee["refinement"] += n
      else if ($0 ~ /BranchAndBound\(/) callee["branch_and_bound"] += n
      else if ($0 ~ /BilinearScoresAt\(/) callee["profile"] += n
      else if ($0 ~ /::Discretize\(/) callee["discretise"] += n
      else if ($0 ~ /SearchContext::ScoreFour\(/) callee["top_level"] += n
      next
    }
    END {
      print "total", best["total"] + 0
      print "reading", best["open"] + best["next"]
      print "front_end", best["front_end"] + 0
      print "insertion", best["insertion"] + 0
      print "loop_search", best["loop_search"] + 0
      print "solves", best["solves"] + 0
      rest = best["run"] - best["add"] - best["open"] - best["next"]
      print "outputs", (rest > 0 ? rest : 0)
      print "matches", best["matches"] + 0
      n = split("tables refinement branch_and_bound profile discretise top_level", keys, " ")
      for (i = 1; i <= n; ++i) print keys[i], callee[keys[i]] + 0
    }' "$out/annotate.txt" >"$out/stages.txt"
}

status=0
count new "$build" || status=1
if [ -n "$base" ]; then
  count base "$base" || status=1
fi
[ $status -eq 0 ] || exit 1

echo
echo "hetslam_run on $clf under callgrind ($(valgrind --version)), $( [ "$scans" -gt 0 ] && echo "first $scans scans" || echo "every scan" )"
[ ${#extra[@]} -gt 0 ] && echo "extra hetslam_run flags: ${extra[*]}"
echo "build: $build${base:+; base: $base}"
echo
awk -v with_base="${base:+1}" '
  BEGIN {
    names["total"] = "the whole process"
    names["reading"] = "  reading the log"
    names["front_end"] = "  front-end matching"
    names["insertion"] = "  map insertion"
    names["loop_search"] = "  loop search"
    names["solves"] = "  solves"
    names["outputs"] = "  maps, files and the rest"
    names["matches"] = "every scan match (front end and loop search)"
    names["tables"] = "  branch-and-bound tables"
    names["refinement"] = "  refinement (Ceres)"
    names["branch_and_bound"] = "  branch and bound"
    names["profile"] = "  score profile"
    names["discretise"] = "  discretised scan"
    names["top_level"] = "  top-level scores"
  }
  FILENAME ~ /\/new\/stages.txt$/ { order[++rows] = $1; now[$1] = $2; next }
  { before[$1] = $2 }
  END {
    if (with_base) printf "%-46s %12s %12s %8s %7s\n", "stage", "base (G)", "new (G)", "change", "share"
    else printf "%-46s %12s %7s\n", "stage", "instructions (G)", "share"
    for (i = 1; i <= rows; ++i) {
      k = order[i]
      share = now["total"] > 0 ? 100 * now[k] / now["total"] : 0
      if (with_base) {
        change = before[k] > 0 ? sprintf("%+.1f%%", 100 * (now[k] - before[k]) / before[k]) : "-"
        printf "%-46s %12.3f %12.3f %8s %6.1f%%\n", names[k], before[k] / 1e9, now[k] / 1e9, change, share
      } else {
        printf "%-46s %12.3f %6.1f%%\n", names[k], now[k] / 1e9, share
      }
    }
  }' "$out_root/new/stages.txt" ${base:+"$out_root/base/stages.txt"}
if [ -n "$base" ]; then
  echo
  if cmp -s "$out_root/new/trajectory.txt" "$out_root/base/trajectory.txt"; then
    echo "trajectories: byte-identical"
  else
    echo "trajectories: DIFFERENT ($out_root/new/trajectory.txt, $out_root/base/trajectory.txt)"
  fi
fi
echo
echo "Full outputs: $out_root/<new|base>/ (annotate.txt: callgrind_annotate's inclusive counts and call tree)"
exit 0
