#!/usr/bin/env bash
# End-to-end benchmark of hetslam_team on the simulator's team scenarios. NOT a ctest test: it
# renders every team dataset with camera images and maps it (about half a minute per team and
# seed), so it is run by hand, e.g. before quoting figures.
#
#   tests/bench/run_teams.sh [BUILD_DIR] [-- extra hetslam_team flags...]
#
#   BUILD_DIR   build folder holding examples/hetslam_sim and examples/hetslam_team
#               (default: <repo>/build).
#   -- ...      everything after `--` is passed to every hetslam_team call
#               (e.g. `-- --wrong_tag_id_rate=0.2`).
#
# Environment:
#   HETSLAM_SEEDS      the simulator seeds, separated by spaces or commas (default: 1).
#   HETSLAM_TEAMS      the team scenarios (default: "team_two team_three team_overlap").
#   HETSLAM_BENCH_OUT  output folder (default: <repo>/out/teams): <team>/seed-<seed>/{sim,run},
#                      run.log = hetslam_team's output.
#   HETSLAM_MIRROR     1: simulate every scenario mirrored (hetslam_sim --mirror: the world, tags,
#                      starts and routes mirrored about the middle of the walls), to see whether a
#                      figure depends on the handedness of the building; default 0.
#
# One row per team, seed and pair of robots, from the "truth:" lines hetslam_team prints on
# simulated data: the error of the pair's relative pose against the truth after the first link,
# after the second constraint and at the end (each robot's frame = its body at its first TRUTH),
# and at the end against the frames as the maps were built (each robot's trajectory aligned to
# its truth: what the merger itself got wrong). "-" where the pair never got that far (a pair
# linked through a third robot has no link of its own). Then the worst of each column per
# team and pair over the seeds.
# Then, when build/examples/hetslam_layers exists, the merged map against the true layers: one
# row per team and seed, run/merged_map.pgm scored as a map.pgm (walls + furniture; precision
# and recall within one cell, hetslam_layers --help) after aligning the first robot's trajectory
# (the common frame) to its truth; its output in run/merged_layers/, then worst / mean per team.
# And each robot's own run/<robot>/map.pgm and walls.pgm (the walls without the cells a
# teammate saw through: hetslam_team --wall_seen_through), aligned by its own trajectory, worst /
# mean per team and robot (hetslam_layers' output in run/<robot>/layers.csv).
# Then every pose the map-overlap search checked against the two groups' maps (accepted, held or
# refused), scored against the truth (right: within 0.3 m / 3 deg of the true relative pose of
# the two robots' frames): per team, how many were right and the largest conflict share among
# them, how many wrong and the smallest among them (the map check's margins either side of
# hetslam_team --overlap_max_conflict), and how many wrong ones were accepted (wrong merges).
# Last, every map-overlap link withdrawn because the joined group's tags contradicted it (the
# robots were in one frame wrongly until then; the first-link column shows the link after it).
# Exit status: 0 when every run finished, 1 otherwise, 2 on a usage error.
set -uo pipefail

usage() { sed -n '2,/^# Exit status/p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/../.." && pwd)
build=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "run_teams.sh: unknown option '$1' (hetslam_team flags go after --; see --help)" >&2; exit 2 ;;
    *)
      if [ -n "$build" ]; then echo "run_teams.sh: more than one build folder given ('$build', '$1')" >&2; exit 2; fi
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
out_root=${HETSLAM_BENCH_OUT:-$root/out/teams}
seed_list=${HETSLAM_SEEDS:-1}
read -r -a seeds <<<"${seed_list//,/ }"
read -r -a teams <<<"${HETSLAM_TEAMS:-team_two team_three team_overlap}"
for seed in "${seeds[@]}"; do
  if ! [[ $seed =~ ^[0-9]{1,19}$ ]]; then
    echo "run_teams.sh: seed '$seed' in HETSLAM_SEEDS is not a non-negative integer" >&2
    exit 2
  fi
done
for tool in hetslam_sim hetslam_team; do
  if [ ! -x "$build/examples/$tool" ]; then
    echo "run_teams.sh: $build/examples/$tool not found; build first (scripts/build.sh)" >&2
    exit 2
  fi
done

