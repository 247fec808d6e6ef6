#include "core/file_io.h"

#include <sstream>

#include <cerrno>
#include <cstring>

#include "glog/logging.h"

namespace hetslam {

Status CloseWrittenFile(std::FILE* file, const std::string& path) {
  CHECK(file != nullptr) << "CloseWrittenFile: file for '" << path << "' is null";
  const bool write_failed = std::ferror(file) != 0;
  // errno as the failed write left it; fclose may overwrite it.
  const int write_errno = errno;
  if (std::fclose(file) != 0 || write_failed) {
    return Status::Error("error writing '" + path + "': " +
                         std::strerror(write_failed ? write_errno : errno));
  }
  return Status::Ok();
}

Status WriteFileBytes(const std::string& path, const void* data, std::size_t size) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) {
    return Status::Error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  }
  if (size > 0) std::fwrite(data, 1, size, file);
  return CloseWrittenFile(file, path);
}

void WriteCommentLines(std::FILE* file, const std::vector<std::string>& comment_lines) {
  for (const std::string& comment : comment_lines) {
    std::istringstream lines(comment);
    std::string one;
    bool any = false;
    while (std::getline(lines, one)) {
      std::fprintf(file, "# %s\n", one.c_str());
      any = true;
    }
    if (!any) std::fprintf(file, "#\n");
  }
}

}  // namespace hetslam
