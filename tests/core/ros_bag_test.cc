#include "core/ros_bag.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <bzlib.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/Image.h>

#include "core/measurement_log.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/ros_bag_test_util.h"
#include "tests/test_data.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;
using namespace testing_bag;  // NOLINT: the synthetic bag's constants

// Per process: ctest runs each test (and each parameter) as its own process, in parallel.
std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/ros_bag_test_" + std::to_string(getpid()) + "_" + name;
}

std::string Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

template <typename T>
std::vector<T> OfKind(const MeasurementLog& log) {
  std::vector<T> out;
  for (const Measurement& m : log.measurements) {
    if (const auto* x = std::get_if<T>(&m)) out.push_back(*x);
  }
  return out;
}

class RosBagReadTest : public ::testing::TestWithParam<uint32_t> {};

// Every kind reads back with the values written: scans beam for beam (float32 ranges, the
// laser mount from /tf_static), IMU samples rotated out of their tilted mount into base_link
// (the tilted body's gravity and turn rate, both along the world's z), the IMU orientation as the body attitude,
// odometry and commands; the stream is ordered by stamp. Plain, bz2 and lz4 bags alike.
TEST_P(RosBagReadTest, SyntheticBagReadsBackExactly) {
  SyntheticBagOptions bag_options;
  bag_options.body_roll_radians = 0.05;
  bag_options.body_pitch_radians = -0.1;
  bag_options.compression = GetParam();
  const std::string path = TempPath("synthetic_" + std::to_string(GetParam()) + ".bag");
  WriteSyntheticBag(path, bag_options);

  LogFormat format;
  ASSERT_TRUE(DetectLogFormat(path, &format).ok());
  EXPECT_EQ(LogFormat::kRosBag, format);
  MeasurementLog log;
  const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(log.warnings.empty()) << log.warnings.front();
  EXPECT_EQ("/scan", log.params.at("scan_topic"));
  EXPECT_EQ("/imu", log.params.at("imu_topic"));
  EXPECT_EQ("/odom", log.params.at("odom_topic"));
  EXPECT_EQ("/cmd_vel", log.params.at("cmd_topic"));
  EXPECT_EQ("tf_static", log.params.at("laser_mount"));

  const auto lasers = OfKind<LaserReading>(log);
  ASSERT_EQ(bag_options.num_scans, static_cast<int>(lasers.size()));
  EXPECT_EQ(bag_options.num_scans, log.num_scans);
  for (int k = 0; k < bag_options.num_scans; ++k) {
    const LaserScan& scan = lasers[k].scan;
    EXPECT_DOUBLE_EQ(ros::Time(kT0 + k * kScanPeriod).toSec(), scan.stamp_seconds);
    ASSERT_EQ(kBeams, static_cast<int>(scan.ranges_meters.size()));
    for (int i = 0; i < kBeams; ++i) {
      ASSERT_EQ(static_cast<double>(ExpectedRange(k, i, bag_options.body_roll_radians, bag_options.body_pitch_radians)),
                scan.ranges_meters[i])
          << "scan " << k << " beam " << i;
      ASSERT_NEAR(kAngleMin + i * kAngleIncrement, scan.angles_radians[i], 1e-6);
    }
    EXPECT_FLOAT_EQ(0.05f, scan.range_min_meters);
    EXPECT_FLOAT_EQ(10.0f, scan.range_max_meters);
    EXPECT_TRUE(scan.robot_T_sensor.isApprox(LaserMount(), 1e-12));
    EXPECT_GT(lasers[k].line_number, 0);  // the message's position in the bag
  }

  const auto marg = OfKind<MargSample>(log);
  ASSERT_EQ(191u, marg.size());
  const Eigen::Matrix3d world_R_body =
      RotationFromRollPitchYaw(bag_options.body_roll_radians, bag_options.body_pitch_radians, 0.0);
  const Eigen::Vector3d expected_accel = world_R_body.transpose() * Eigen::Vector3d(0, 0, kGravity);
  for (const MargSample& sample : marg) {
    EXPECT_TRUE(sample.accel_mps2.isApprox(expected_accel, 1e-12)) << sample.accel_mps2.transpose();
    EXPECT_TRUE(sample.gyro_radps.isApprox(expected_accel * (kYawRateRadps / kGravity), 1e-12))
        << sample.gyro_radps.transpose();
    EXPECT_FALSE(sample.has_magnetometer);
  }
  const auto attitudes = OfKind<AttitudeReading>(log);
  ASSERT_EQ(marg.size(), attitudes.size());
  for (const AttitudeReading& attitude : attitudes) {
    EXPECT_NEAR(bag_options.body_roll_radians, attitude.roll_radians, 1e-9);
    EXPECT_NEAR(bag_options.body_pitch_radians, attitude.pitch_radians, 1e-9);
    EXPECT_NEAR(kYawRateRadps * (attitude.stamp_seconds - kT0), attitude.yaw_radians, 1e-6);
  }

  const auto odometry = OfKind<OdometryReading>(log);
  ASSERT_EQ(bag_options.num_scans, static_cast<int>(odometry.size()));
  for (int k = 0; k < bag_options.num_scans; ++k) {
    const Pose2 truth = TrueBodyPose(k * kScanPeriod);
    EXPECT_NEAR(truth.x(), odometry[k].pose.x(), 1e-12);
    EXPECT_NEAR(truth.y(), odometry[k].pose.y(), 1e-12);
    EXPECT_NEAR(truth.theta(), odometry[k].pose.theta(), 1e-12);
  }
  const auto commands = OfKind<VelocityCommand>(log);
  ASSERT_EQ(bag_options.num_scans, static_cast<int>(commands.size()));
  EXPECT_EQ(kForwardMps, commands.front().forward_mps);
  EXPECT_EQ(0.0, commands.front().left_mps);
  EXPECT_EQ(kYawRateRadps, commands.front().yaw_rate_radps);

  for (size_t i = 1; i < log.measurements.size(); ++i) {
    ASSERT_LE(StampOf(log.measurements[i - 1]), StampOf(log.measurements[i])) << "measurement " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Compression, RosBagReadTest,
                         ::testing::Values(rosbag::compression::Uncompressed, rosbag::compression::BZ2,
                                           rosbag::compression::LZ4));

// A mount given in the options wins over /tf_static; "none" leaves a kind out; a topic named
// without its leading slash is found.
TEST(RosBagTest, OptionsOverrideTheMountAndLeaveKindsOut) {
  const std::string path = TempPath("options.bag");
  WriteSyntheticBag(path, SyntheticBagOptions());
  RosBagReadOptions options;
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.translation() = Eigen::Vector3d(0.2, 0.0, 0.5);
  options.robot_T_laser = mount;
  options.imu_topic = "none";
  options.cmd_topic = "none";
  options.odom_topic = "odom";  // the global /odom
  RosBagContents bag;
  const Status status = ReadRosBag(path, options, &bag);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ("options", bag.params.at("laser_mount"));
  EXPECT_TRUE(bag.lasers.front().scan.robot_T_sensor.isApprox(mount));
  EXPECT_TRUE(bag.marg.empty());
  EXPECT_TRUE(bag.attitudes.empty());
  EXPECT_TRUE(bag.commands.empty());
  EXPECT_EQ(20u, bag.odometry.size());
  EXPECT_EQ("/odom", bag.params.at("odom_topic"));
}

TEST(RosBagTest, MissingTopicListsTheBagsTopics) {
  const std::string path = TempPath("missing.bag");
  WriteSyntheticBag(path, SyntheticBagOptions());
  RosBagReadOptions options;
  options.scan_topic = "/base_scan";
  RosBagContents bag;
  const Status status = ReadRosBag(path, options, &bag);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr("no topic '/base_scan'"));
  EXPECT_THAT(status.message(), HasSubstr("/scan [sensor_msgs/LaserScan, 20 messages]"));
  EXPECT_THAT(status.message(), HasSubstr("/imu [sensor_msgs/Imu, 191 messages]"));
}

