// Where tests find the shared third-party datasets (never committed to the repository).
//
// The folder is the environment variable HETSLAM_DATA_DIR when it is set and non-empty,
// else the compile definition HETSLAM_TEST_DATA_DIR (tests/CMakeLists.txt). Tests that need
// the data skip when it is absent:
//   const std::string clf = SharedDatasetPath("intel/intel.clf");
//   if (clf.empty()) GTEST_SKIP() << "shared datasets not found at " << SharedDatasetDir();
#ifndef HETSLAM_TESTS_TEST_DATA_H_
#define HETSLAM_TESTS_TEST_DATA_H_

#include <sys/stat.h>

#include <cstdlib>
#include <string>

namespace hetslam {

inline std::string SharedDatasetDir() {
  const char* env = std::getenv("HETSLAM_DATA_DIR");
  if (env != nullptr && env[0] != '\0') return env;
#ifdef HETSLAM_TEST_DATA_DIR
  return HETSLAM_TEST_DATA_DIR;
#else
  return "";
#endif
}

// Full path of `relative` (e.g. "intel/intel.clf") inside the shared dataset folder, or ""
// when that file does not exist (or is not a regular file).
inline std::string SharedDatasetPath(const std::string& relative) {
  const std::string dir = SharedDatasetDir();
  if (dir.empty()) return "";
  const std::string path = dir + "/" + relative;
  struct stat info;
  if (stat(path.c_str(), &info) != 0 || !S_ISREG(info.st_mode)) return "";
  return path;
}

}  // namespace hetslam

#endif  // HETSLAM_TESTS_TEST_DATA_H_
