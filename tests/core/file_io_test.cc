#include "core/file_io.h"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

// The whole file, bytes as they are.
std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

TEST(FileIoTest, CloseWrittenFileKeepsWhatWasWritten) {
  const std::string path = ::testing::TempDir() + "/file_io_test_closed.txt";
  std::FILE* file = std::fopen(path.c_str(), "w");
  ASSERT_NE(file, nullptr);
  std::fprintf(file, "one %d\n", 2);
  const Status status = CloseWrittenFile(file, path);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ("one 2\n", FileBytes(path));
}

TEST(FileIoTest, CloseWrittenFileReportsAFullDevice) {
  // /dev/full accepts the buffered fprintf and fails the flush on close with ENOSPC.
  std::FILE* file = std::fopen("/dev/full", "w");
  if (file == nullptr) GTEST_SKIP() << "no /dev/full on this system";
  std::fprintf(file, "does not fit\n");
  const Status status = CloseWrittenFile(file, "/dev/full");
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("error writing '/dev/full': "));
  EXPECT_THAT(status.message(), HasSubstr("No space left on device"));
}

TEST(FileIoTest, WriteFileBytesWritesExactlyTheBytes) {
  const std::string path = ::testing::TempDir() + "/file_io_test_bytes.bin";
  const std::string bytes("a\0b\nc", 5);
  ASSERT_TRUE(WriteFileBytes(path, bytes.data(), bytes.size()).ok());
  EXPECT_EQ(bytes, FileBytes(path));
  // Zero bytes truncate the file to empty.
  ASSERT_TRUE(WriteFileBytes(path, nullptr, 0).ok());
  EXPECT_EQ("", FileBytes(path));
}

TEST(FileIoTest, WriteFileBytesNamesAPathThatCannotBeOpened) {
  const Status status = WriteFileBytes("/nonexistent/dir/out.bin", "x", 1);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ("cannot open '/nonexistent/dir/out.bin' for writing: No such file or directory",
            status.message());
}


// Issue #16: a failed write leaves no truncated file and keeps an older complete one.
TEST(FileIoTest, FailedWritesLeaveNoPartialFileAndKeepTheOldOne) {
  const std::string path = ::testing::TempDir() + "/file_io_test_atomic.txt";
  ASSERT_TRUE(WriteFileBytes(path, "old\n", 4).ok());
  std::FILE* file = nullptr;
  ASSERT_TRUE(OpenForWriting(path, "w", &file).ok());
  std::fprintf(file, "new, half written\n");
  EXPECT_EQ("old\n", FileBytes(path));  // readers see the old file until the commit
  // Simulate a failed write: the stream's error flag is set as a full disk would.
  std::fclose(file);
  file = std::fopen(TemporaryPathFor(path).c_str(), "r");  // writing to a read-only stream fails
  ASSERT_NE(file, nullptr);
  std::fputc('x', file);
  const Status status = CommitWrittenFile(file, path);
  EXPECT_FALSE(status.ok());
  EXPECT_EQ("old\n", FileBytes(path));
  std::FILE* gone = std::fopen(TemporaryPathFor(path).c_str(), "r");
  EXPECT_EQ(gone, nullptr) << "the temporary file was left behind";
  if (gone != nullptr) std::fclose(gone);

  ASSERT_TRUE(OpenForWriting(path, "w", &file).ok());
  std::fprintf(file, "new\n");
  ASSERT_TRUE(CommitWrittenFile(file, path).ok());
  EXPECT_EQ("new\n", FileBytes(path));
}

TEST(FileIoTest, AnUnwritableFolderIsAnErrorNamingThePath) {
  const Status status = WriteFileBytes("/nonexistent_dir/out.txt", "x", 1);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("cannot open '/nonexistent_dir/out.txt' for writing"));
}

}  // namespace
}  // namespace hetslam