TEST(RosBagTest, WrongMessageTypeIsAnError) {
  const std::string path = TempPath("wrong_type.bag");
  WriteSyntheticBag(path, SyntheticBagOptions());
  RosBagReadOptions options;
  options.scan_topic = "/imu";
  RosBagContents bag;
  Status status = ReadRosBag(path, options, &bag);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr("topic '/imu' holds sensor_msgs/Imu messages, but scan_topic needs "
                                          "sensor_msgs/LaserScan"));
  options.scan_topic = "";
  options.odom_topic = "/cmd_vel";
  status = ReadRosBag(path, options, &bag);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("holds geometry_msgs/Twist messages, but odom_topic needs nav_msgs/Odometry"));
}

TEST(RosBagTest, BagWithoutScansIsAnError) {
  const std::string path = TempPath("no_scans.bag");
  SyntheticBagOptions bag_options;
  bag_options.with_scans = false;
  WriteSyntheticBag(path, bag_options);
  MeasurementLog log;
  const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr("no sensor_msgs/LaserScan topic"));
  EXPECT_THAT(status.message(), HasSubstr("/odom [nav_msgs/Odometry"));
}

// A bag cut short (the recorder killed) has no index; a bag whose bytes are cut at any of
// several points, or overwritten, is an error naming the file, never a crash.
TEST(RosBagTest, TruncatedBagIsAnErrorNamingTheFile) {
  const std::string good = TempPath("whole.bag");
  WriteSyntheticBag(good, SyntheticBagOptions());
  const std::string bytes = Bytes(good);
  for (const double fraction : {0.0005, 0.01, 0.3, 0.6, 0.9, 0.999}) {
    const std::string path = TempPath("truncated.bag");
    WriteBytes(path, bytes.substr(0, static_cast<size_t>(fraction * bytes.size())));
    MeasurementLog log;
    const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
    ASSERT_FALSE(status.ok()) << "cut at " << fraction;
    EXPECT_THAT(status.message(), HasSubstr(path)) << "cut at " << fraction;
  }
}

