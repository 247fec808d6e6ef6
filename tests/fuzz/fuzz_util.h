// Helpers shared by the libFuzzer targets of tests/fuzz/ (issue #16). The readers take file
// paths, so an input is written to a file in a per-process scratch folder first.
#ifndef HETSLAM_TESTS_FUZZ_FUZZ_UTIL_H_
#define HETSLAM_TESTS_FUZZ_FUZZ_UTIL_H_

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>

#include <sys/stat.h>

namespace hetslam {
namespace fuzz {

// $TMPDIR (or /tmp)/hetslam_fuzz_<pid>: created once; files in it are overwritten per input.
inline const std::string& ScratchDir() {
  static const std::string dir = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::string d = std::string(tmp != nullptr && tmp[0] != '\0' ? tmp : "/tmp") + "/hetslam_fuzz_" +
                    std::to_string(static_cast<long long>(getpid()));
    mkdir(d.c_str(), 0700);
    return d;
  }();
  return dir;
}

// Writes `bytes` to ScratchDir()/name and returns the path.
inline std::string WriteScratchFile(const std::string& name, std::string_view bytes) {
  const std::string path = ScratchDir() + "/" + name;
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) std::abort();  // the harness itself is broken, not the reader
  if (!bytes.empty()) std::fwrite(bytes.data(), 1, bytes.size(), file);
  std::fclose(file);
  return path;
}

inline std::string_view AsText(const uint8_t* data, size_t size) {
  return std::string_view(reinterpret_cast<const char*>(data), size);
}

// Splits an input at the first `separator` line: (before, after); after is empty without one.
inline std::pair<std::string_view, std::string_view> SplitAt(std::string_view text, std::string_view separator) {
  const size_t at = text.find(separator);
  if (at == std::string_view::npos) return {text, std::string_view()};
  return {text.substr(0, at), text.substr(at + separator.size())};
}

}  // namespace fuzz
}  // namespace hetslam

#endif  // HETSLAM_TESTS_FUZZ_FUZZ_UTIL_H_
