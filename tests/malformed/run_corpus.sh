#!/usr/bin/env bash
# Runs the malformed-input corpus (tests/data/malformed/MANIFEST.txt) through the example
# programs and checks each case's exit status and message. Any process that dies by a signal
# (a crash, an abort, an uncaught exception) or runs past the time limit fails the test.
#   run_corpus.sh BIN_DIR CORPUS_DIR [SECONDS_PER_CASE]
set -u
bin_dir=$1
corpus=$(cd "$2" && pwd)
limit=${3:-60}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cases=0
failures=0
line_number=0
trim() { local s=$1; s=${s#"${s%%[![:space:]]*}"}; s=${s%"${s##*[![:space:]]}"}; printf '%s' "$s"; }
while IFS= read -r line || [ -n "$line" ]; do
  line_number=$((line_number + 1))
  [[ -z "$(trim "$line")" || "$(trim "$line")" == \#* ]] && continue
  IFS='|' read -r want_status want_text command <<< "$line"
  want_status=$(trim "$want_status")
  want_text=$(trim "$want_text")
  command=$(trim "$command")
  cases=$((cases + 1))
  out="$work/case$cases"
  mkdir -p "$out"
  want_text=${want_text//\{dir\}/$corpus}
  want_text=${want_text//\{out\}/$out}
  command=${command//\{dir\}/$corpus}
  command=${command//\{out\}/$out}
  read -r -a argv <<< "$command"
  program="$bin_dir/${argv[0]}"
  where="MANIFEST.txt:$line_number ($command)"
  if [ ! -x "$program" ]; then
    echo "FAIL $where: no program $program"
    failures=$((failures + 1))
    continue
  fi
  timeout -k 5 "$limit" "$program" "${argv[@]:1}" > "$out/output.txt" 2>&1
  status=$?
  if [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then
    echo "FAIL $where: killed after the time limit of $limit s"
    failures=$((failures + 1))
  elif [ "$status" -gt 128 ]; then
    echo "FAIL $where: died by signal $((status - 128))"
    tail -5 "$out/output.txt"
    failures=$((failures + 1))
  elif [ "$status" -ne "$want_status" ]; then
    echo "FAIL $where: exit status $status, expected $want_status"
    tail -5 "$out/output.txt"
    failures=$((failures + 1))
  elif ! grep -qF -- "$want_text" "$out/output.txt"; then
    echo "FAIL $where: output lacks '$want_text'"
    tail -5 "$out/output.txt"
    failures=$((failures + 1))
  fi
  # No temporary output file may be left behind by a failed write.
  if find "$out" -name '*.tmp' | grep -q .; then
    echo "FAIL $where: left a temporary file behind: $(find "$out" -name '*.tmp')"
    failures=$((failures + 1))
  fi
done < "$corpus/MANIFEST.txt"
echo "$cases cases, $failures failed"
[ "$cases" -gt 0 ] && [ "$failures" -eq 0 ]