TEST(RosBagTest, CorruptBagIsAnErrorNamingTheFile) {
  for (const uint32_t compression : {rosbag::compression::Uncompressed, rosbag::compression::LZ4}) {
    const std::string good = TempPath("whole_" + std::to_string(compression) + ".bag");
    SyntheticBagOptions bag_options;
    bag_options.compression = compression;
    WriteSyntheticBag(good, bag_options);
    const std::string bytes = Bytes(good);
    // The bag header record (its index position and counts) right after the magic line.
    std::string corrupt = bytes;
    for (size_t i = 13; i < 60; ++i) corrupt[i] = '\xff';
    const std::string path = TempPath("corrupt.bag");
    WriteBytes(path, corrupt);
    MeasurementLog log;
    Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
    ASSERT_FALSE(status.ok());
    EXPECT_THAT(status.message(), HasSubstr(path));
    // The index at the end of the file.
    corrupt = bytes;
    for (size_t i = bytes.size() - 200; i < bytes.size(); ++i) corrupt[i] = '\x7f';
    WriteBytes(path, corrupt);
    status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
    ASSERT_FALSE(status.ok());
    EXPECT_THAT(status.message(), HasSubstr(path));
  }
}

// The bags the fuzzer found crashing or exhausting memory inside rosbag_storage (a header field
// longer than its header, a record header length of gigabytes) are refused by the record check
// before the library opens them, with an error naming the file and the record.
TEST(RosBagTest, HostileRecordLengthsAreRefusedBeforeTheLibraryReadsThem) {
  const std::string dir = std::string(HETSLAM_SOURCE_DIR) + "/tests/fuzz/known_failures/ros_bag";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".bag") continue;
    ++files;
    RosBagContents contents;
    const Status status = ReadRosBag(entry.path().string(), RosBagReadOptions(), &contents);
    ASSERT_FALSE(status.ok()) << entry.path();
    EXPECT_THAT(status.message(), HasSubstr(entry.path().string()));
    EXPECT_THAT(status.message(), HasSubstr("record at byte"));
  }
  EXPECT_EQ(4, files);
}

