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

std::string TemporaryPathFor(const std::string& path) { return path + ".tmp"; }

Status OpenForWriting(const std::string& path, const char* mode, std::FILE** file) {
  CHECK(file != nullptr) << "OpenForWriting: file is null";
  *file = nullptr;
  if (path.empty()) return Status::Error("cannot write a file with an empty name");
  const std::string temporary = TemporaryPathFor(path);
  *file = std::fopen(temporary.c_str(), mode);
  if (*file == nullptr) {
    return Status::Error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  }
  return Status::Ok();
}

Status CommitWrittenFile(std::FILE* file, const std::string& path) {
  const std::string temporary = TemporaryPathFor(path);
  const Status closed = CloseWrittenFile(file, path);
  if (!closed.ok()) {
    std::remove(temporary.c_str());
    return closed;
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(temporary.c_str());
    return Status::Error("cannot write '" + path + "': " + reason);
  }
  return Status::Ok();
}

Status WriteFileBytes(const std::string& path, const void* data, std::size_t size) {
  std::FILE* file = nullptr;
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "wb", &file));
  if (size > 0) std::fwrite(data, 1, size, file);
  return CommitWrittenFile(file, path);
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
