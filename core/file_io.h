// Writing files with user-facing errors: every failure is a Status naming the path and the
// system's reason ("error writing 'out/map.pgm': No space left on device").
//
// Every output is written to a temporary file next to it (`path` + ".tmp") and renamed over
// `path` only when everything reached the disk: a failed write (full disk, unwritable folder)
// leaves no truncated or empty output and keeps an older complete file of that name.
#ifndef HETSLAM_CORE_FILE_IO_H_
#define HETSLAM_CORE_FILE_IO_H_

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

#include "core/status.h"

namespace hetslam {

// Closes `file` (open for writing with std::fopen; not null) and says whether everything
// written to it reached `path`: an error when an earlier write failed (the stream's error
// indicator) or when closing fails (the final flush: a full disk often shows only here).
// The file is closed in every case.
Status CloseWrittenFile(std::FILE* file, const std::string& path);

// Opens `path` + ".tmp" for writing (`mode` as std::fopen: "w" or "wb"); *file is null on
// error. Finish with CommitWrittenFile.
Status OpenForWriting(const std::string& path, const char* mode, std::FILE** file);

// CloseWrittenFile on the file OpenForWriting(path) gave, then renames `path` + ".tmp" to
// `path` when everything was written, else removes the temporary file.
Status CommitWrittenFile(std::FILE* file, const std::string& path);

// The temporary name OpenForWriting uses for `path`.
std::string TemporaryPathFor(const std::string& path);

// Writes the `size` bytes at `data` to `path` (binary) through a temporary file (see above).
Status WriteFileBytes(const std::string& path, const void* data, std::size_t size);

// Writes each comment as '#' lines ("# text"; a comment with line breaks gives one '#' line per
// line, an empty one a lone "#"): the header comments of our text formats.
void WriteCommentLines(std::FILE* file, const std::vector<std::string>& comment_lines);

}  // namespace hetslam

#endif  // HETSLAM_CORE_FILE_IO_H_