// A message whose own lengths run past it: the ros_bag fuzzer's 10-minute run found a LaserScan
// claiming 1.8e9 ranges, which roscpp's deserializer allocated (7.3 GB) before checking the
// bytes. Refused before the library deserializes it, naming the file and the message; lenient,
// the message is skipped and counted.
TEST(RosBagTest, MessageLengthsBeyondTheMessageAreRefused) {
  const std::string path =
      std::string(HETSLAM_SOURCE_DIR) + "/tests/fuzz/known_failures/ros_bag/message_lengths/oom_scan_ranges_length.bag";
  RosBagContents contents;
  const Status status = ReadRosBag(path, RosBagReadOptions(), &contents);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path + ": message "));
  EXPECT_THAT(status.message(), HasSubstr("a string or array length longer than the message's"));
  RosBagReadOptions lenient;
  lenient.lenient = true;
  const Status skipped = ReadRosBag(path, lenient, &contents);
  EXPECT_GE(contents.malformed_messages_skipped, 1) << skipped.message();
}

// ---- Compressed chunks rewritten by hand ----
// A bag is "#ROSBAG V2.0\n" (13 bytes) and then records: a 4-byte header length, the header
// (fields of a 4-byte length and "name=value"), a 4-byte data length and the data. The bag
// header record comes first; a small bag written by WriteSyntheticBag has one chunk right after
// it, whose data are its inner records (connections and messages), compressed.

uint32_t U32At(const std::string& bytes, size_t at) {
  uint32_t value = 0;
  std::memcpy(&value, bytes.data() + at, 4);
  return value;
}

void SetU32At(std::string* bytes, size_t at, uint32_t value) { std::memcpy(&(*bytes)[at], &value, 4); }

size_t RecordEnd(const std::string& bytes, size_t record) {
  const uint32_t header_length = U32At(bytes, record);
  return record + 8 + header_length + U32At(bytes, record + 4 + header_length);
}

// Where the value of the field `name` of the record header at `record` starts.
size_t FieldValueAt(const std::string& bytes, size_t record, const std::string& name) {
  const size_t end = record + 4 + U32At(bytes, record);
  for (size_t k = record + 4; k < end; k += 4 + U32At(bytes, k)) {
    if (bytes.compare(k + 4, name.size() + 1, name + "=") == 0) return k + 4 + name.size() + 1;
  }
  ADD_FAILURE() << "no field " << name << " in the record at byte " << record;
  return 0;
}

std::string Compress(uint32_t compression, const std::string& plain) {
  std::string out(plain.size() + plain.size() / 50 + 1024, '\0');
  unsigned int length = static_cast<unsigned int>(out.size());
  std::string input = plain;  // the C interfaces take non-const pointers
  if (compression == rosbag::compression::BZ2) {
    EXPECT_EQ(BZ_OK, BZ2_bzBuffToBuffCompress(&out[0], &length, &input[0], static_cast<unsigned int>(input.size()),
                                              /*blockSize100k=*/9, /*verbosity=*/0, /*workFactor=*/30));
  } else {
    EXPECT_EQ(ROSLZ4_OK, roslz4_buffToBuffCompress(&input[0], static_cast<unsigned int>(input.size()), &out[0], &length,
                                                   /*block_size_id=*/6));
  }
  out.resize(length);
  return out;
}

std::string Decompress(uint32_t compression, const std::string& packed, uint32_t size) {
  std::string out(size, '\0');
  unsigned int length = size;
  std::string input = packed;
  if (compression == rosbag::compression::BZ2) {
    EXPECT_EQ(BZ_OK, BZ2_bzBuffToBuffDecompress(&out[0], &length, &input[0], static_cast<unsigned int>(input.size()),
                                                0, 0));
  } else {
    EXPECT_EQ(ROSLZ4_OK, roslz4_buffToBuffDecompress(&input[0], static_cast<unsigned int>(input.size()), &out[0],
                                                     &length));
  }
  EXPECT_EQ(size, length);
  return out;
}

// A small compressed bag written by the library, with its one chunk taken apart.
struct CompressedBag {
  std::string bytes;
  size_t chunk = 0;  // the chunk record's first byte
  uint32_t size = 0;  // the chunk header's uncompressed size
  std::string plain;  // the chunk's records, decompressed
};