status=0
rows=$(mktemp)
trap 'rm -f "$rows"' EXIT
for team in "${teams[@]}"; do
  scenario="$root/datasets/scenarios/$team.scenario"
  if [ ! -f "$scenario" ]; then
    echo "run_teams.sh: no scenario $scenario" >&2
    status=1
    continue
  fi
  for seed in "${seeds[@]}"; do
    dir="$out_root/$team/seed-$seed"
    rm -rf "$dir"
    mkdir -p "$dir"
    echo "== $team seed $seed" >&2
    if ! "$build/examples/hetslam_sim" --scenario="$scenario" --seed="$seed" --out="$dir/sim" "${mirror_flag[@]}" >"$dir/sim.log" 2>&1; then
      echo "run_teams.sh: hetslam_sim failed, see $dir/sim.log" >&2
      status=1
      continue
    fi
    if ! "$build/examples/hetslam_team" --manifest="$dir/sim/team.txt" --out="$dir/run" "${extra[@]}" >"$dir/run.log" 2>&1; then
      echo "run_teams.sh: hetslam_team failed, see $dir/run.log" >&2
      status=1
      continue
    fi
    # Pairs: every "final A-B" line. First link / second constraint: the last such line for the pair.
    grep -o 'truth: final [A-Za-z0-9_]*-[A-Za-z0-9_]*: .*' "$dir/run.log" | while read -r line; do
      pair=$(sed 's/truth: final \([^:]*\):.*/\1/' <<<"$line")
      final=$(sed -n 's/.*: error \([0-9.]*\) m \/ \([0-9.]*\) deg (estimate.*/\1 \2/p' <<<"$line")
      built=$(sed -n 's/.*against the frames as built (alignment): error \([0-9.]*\) m \/ \([0-9.]*\) deg.*/\1 \2/p' <<<"$line")
      first=$(grep "truth: after first link .*: $pair after error" "$dir/run.log" | tail -1 |
              sed -n "s/.*: $pair after error \([0-9.]*\) m \/ \([0-9.]*\) deg.*/\1 \2/p")
      second=$(grep "truth: after second constraint .*: $pair before" "$dir/run.log" | tail -1 |
               sed -n 's/.*after error \([0-9.]*\) m \/ \([0-9.]*\) deg.*/\1 \2/p')
      echo "$team $seed $pair ${first:-- -} ${second:-- -} ${final:-- -} ${built:-- -}" >>"$rows"
    done
  done
done

# The merged map as the run's map.pgm, aligned by the first robot of the manifest; then each
# robot's own outputs in the team run (OUT/<robot>/map.pgm and walls.pgm, in the common frame;
# the walls without the cells a teammate saw through), aligned by that robot's trajectory.
merged_rows=$(mktemp)
robot_rows=$(mktemp)
trap 'rm -f "$rows" "$merged_rows" "$robot_rows"' EXIT
if [ -x "$build/examples/hetslam_layers" ]; then
  for team in "${teams[@]}"; do
    for seed in "${seeds[@]}"; do
      dir="$out_root/$team/seed-$seed"
      [ -f "$dir/run/merged_map.yaml" ] || continue
      first=$(awk '$1 == "robot" { print $2; exit }' "$dir/sim/team.txt")
      scored="$dir/run/merged_layers"
      rm -rf "$scored"
      mkdir -p "$scored"
      cp "$dir/run/merged_map.pgm" "$scored/map.pgm"
      sed 's/^image:.*/image: map.pgm/' "$dir/run/merged_map.yaml" >"$scored/map.yaml"
      if "$build/examples/hetslam_layers" --run_dir="$scored" --truth_layers="$dir/sim/truth_layers" \
          --trajectory="$dir/run/$first/trajectory.txt" --truth="$dir/sim/$first/log.txt" \
          --out_csv="$scored/layers.csv" >"$scored/layers.log" 2>&1; then
        awk -F, -v team="$team" -v seed="$seed" '$1 == "map" && $3 == "scored" { print team, seed, $4, $5 }' \
          "$scored/layers.csv" >>"$merged_rows"
      else
        echo "run_teams.sh: hetslam_layers failed on the merged map, see $scored/layers.log" >&2
        status=1
      fi
      for robot in $(awk '$1 == "robot" { print $2 }' "$dir/sim/team.txt"); do
        run="$dir/run/$robot"
        [ -f "$run/trajectory.txt" ] || continue
        if "$build/examples/hetslam_layers" --run_dir="$run" --truth_layers="$dir/sim/truth_layers" \
            --truth="$dir/sim/$robot/log.txt" --out_csv="$run/layers.csv" >"$run/layers.log" 2>&1; then
          awk -F, -v team="$team" -v seed="$seed" -v robot="$robot" \
            '($1 == "map" || $1 == "walls") && $3 == "scored" { print team, seed, robot, $1, $4, $5 }' \
            "$run/layers.csv" >>"$robot_rows"
        else
          echo "run_teams.sh: hetslam_layers failed on $run, see $run/layers.log" >&2
          status=1
        fi
      done
    done
  done
