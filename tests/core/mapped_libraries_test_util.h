// Whether a shared library is mapped into the calling process: for the tests of the plugins
// (core/plugin_loader.h), which promise that a library arrives only with its plugin.
#ifndef HETSLAM_TESTS_CORE_MAPPED_LIBRARIES_TEST_UTIL_H_
#define HETSLAM_TESTS_CORE_MAPPED_LIBRARIES_TEST_UTIL_H_

#include <link.h>

#include <string>

namespace hetslam {

// True when a library whose file name contains `name` is mapped into this process.
inline bool LibraryMapped(const std::string& name) {
  struct Search {
    std::string name;
    bool found = false;
  } search{name};
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void* data) {
        auto* s = static_cast<Search*>(data);
        if (info->dlpi_name != nullptr && std::string(info->dlpi_name).find(s->name) != std::string::npos) {
          s->found = true;
        }
        return 0;
      },
      &search);
  return search.found;
}

}  // namespace hetslam

#endif  // HETSLAM_TESTS_CORE_MAPPED_LIBRARIES_TEST_UTIL_H_