CompressedBag WriteCompressedBag(uint32_t compression) {
  const std::string path = TempPath("compressed_" + std::to_string(compression) + ".bag");
  SyntheticBagOptions bag_options;
  bag_options.num_scans = 3;
  bag_options.compression = compression;
  WriteSyntheticBag(path, bag_options);
  CompressedBag bag;
  bag.bytes = Bytes(path);
  bag.chunk = RecordEnd(bag.bytes, 13);
  bag.size = U32At(bag.bytes, FieldValueAt(bag.bytes, bag.chunk, "size"));
  const size_t header_length = U32At(bag.bytes, bag.chunk);
  const size_t data = bag.chunk + 8 + header_length;
  bag.plain = Decompress(compression, bag.bytes.substr(data, U32At(bag.bytes, data - 4)), bag.size);
  return bag;
}

// The bag with its chunk's data replaced by `data` and its size field by `size`; the bag
// header's index position moves with the chunk's length (the chunk is the only one, so the
// index records after it keep their meaning).
std::string WithChunk(const CompressedBag& bag, const std::string& data, uint32_t size) {
  const size_t header_length = U32At(bag.bytes, bag.chunk);
  const size_t data_at = bag.chunk + 8 + header_length;
  const size_t old_length = U32At(bag.bytes, data_at - 4);
  std::string out = bag.bytes.substr(0, data_at) + data + bag.bytes.substr(data_at + old_length);
  SetU32At(&out, data_at - 4, static_cast<uint32_t>(data.size()));
  SetU32At(&out, FieldValueAt(out, bag.chunk, "size"), size);
  const size_t index_pos_at = FieldValueAt(out, 13, "index_pos");
  uint64_t index_pos = 0;
  std::memcpy(&index_pos, out.data() + index_pos_at, 8);
  index_pos = index_pos + data.size() - old_length;
  std::memcpy(&out[index_pos_at], &index_pos, 8);
  return out;
}

Status ReadBytesAsBag(const std::string& name, const std::string& bytes, std::string* path) {
  *path = TempPath(name);
  WriteBytes(*path, bytes);
  RosBagContents contents;
  return ReadRosBag(*path, RosBagReadOptions(), &contents);
}

class RosBagCompressedChunkTest : public ::testing::TestWithParam<uint32_t> {};

// The helpers above rebuild a valid bag: recompressed as it was, it reads (every scan), so the
// failures below come from what each case changes.
TEST_P(RosBagCompressedChunkTest, RecompressedChunkReads) {
  const CompressedBag bag = WriteCompressedBag(GetParam());
  const std::string path = TempPath("recompressed.bag");
  WriteBytes(path, WithChunk(bag, Compress(GetParam(), bag.plain), bag.size));
  RosBagContents contents;
  const Status status = ReadRosBag(path, RosBagReadOptions(), &contents);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(3u, contents.lasers.size());
}

// A header field of the first record inside the chunk claims 2 GB in a header of a few dozen
// bytes: ros::Header::parse would read past its buffer (as in the uncompressed reproducers of
// tests/fuzz/known_failures/ros_bag). Refused, naming the file, the chunk and the record.
TEST_P(RosBagCompressedChunkTest, HostileRecordHeaderInsideTheChunkIsRefused) {
  const CompressedBag bag = WriteCompressedBag(GetParam());
  std::string plain = bag.plain;
  const uint32_t header_length = U32At(plain, 0);
  ASSERT_GT(header_length, 8u);
  SetU32At(&plain, 4, 0x7fffffff);  // the first field's length
  std::string path;
  const Status status =
      ReadBytesAsBag("hostile_inner.bag", WithChunk(bag, Compress(GetParam(), plain), bag.size), &path);
  ASSERT_FALSE(status.ok());
  const std::string compression = GetParam() == rosbag::compression::BZ2 ? "bz2" : "lz4";
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr("the record at byte 0 of the " + compression + " chunk at byte " +
                                          std::to_string(bag.chunk) + " (decompressed"));
  EXPECT_THAT(status.message(),
              HasSubstr("a header field of 2147483647 bytes in a header of " + std::to_string(header_length)));

  // A record further in whose data length runs past the end of the decompressed chunk.
  plain = bag.plain;
  const size_t second = RecordEnd(plain, 0);
  ASSERT_LT(second, plain.size());
  SetU32At(&plain, second + 4 + U32At(plain, second), static_cast<uint32_t>(plain.size()));
  const Status past_end =
      ReadBytesAsBag("hostile_inner_data.bag", WithChunk(bag, Compress(GetParam(), plain), bag.size), &path);
  ASSERT_FALSE(past_end.ok());
  EXPECT_THAT(past_end.message(), HasSubstr("record at byte " + std::to_string(second) + " of the " + compression));
  EXPECT_THAT(past_end.message(), HasSubstr("runs past the end of its file or chunk"));
}