fi

fmt() { if [ "$1" = "-" ]; then printf '%-16s' "-"; else printf '%-16s' "$(printf '%.3f m %.2f°' "$1" "$2")"; fi; }
printf '%-11s %4s %-12s %-16s %-16s %-16s %-16s\n' team seed pair first_link second_constraint final final_as_built
while read -r team seed pair f1 f2 s1 s2 e1 e2 b1 b2; do
  printf '%-11s %4s %-12s %s %s %s %s\n' "$team" "$seed" "$pair" "$(fmt "$f1" "$f2")" "$(fmt "$s1" "$s2")" \
    "$(fmt "$e1" "$e2")" "$(fmt "$b1" "$b2")"
done <"$rows"
if [ "${#seeds[@]}" -gt 1 ]; then
  echo
  echo "worst over seeds ${seeds[*]} (metres and degrees each the worst, not necessarily of one seed):"
  awk '
    function upd(key, m, d) { if (m == "-") return; if (!(key in wm) || m + 0 > wm[key]) wm[key] = m + 0;
                              if (!(key in wd) || d + 0 > wd[key]) wd[key] = d + 0; seen[key] = 1 }
    { id = $1 " " $3; ids[id] = 1; upd(id " 1", $4, $5); upd(id " 2", $6, $7); upd(id " 3", $8, $9); upd(id " 4", $10, $11) }
    END { for (id in ids) { line = sprintf("%-24s", id);
            for (c = 1; c <= 4; ++c) { k = id " " c; line = line sprintf(" %-16s", (k in seen) ? sprintf("%.3f m %.2f°", wm[k], wd[k]) : "-") }
            print line } }' "$rows" | sort
fi
if [ -s "$merged_rows" ]; then
  echo
  echo "merged map (merged_map.pgm) against walls + furniture, within one cell:"
  printf '%-11s %4s %9s %9s\n' team seed precision recall
  awk '{ printf "%-11s %4s %9.3f %9.3f\n", $1, $2, $3, $4 }' "$merged_rows"
  awk '{ if (!($1 in n)) order[++k] = $1; n[$1]++; sp[$1] += $3; sr[$1] += $4
         if (!($1 in wp) || $3 < wp[$1]) wp[$1] = $3; if (!($1 in wr) || $4 < wr[$1]) wr[$1] = $4 }
       END { for (i = 1; i <= k; ++i) { t = order[i]
               printf "%-11s worst / mean over %d: precision %.3f / %.3f, recall %.3f / %.3f\n", t, n[t], wp[t], sp[t] / n[t], wr[t], sr[t] / n[t] } }' "$merged_rows"
fi
if [ -s "$robot_rows" ]; then
  echo
  echo "each robot's map.pgm (walls + furniture) and walls.pgm (walls) in the team run, within one cell,"
  echo "worst / mean over the seeds:"
  # A map with no cell of the layer has no precision (hetslam_layers writes nan): left out of
  # the precision's worst and mean, and counted.
  awk '{ k = $1 " " $3 " " $4; if (!(k in n)) order[++m] = k; n[k]++; sr[k] += $6
         if (!(k in wr) || $6 < wr[k]) wr[k] = $6
         if (tolower($5) ~ /nan/) { empty[k]++ } else { np[k]++; sp[k] += $5; if (!(k in wp) || $5 < wp[k]) wp[k] = $5 } }
       END { for (i = 1; i <= m; ++i) { k = order[i]; split(k, f, " ")
               p = (k in wp) ? sprintf("%.3f / %.3f", wp[k], sp[k] / np[k]) : "-"
               note = (k in empty) ? sprintf("; no cell on %d, precision over the others", empty[k]) : ""
               printf "%-11s %-8s %-6s precision %s, recall %.3f / %.3f (%d seeds%s)\n", f[1], f[2], f[3], p, wr[k], sr[k] / n[k], n[k], note } }' "$robot_rows"
