#include "core/process_memory.h"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <sstream>
#include <string>

namespace hetslam {
namespace {

// The kB value of the line `key` ("VmRSS:") of a status text, in bytes.
std::optional<size_t> KibField(std::string_view status, std::string_view key) {
  size_t at = 0;
  while (at < status.size()) {
    const size_t end = std::min(status.find('\n', at), status.size());
    const std::string_view line = status.substr(at, end - at);
    at = end + 1;
    if (line.substr(0, key.size()) != key) continue;
    std::string_view rest = line.substr(key.size());
    while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
    size_t kib = 0;
    const auto [next, error] = std::from_chars(rest.data(), rest.data() + rest.size(), kib);
    if (error != std::errc() || std::string_view(next, rest.data() + rest.size() - next) != " kB") {
      return std::nullopt;
    }
    return kib * 1024;
  }
  return std::nullopt;
}

}  // namespace

std::optional<ResidentMemory> ParseProcStatus(std::string_view status) {
  const std::optional<size_t> resident = KibField(status, "VmRSS:");
  const std::optional<size_t> peak = KibField(status, "VmHWM:");
  if (!resident.has_value() || !peak.has_value()) return std::nullopt;
  return ResidentMemory{*resident, *peak};
}

std::optional<ResidentMemory> ReadResidentMemory() {
#ifdef __linux__
  std::ifstream file("/proc/self/status");
  if (!file) return std::nullopt;
  std::ostringstream text;
  text << file.rdbuf();
  return ParseProcStatus(text.str());
#else
  return std::nullopt;
#endif
}

}  // namespace hetslam