// A size the data does not decompress to, more or fewer bytes, an absurd size (refused before
// anything of that size is allocated) and data that is not compressed at all: each refused with
// the chunk's position.
TEST_P(RosBagCompressedChunkTest, ChunkThatDoesNotDecompressToItsSizeIsRefused) {
  const CompressedBag bag = WriteCompressedBag(GetParam());
  const std::string packed = Compress(GetParam(), bag.plain);
  const std::string chunk = "the record at byte " + std::to_string(bag.chunk) + " has ";
  std::string path;

  Status status = ReadBytesAsBag("size_plus.bag", WithChunk(bag, packed, bag.size + 1), &path);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr(chunk));
  EXPECT_THAT(status.message(), HasSubstr("decompresses to " + std::to_string(bag.size) + " bytes, not its size of " +
                                          std::to_string(bag.size + 1)));

  status = ReadBytesAsBag("size_minus.bag", WithChunk(bag, packed, bag.size - 1), &path);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(chunk));
  EXPECT_THAT(status.message(), HasSubstr("decompresses to " + std::to_string(bag.size) + " bytes, not its size of " +
                                          std::to_string(bag.size - 1)));

  // Decompressing stops at the claimed size (and one byte more), not at the data's end.
  status = ReadBytesAsBag("size_half.bag", WithChunk(bag, packed, bag.size / 2), &path);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(chunk));
  EXPECT_THAT(status.message(), HasSubstr("decompresses to more than its size of " + std::to_string(bag.size / 2)));

  status = ReadBytesAsBag("size_absurd.bag", WithChunk(bag, packed, 0xf0000000u), &path);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(chunk));
  EXPECT_THAT(status.message(), HasSubstr("an uncompressed size of 4026531840 bytes, over the 1073741824 bytes"));

  status = ReadBytesAsBag("not_compressed.bag", WithChunk(bag, bag.plain, bag.size), &path);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(chunk));
  EXPECT_THAT(status.message(), HasSubstr("that does not decompress"));
}

INSTANTIATE_TEST_SUITE_P(Compression, RosBagCompressedChunkTest,
                         ::testing::Values(rosbag::compression::BZ2, rosbag::compression::LZ4));

// The fuzzer's seed bags (plain, bz2 and lz4 chunks) pass the record check and read.
TEST(RosBagTest, FuzzSeedBagsRead) {
  const std::string dir = std::string(HETSLAM_SOURCE_DIR) + "/tests/fuzz/seeds/ros_bag";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".bag") continue;
    ++files;
    RosBagContents contents;
    const Status status = ReadRosBag(entry.path().string(), RosBagReadOptions(), &contents);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(3u, contents.lasers.size()) << entry.path();
  }
  EXPECT_EQ(3, files);
}

// Images are written as grey PGM files into image_directory and become camera images; without
// an image_directory they are not read.
TEST(RosBagTest, ImagesBecomeGreyPgmFiles) {
  const std::string path = TempPath("images.bag");
  WriteSyntheticBag(path, SyntheticBagOptions());
  {
    rosbag::Bag bag(path, rosbag::bagmode::Append);
    sensor_msgs::Image image;
    image.header.stamp = ros::Time(kT0 + 0.05);
    image.encoding = "rgb8";
    image.width = 2;
    image.height = 1;
    image.step = 6;
    image.data = {255, 0, 0, 0, 0, 255};  // red, blue
    bag.write("/camera/image_raw", image.header.stamp, image);
  }
  RosBagContents bag;
  ASSERT_TRUE(ReadRosBag(path, RosBagReadOptions(), &bag).ok());
  EXPECT_TRUE(bag.images.empty());
  RosBagReadOptions options;
  options.image_directory = TempPath("images");
  const Status status = ReadRosBag(path, options, &bag);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ("/camera/image_raw", bag.params.at("image_topic"));
  ASSERT_EQ(1u, bag.images.size());
  EXPECT_DOUBLE_EQ(ros::Time(kT0 + 0.05).toSec(), bag.images[0].stamp_seconds);
  // 0.299 R + 0.587 G + 0.114 B, rounded.
  EXPECT_EQ(std::string("P5\n2 1\n255\n") + char(76) + char(29), Bytes(bag.images[0].path));
}

