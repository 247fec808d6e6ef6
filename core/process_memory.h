// The calling process's resident memory and its peak so far, as the kernel counts them (the
// peak is what `/usr/bin/time` reports as the maximum resident set size). Linux only
// (/proc/self/status); elsewhere ReadResidentMemory returns nothing.
#ifndef HETSLAM_CORE_PROCESS_MEMORY_H_
#define HETSLAM_CORE_PROCESS_MEMORY_H_

#include <cstddef>
#include <optional>
#include <string_view>

namespace hetslam {

struct ResidentMemory {
  size_t resident_bytes = 0;  // VmRSS
  size_t peak_bytes = 0;      // VmHWM: the most resident so far
};

// Reads /proc/self/status (one small file read); nothing where it cannot be read or parsed.
std::optional<ResidentMemory> ReadResidentMemory();

// The VmRSS and VmHWM lines of a /proc/<pid>/status text ("VmRSS:\t  28480 kB"); nothing when
// either is missing or not a number of kB.
std::optional<ResidentMemory> ParseProcStatus(std::string_view status);

}  // namespace hetslam

#endif  // HETSLAM_CORE_PROCESS_MEMORY_H_
