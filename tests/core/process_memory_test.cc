#include "core/process_memory.h"

#include <memory>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

TEST(ParseProcStatusTest, ReadsResidentAndPeakInBytes) {
  const std::optional<ResidentMemory> memory = ParseProcStatus(
      "Name:\thetslam_run\nVmPeak:\t  123456 kB\nVmHWM:\t   30124 kB\nVmRSS:\t   28480 kB\nThreads:\t1\n");
  ASSERT_TRUE(memory.has_value());
  EXPECT_EQ(28480u * 1024, memory->resident_bytes);
  EXPECT_EQ(30124u * 1024, memory->peak_bytes);
}

TEST(ParseProcStatusTest, NothingWhenAFieldIsMissingOrNotKib) {
  EXPECT_FALSE(ParseProcStatus("VmRSS:\t 100 kB\n").has_value());  // no VmHWM
  EXPECT_FALSE(ParseProcStatus("VmHWM:\t 100 kB\n").has_value());  // no VmRSS
  EXPECT_FALSE(ParseProcStatus("VmHWM:\t 100 kB\nVmRSS:\t x kB\n").has_value());
  EXPECT_FALSE(ParseProcStatus("VmHWM:\t 100 kB\nVmRSS:\t 100 MB\n").has_value());
  EXPECT_FALSE(ParseProcStatus("VmHWM:\t 100 kB\nVmRSS:\t -5 kB\n").has_value());
  EXPECT_FALSE(ParseProcStatus("").has_value());
  // A last line without its newline is read.
  EXPECT_TRUE(ParseProcStatus("VmHWM:\t 100 kB\nVmRSS:\t 90 kB").has_value());
}

#ifdef __linux__
// Touching 32 MiB of fresh pages raises the resident set by about that much, and the peak
// never lies below it.
TEST(ReadResidentMemoryTest, FollowsTouchedPages) {
  const std::optional<ResidentMemory> before = ReadResidentMemory();
  ASSERT_TRUE(before.has_value());
  EXPECT_GT(before->resident_bytes, 0u);
  EXPECT_GE(before->peak_bytes, before->resident_bytes);
  constexpr size_t kBytes = size_t{32} << 20;
  std::unique_ptr<char[]> block(new char[kBytes]);
  volatile char* touch = block.get();  // (volatile: stores the compiler must keep)
  for (size_t i = 0; i < kBytes; i += 4096) touch[i] = 1;
  const std::optional<ResidentMemory> after = ReadResidentMemory();
  ASSERT_TRUE(after.has_value());
  EXPECT_GE(after->resident_bytes, before->resident_bytes + kBytes * 3 / 4);
  EXPECT_GE(after->peak_bytes, after->resident_bytes);
}
#endif

}  // namespace
}  // namespace hetslam