// The trajectory bag plays with the library: one PoseStamped per pose, then a Path of them.
TEST(RosBagTest, TrajectoryBagReadsBackWithTheLibrary) {
  std::vector<StampedPose2> trajectory;
  for (int k = 0; k < 5; ++k) trajectory.push_back({kT0 + 0.1 * k, Pose2(0.5 * k, -0.2 * k, 0.4 * k - 0.7)});
  const std::string path = TempPath("trajectory.bag");
  const Status status = WriteTrajectoryBag(path, trajectory, TrajectoryBagOptions());
  ASSERT_TRUE(status.ok()) << status.message();

  rosbag::Bag bag(path, rosbag::bagmode::Read);
  std::vector<geometry_msgs::PoseStamped> poses;
  std::vector<nav_msgs::Path> paths;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    if (m.getTopic() == "/hetslam/pose") poses.push_back(*m.instantiate<geometry_msgs::PoseStamped>());
    if (m.getTopic() == "/hetslam/path") {
      EXPECT_EQ(5u, poses.size()) << "the path comes last";
      paths.push_back(*m.instantiate<nav_msgs::Path>());
    }
  }
  ASSERT_EQ(5u, poses.size());
  ASSERT_EQ(1u, paths.size());
  ASSERT_EQ(5u, paths[0].poses.size());
  EXPECT_EQ("map", paths[0].header.frame_id);
  for (int k = 0; k < 5; ++k) {
    for (const geometry_msgs::PoseStamped& pose : {poses[k], paths[0].poses[k]}) {
      EXPECT_EQ("map", pose.header.frame_id);
      EXPECT_NEAR(trajectory[k].stamp_seconds, pose.header.stamp.toSec(), 1e-9);
      EXPECT_DOUBLE_EQ(trajectory[k].pose.x(), pose.pose.position.x);
      EXPECT_DOUBLE_EQ(trajectory[k].pose.y(), pose.pose.position.y);
      EXPECT_EQ(0.0, pose.pose.position.z);
      const Eigen::Quaterniond q(pose.pose.orientation.w, pose.pose.orientation.x, pose.pose.orientation.y,
                                 pose.pose.orientation.z);
      EXPECT_NEAR(trajectory[k].pose.theta(), RollPitchYawFromRotation(q.toRotationMatrix()).z(), 1e-12);
    }
  }
}

TEST(RosBagTest, TrajectoryBagRefusesStampsOutsideRosTime) {
  const Status status =
      WriteTrajectoryBag(TempPath("negative.bag"), {{-1.0, Pose2(0, 0, 0)}}, TrajectoryBagOptions());
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("negative.bag"));
}

// The shared real recording: a Hokuyo on /scan, nothing else.
TEST(RosBagTest, ReadsTheCcnyDemoBag) {
  const std::string path = SharedDatasetPath("ccny-scan-tools-demo/laser_scan_matcher_demo.bag");
  if (path.empty()) GTEST_SKIP() << "shared datasets not found at " << SharedDatasetDir();
  MeasurementLog log;
  const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(360, log.num_scans);
  EXPECT_EQ(360u, log.measurements.size());
  EXPECT_EQ("none", log.params.at("imu_topic"));
  EXPECT_EQ("identity", log.params.at("laser_mount"));  // the bag has no /tf_static
  const LaserScan& scan = std::get<LaserReading>(log.measurements.front()).scan;
  EXPECT_EQ(681u, scan.ranges_meters.size());
  EXPECT_NEAR(35.8, log.ScanDurationSeconds(), 0.1);
}

}  // namespace
}  // namespace hetslam
