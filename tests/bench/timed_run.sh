# Sourced by the end-to-end benchmark scripts (run_real_logs.sh, run_lama.sh): timing and peak
# memory of one program run.
#
#   now                      seconds since the epoch, with nanoseconds
#   run_timed TIME_FILE CMD...
#       runs CMD with stdout and stderr as inherited and returns its exit status; writes
#       "peak_rss_kib <n>" and "cpu_seconds <s>" (user + system) to TIME_FILE, after
#       /usr/bin/time -v's whole report when GNU time is there. Without it the peak is the
#       process's high-water mark (VmHWM) polled every 50 ms, and the CPU time is not known.

timed_run_have_gnu_time=0
[ -x /usr/bin/time ] && /usr/bin/time -v true >/dev/null 2>&1 && timed_run_have_gnu_time=1

now() { date +%s.%N; }

run_timed() {
  local time_file=$1
  shift
  if [ "$timed_run_have_gnu_time" -eq 1 ]; then
    /usr/bin/time -v -o "$time_file.raw" "$@"
    local rc=$?
    cp "$time_file.raw" "$time_file"
    awk -F': ' '/Maximum resident set size/ {print "peak_rss_kib " $2}
                /User time \(seconds\)/ {u = $2} /System time \(seconds\)/ {s = $2}
                END {printf "cpu_seconds %.2f\n", u + s}' "$time_file.raw" >>"$time_file"
    rm -f "$time_file.raw"
    return $rc
  fi
  "$@" &
  local pid=$! hwm=0 v
  while kill -0 "$pid" 2>/dev/null; do
    v=$(awk '/^VmHWM:/ {print $2}' "/proc/$pid/status" 2>/dev/null)
    [ -n "$v" ] && [ "$v" -gt "$hwm" ] && hwm=$v
    sleep 0.05
  done
  wait "$pid"
  local rc=$?
  echo "peak_rss_kib $hwm (VmHWM polled every 50 ms; may miss a short final peak)" >"$time_file"
  return $rc
}