fi
# Links undone: a map-overlap link the joined group's tags contradicted later (the robots were
# in one frame wrongly until then).
echo
# Every pose the map-overlap search checked against the two maps (constraints.txt rows of kind
# map_overlap with a map check: accepted, held or refused), scored against the truth: the true
# relative pose of the two robots' frames from their first TRUTH lines (each robot's frame is its
# body at its first scan). Right: within 0.3 m and 3 deg of it (a wrong pose is metres off).
echo "map-overlap poses checked against the maps, scored against the truth (right: within 0.3 m / 3 deg;"
echo "conflict: the map check's share, hetslam_team --overlap_max_conflict; a wrong pose accepted is a wrong merge):"
printf '%-12s %6s %-22s %6s %-22s %s\n' team right "worst conflict" wrong "least conflict" "wrong accepted"
for team in "${teams[@]}"; do
  for seed in "${seeds[@]}"; do
    dir="$out_root/$team/seed-$seed"
    [ -f "$dir/run/constraints.txt" ] || continue
    # "robot x y yaw" of each robot's first TRUTH line, then the checked poses.
    for log in "$dir"/sim/*/log.txt; do
      robot=$(basename "$(dirname "$log")")
      awk -v r="$robot" '$1 == "TRUTH" { print "start", r, $3, $4, $8; exit }' "$log"
    done
    awk -v seed="$seed" '$4 == "map_overlap" && /map cells agree/ { print "pose", seed, $0 }' "$dir/run/constraints.txt"
  done | awk -v team="$team" '
    function wrap(a) { while (a > 3.14159265358979) a -= 6.28318530717959; while (a < -3.14159265358979) a += 6.28318530717959; return a }
    $1 == "start" { x[$2] = $3; y[$2] = $4; yaw[$2] = $5; next }
    $1 == "pose" {
      seed = $2; a = $4; b = $5
      if (!(a in x) || !(b in x) || !match($0, /conflict \([0-9.e+-]+%\)/)) next
      conflict = substr($0, RSTART + 10, RLENGTH - 12) + 0
      # The true a_T_b: b'"'"'s start in a'"'"'s frame.
      dx = x[b] - x[a]; dy = y[b] - y[a]; c = cos(yaw[a]); s = sin(yaw[a])
      tx = c * dx + s * dy; ty = -s * dx + c * dy; tt = wrap(yaw[b] - yaw[a])
      err = sqrt(($8 - tx) ^ 2 + ($9 - ty) ^ 2); aerr = wrap($10 - tt); if (aerr < 0) aerr = -aerr
      if (err <= 0.3 && aerr <= 3 * 3.14159265358979 / 180) {
        ++right; if (right == 1 || conflict > worst) { worst = conflict; worst_seed = seed }
      } else {
        ++wrong; if (wrong == 1 || conflict < least) { least = conflict; least_seed = seed }
        if ($16 == "accepted") ++wrong_accepted
      }
    }
    END {
      w = right > 0 ? sprintf("%.3g%% (seed %s)", worst, worst_seed) : "-"
      l = wrong > 0 ? sprintf("%.3g%% (seed %s)", least, least_seed) : "-"
      printf "%-12s %6d %-22s %6d %-22s %d\n", team, right, w, wrong, l, wrong_accepted
    }'
done
echo
echo "map-overlap links withdrawn (\"split again\" in run.log):"
withdrawn=0
for team in "${teams[@]}"; do
  for seed in "${seeds[@]}"; do
    log="$out_root/$team/seed-$seed/run.log"
    [ -f "$log" ] || continue
    while read -r line; do
      echo "$team seed $seed: $line"
      withdrawn=$((withdrawn + 1))
    done < <(grep '^t=.* split again ' "$log")
  done
done
[ "$withdrawn" -eq 0 ] && echo "none"
exit $status
