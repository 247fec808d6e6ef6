// The ROS-facing half of core/ros_bag.h (see core/ros_bag_plugin.h for why it is a plugin): the
// only code of hetslam that includes ROS headers and links Debian's ROS libraries. Built into
// libhetslam_rosbag_plugin.so, which exports hetslam_rosbag_plugin_api() and nothing else
// (hidden visibility); core/ros_bag.cc checks the options before calling in here.
#include "core/ros_bag_plugin.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <memory>
#include <utility>

#include <bzlib.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include "core/euler.h"

namespace hetslam {

namespace {

constexpr char kTfStaticTopic[] = "/tf_static";
constexpr char kTfMessageType[] = "tf2_msgs/TFMessage";

struct TopicInfo {
  std::string topic;
  std::string datatype;
  uint32_t messages = 0;
};

// One kind of measurement a topic can feed.
struct KindSpec {
  const char* option;                     // the option (and program flag) that picks the topic
  std::vector<std::string> types;         // accepted message types
  std::vector<std::string> conventional;  // names preferred among several candidates
  bool required;                          // scans: a bag without them cannot be mapped
};

const KindSpec kScanKind{"scan_topic", {"sensor_msgs/LaserScan"}, {"/scan"}, true};
const KindSpec kImuKind{"imu_topic", {"sensor_msgs/Imu"}, {"/imu/data", "/imu"}, false};
const KindSpec kOdomKind{"odom_topic", {"nav_msgs/Odometry"}, {"/odom"}, false};
const KindSpec kCmdKind{"cmd_topic", {"geometry_msgs/Twist", "geometry_msgs/TwistStamped"}, {"/cmd_vel"}, false};
const KindSpec kImageKind{"image_topic", {"sensor_msgs/Image"}, {"/camera/image_raw", "/image_raw"}, false};

std::string Join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i > 0 ? separator : "") + items[i];
  return out;
}

// "/scan [sensor_msgs/LaserScan, 360 messages], /tf [tf2_msgs/TFMessage, 12 messages]".
std::string TopicList(const std::vector<TopicInfo>& topics) {
  if (topics.empty()) return "no topics";
  std::vector<std::string> items;
  for (const TopicInfo& t : topics) {
    items.push_back(t.topic + " [" + t.datatype + ", " + std::to_string(t.messages) + " messages]");
  }
  return Join(items, ", ");
}

// The topics of `bag` in name order, one entry per topic (several connections may share one).
std::vector<TopicInfo> ListTopics(const rosbag::Bag& bag) {
  std::map<std::string, TopicInfo> by_name;
  rosbag::View view(bag);
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    TopicInfo& info = by_name[c->topic];
    info.topic = c->topic;
    info.datatype = c->datatype;
  }
  for (auto& [name, info] : by_name) info.messages = rosbag::View(bag, rosbag::TopicQuery(name)).size();
  std::vector<TopicInfo> topics;
  for (auto& entry : by_name) topics.push_back(entry.second);
  return topics;
}

bool Accepts(const KindSpec& kind, const std::string& datatype) {
  return std::find(kind.types.begin(), kind.types.end(), datatype) != kind.types.end();
}

// Picks the topic of `kind` (see the header); *topic = "" when none is read.
Status ChooseTopic(const std::string& path, const std::string& requested, const KindSpec& kind,
                   const std::vector<TopicInfo>& topics, std::string* topic, std::vector<std::string>* notes) {
  topic->clear();
  const std::string types = Join(kind.types, " or ");
  if (requested == "none") return Status::Ok();
  if (!requested.empty()) {
    // "scan" names "/scan" too: ROS 1 topics are global.
    const std::string global = requested[0] == '/' ? requested : "/" + requested;
    for (const TopicInfo& t : topics) {
      if (t.topic != requested && t.topic != global) continue;
      if (!Accepts(kind, t.datatype)) {
        return Status::Error(path + ": topic '" + requested + "' holds " + t.datatype + " messages, but " +
                             kind.option + " needs " + types + " (the bag has: " + TopicList(topics) + ")");
      }
      *topic = t.topic;
      return Status::Ok();
    }
    return Status::Error(path + ": no topic '" + requested + "' (" + kind.option + "); the bag has: " +
                         TopicList(topics));
  }
  std::vector<std::string> candidates;
  for (const TopicInfo& t : topics) {
    if (Accepts(kind, t.datatype)) candidates.push_back(t.topic);
  }
  if (candidates.size() == 1) {
    *topic = candidates.front();
    return Status::Ok();
  }
  if (candidates.empty()) {
    if (!kind.required) return Status::Ok();
    return Status::Error(path + ": no " + types + " topic, so no laser scans to map; the bag has: " +
                         TopicList(topics));
  }
  for (const std::string& name : kind.conventional) {
    if (std::find(candidates.begin(), candidates.end(), name) != candidates.end()) {
      *topic = name;
      notes->push_back(path + ": several " + types + " topics (" + Join(candidates, ", ") + "); reading " + name +
                       " (choose another with " + kind.option + ")");
      return Status::Ok();
    }
  }
  const std::string several = "several " + types + " topics (" + Join(candidates, ", ") + ")";
  if (kind.required) return Status::Error(path + ": " + several + "; choose one with " + kind.option);
  notes->push_back(path + ": " + several + ", none read; choose one with " + kind.option);
  return Status::Ok();
}

std::string StripLeadingSlashes(std::string frame) {
  const size_t start = frame.find_first_not_of('/');
  return start == std::string::npos ? std::string() : frame.substr(start);
}

Eigen::Quaterniond ToEigen(const geometry_msgs::Quaternion& q) { return Eigen::Quaterniond(q.w, q.x, q.y, q.z); }

// The static transforms of a bag: child frame -> (parent frame, parent_T_child).
class StaticTransforms {
 public:
  void Add(const tf2_msgs::TFMessage& message) {
    for (const geometry_msgs::TransformStamped& t : message.transforms) {
      const Eigen::Quaterniond q = ToEigen(t.transform.rotation);
      if (!(q.norm() > 0.5) || !std::isfinite(q.norm())) continue;  // unusable; the lookup then fails
      Eigen::Isometry3d parent_T_child = Eigen::Isometry3d::Identity();
      parent_T_child.linear() = q.normalized().toRotationMatrix();
      parent_T_child.translation() =
          Eigen::Vector3d(t.transform.translation.x, t.transform.translation.y, t.transform.translation.z);
      if (!parent_T_child.matrix().allFinite()) continue;
      parents_[StripLeadingSlashes(t.child_frame_id)] = {StripLeadingSlashes(t.header.frame_id), parent_T_child};
    }
  }

  // base_T_frame by walking from `frame` up its parents to `base`; false when not connected.
  bool Lookup(const std::string& base, const std::string& frame, Eigen::Isometry3d* base_T_frame) const {
    Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
    std::string current = frame;
    for (size_t step = 0; step <= parents_.size(); ++step) {  // bounded: a cycle ends the walk
      if (current == base) {
        *base_T_frame = transform;
        return true;
      }
      const auto it = parents_.find(current);
      if (it == parents_.end()) return false;
      transform = it->second.second * transform;
      current = it->second.first;
    }
    return false;
  }

 private:
  std::map<std::string, std::pair<std::string, Eigen::Isometry3d>> parents_;
};

double SecondsOf(const ros::Time& header_stamp, const rosbag::MessageInstance& m) {
  return header_stamp.isZero() ? m.getTime().toSec() : header_stamp.toSec();
}

// Converts one image to 8-bit grey rows (width * height bytes); an error text when the encoding
// is not handled or the data is short.
std::string ImageToGrey(const sensor_msgs::Image& image, std::vector<uint8_t>* grey) {
  int channels = 0, bytes_per_channel = 1;
  int r = 0, g = 0, b = 0;  // channel index of red, green, blue
  const std::string& e = image.encoding;
  if (e == "mono8" || e == "8UC1") {
    channels = 1;
  } else if (e == "mono16" || e == "16UC1") {
    channels = 1;
    bytes_per_channel = 2;
  } else if (e == "rgb8" || e == "rgba8") {
    channels = e == "rgb8" ? 3 : 4;
    r = 0, g = 1, b = 2;
  } else if (e == "bgr8" || e == "bgra8") {
    channels = e == "bgr8" ? 3 : 4;
    r = 2, g = 1, b = 0;
  } else {
    return "image encoding '" + e + "' is not handled (mono8, mono16, rgb8, bgr8, rgba8, bgra8 are)";
  }
  const uint64_t row_bytes = uint64_t{image.width} * channels * bytes_per_channel;
  if (image.width == 0 || image.height == 0 || image.step < row_bytes ||
      image.data.size() < uint64_t{image.step} * image.height) {
    return "image data is shorter than its " + std::to_string(image.width) + " x " + std::to_string(image.height) +
           " " + e + " size";
  }
  grey->resize(size_t{image.width} * image.height);
  for (uint32_t row = 0; row < image.height; ++row) {
    const uint8_t* in = image.data.data() + size_t{row} * image.step;
    for (uint32_t col = 0; col < image.width; ++col) {
      const uint8_t* px = in + size_t{col} * channels * bytes_per_channel;
      uint8_t value;
      if (channels == 1 && bytes_per_channel == 2) {
        value = image.is_bigendian ? px[0] : px[1];  // the high byte
      } else if (channels == 1) {
        value = px[0];
      } else {
        value = static_cast<uint8_t>(std::lround(0.299 * px[r] + 0.587 * px[g] + 0.114 * px[b]));
      }
      (*grey)[size_t{row} * image.width + col] = value;
    }
  }
  return "";
}

// The record structure of a ROS bag 2.0 file, checked before rosbag_storage opens it. The
// library trusts the lengths in the file: a header field longer than its header is read past
// the buffer, and a record's header length is allocated before it is compared with the file
// (issue #16; tests/fuzz/known_failures/ros_bag: heap overreads, a segfault, a 2.3 GB
// allocation; a message read at an index offset outside its chunk). Every record the library
// reads on opening (the bag header, the connection and chunk-info records, each chunk's header
// and the index records after it) and the records inside every chunk are checked here:
// header and data lengths within the file (or the chunk), every header field (4-byte length,
// "name=value") within its header, a connection's data (a header too) likewise, positions
// within the file, index offsets within the chunk and at one of its records. A compressed (bz2,
// lz4) chunk is decompressed here first, with the same libraries rosbag_storage uses, and its
// records are walked in the decompressed bytes: a chunk whose claimed size is over
// kMaxChunkBytes, whose data does not decompress, or decompresses to another length than its
// size is refused.
class BagRecordCheck {
 public:
  explicit BagRecordCheck(const std::string& path) : path_(path) {}

  // In the order rosbag_storage reads a bag when it opens it: the bag header, the connection
  // and chunk-info records at the index position, then per chunk its header, its records
  // (decompressed first when the chunk is compressed) and the connection index records that
  // follow it.
  Status Run() {
    in_.open(path_, std::ios::binary);
    if (!in_) return Status::Error(path_ + ": cannot open the ROS bag");
    in_.seekg(0, std::ios::end);
    size_ = static_cast<uint64_t>(in_.tellg());
    static const std::string kMagic = "#ROSBAG V2.0\n";
    std::string magic(kMagic.size(), '\0');
    in_.seekg(0);
    if (size_ < kMagic.size() || !in_.read(&magic[0], magic.size()) || magic != kMagic) {
      return Status::Error(path_ + ": not a ROS bag 2.0 file (no '#ROSBAG V2.0' line at the start)");
    }
    Record header;
    HETSLAM_RETURN_IF_ERROR(Read(kMagic.size(), size_, &header));
    uint64_t index_pos = 0;
    uint32_t connections = 0, chunks = 0;
    if (header.op != 0x03 || !Field(header, "index_pos", &index_pos) || !Field(header, "conn_count", &connections) ||
        !Field(header, "chunk_count", &chunks)) {
      return Bad(header.pos, "no bag header (op 3 with index_pos, conn_count and chunk_count)");
    }
    // A bag whose recording was cut has index_pos 0: the library reports it unindexed.
    if (index_pos == 0) return Status::Ok();
    if (index_pos < header.end || index_pos > size_) return Bad(header.pos, "an index position outside the file");
    uint64_t pos = index_pos;
    for (uint32_t k = 0; k < connections; ++k) {
      Record connection;
      HETSLAM_RETURN_IF_ERROR(Read(pos, size_, &connection));
      pos = connection.end;
    }
    for (uint32_t k = 0; k < chunks; ++k) {
      Record info;
      HETSLAM_RETURN_IF_ERROR(Read(pos, size_, &info));
      pos = info.end;
      uint64_t chunk_pos = 0;
      uint32_t chunk_connections = 0;
      if (info.op != 0x06 || !Field(info, "chunk_pos", &chunk_pos) || !Field(info, "count", &chunk_connections)) {
        return Bad(info.pos, "no chunk info (op 6 with chunk_pos and count)");
      }
      if (chunk_pos < header.end || chunk_pos >= size_) return Bad(info.pos, "a chunk position outside the file");
      Record chunk;
      HETSLAM_RETURN_IF_ERROR(Read(chunk_pos, size_, &chunk));
      const auto compression = chunk.fields.find("compression");
      uint32_t uncompressed_size = 0;
      if (chunk.op != 0x05 || compression == chunk.fields.end() || !Field(chunk, "size", &uncompressed_size)) {
        return Bad(chunk.pos, "no chunk header (op 5 with compression and size)");
      }
      // Offsets (within the uncompressed chunk) where its records start: what the index
      // entries below must point at.
      std::set<uint32_t> starts;
      if (compression->second == "none") {
        if (chunk.end - chunk.data != uncompressed_size) return Bad(chunk.pos, "a size other than its data's");
        for (uint64_t at = chunk.data; at < chunk.end;) {
          Record inner;
          HETSLAM_RETURN_IF_ERROR(Read(at, chunk.end, &inner));
          starts.insert(static_cast<uint32_t>(at - chunk.data));
          at = inner.end;
        }
      } else {
        HETSLAM_RETURN_IF_ERROR(CheckCompressedChunk(chunk, compression->second, uncompressed_size, &starts));
      }
      // The connection index records after the chunk: (time, offset) entries of 12 bytes whose
      // offsets the library reads messages at.
      uint64_t at = chunk.end;
      for (uint32_t c = 0; c < chunk_connections; ++c) {
        Record index;
        HETSLAM_RETURN_IF_ERROR(Read(at, size_, &index));
        uint32_t version = 0, count = 0;
        // The library reads `count` entries and the next record right after them, whatever the
        // record's data length says (the shared ccny bag has 5560 bytes for 278 entries).
        if (index.op != 0x04 || !Field(index, "ver", &version) || version != 1 || !Field(index, "count", &count) ||
            index.end - index.data < uint64_t{count} * 12) {
          return Bad(index.pos, "no index data (op 4, version 1, 12 bytes per entry)");
        }
        std::string entries(uint64_t{count} * 12, '\0');
        if (!entries.empty() && !ReadBytes(index.data, entries.size(), &entries[0])) {
          return Truncated(index.pos, "its entries");
        }
        for (uint32_t e = 0; e < count; ++e) {
          uint32_t offset = 0;
          std::memcpy(&offset, entries.data() + 12 * e + 8, 4);
          if (offset >= uncompressed_size || starts.count(offset) == 0) {
            return Bad(index.pos, "an index entry pointing at byte " + std::to_string(offset) +
                                      ", not at a record of its chunk (" + std::to_string(uncompressed_size) +
                                      " bytes)");
          }
        }
        at = index.data + entries.size();
      }
    }
    return Status::Ok();
  }

 private:
  // The largest uncompressed chunk accepted: rosbag writes chunks of about 768 KB by default
  // (its chunk threshold), and both this check and the library hold one whole chunk in memory.
  static constexpr uint64_t kMaxChunkBytes = uint64_t{1} << 30;

  struct Record {
    uint64_t pos = 0;   // first byte
    uint64_t data = 0;  // first byte of the data
    uint64_t end = 0;   // one past the last byte
    uint8_t op = 0;
    std::map<std::string, std::string> fields;
  };

  // Decompresses the `compression` chunk `chunk` (whose header claims `size` uncompressed bytes)
  // and walks its records; *starts receives the offset of each. The claimed size is bounded
  // before anything is allocated, and the buffer is not filled beforehand, so a chunk that
  // claims much more than its data holds costs only the pages the decompressor writes.
  Status CheckCompressedChunk(const Record& chunk, const std::string& compression, uint32_t size,
                              std::set<uint32_t>* starts) {
    if (compression != "bz2" && compression != "lz4") {
      return Bad(chunk.pos, "an unknown compression '" + compression + "' (none, bz2 or lz4 are known)");
    }
    if (size > kMaxChunkBytes) {
      return Bad(chunk.pos, "an uncompressed size of " + std::to_string(size) + " bytes, over the " +
                                std::to_string(kMaxChunkBytes) + " bytes accepted for one chunk");
    }
    const uint64_t compressed_size = chunk.end - chunk.data;
    std::unique_ptr<char[]> compressed(new char[std::max<uint64_t>(compressed_size, 1)]);
    if (!ReadBytes(chunk.data, compressed_size, compressed.get())) return Truncated(chunk.pos, "its data");
    // One spare byte: data that decompresses to more than `size` then fills it (or overflows)
    // and is told apart from data of exactly `size` bytes.
    std::unique_ptr<char[]> bytes(new char[uint64_t{size} + 1]);
    unsigned int length = size + 1;
    int result = 0;
    bool decompressed = false;
    if (compression == "bz2") {
      result = BZ2_bzBuffToBuffDecompress(bytes.get(), &length, compressed.get(),
                                          static_cast<unsigned int>(compressed_size), /*small=*/0, /*verbosity=*/0);
      decompressed = result == BZ_OK;
    } else {
      result = roslz4_buffToBuffDecompress(compressed.get(), static_cast<unsigned int>(compressed_size), bytes.get(),
                                           &length);
      decompressed = result == ROSLZ4_OK;
    }
    const std::string what = compression + " data";
    if (!decompressed) {
      // BZ_OUTBUFF_FULL (-8) and ROSLZ4_OUTPUT_SMALL (-2): more than the claimed size.
      const bool longer = (compression == "bz2" && result == BZ_OUTBUFF_FULL) ||
                          (compression == "lz4" && result == ROSLZ4_OUTPUT_SMALL);
      if (longer) return Bad(chunk.pos, what + " that decompresses to more than its size of " + std::to_string(size) +
                                          " bytes");
      return Bad(chunk.pos, what + " that does not decompress (" +
                                (compression == "bz2" ? "libbz2" : "roslz4") + " error " + std::to_string(result) + ")");
    }
    if (length != size) {
      return Bad(chunk.pos, what + " that decompresses to " + std::to_string(length) + " bytes, not its size of " +
                                std::to_string(size));
    }
    chunk_pos_ = chunk.pos;
    chunk_compression_ = compression;
    chunk_bytes_ = bytes.get();
    chunk_size_ = size;
    Status status = Status::Ok();
    for (uint64_t at = 0; at < size && status.ok();) {
      Record inner;
      status = Read(at, size, &inner);
      if (status.ok()) starts->insert(static_cast<uint32_t>(at));
      at = inner.end;
    }
    chunk_bytes_ = nullptr;  // back to the file
    chunk_size_ = 0;
    return status;
  }

  // The record at `pos`, within `end`: its header fields, and a connection's data (a header too).
  // Positions are in the bytes being walked: the file, or the decompressed chunk while
  // CheckCompressedChunk walks it.
  Status Read(uint64_t pos, uint64_t end, Record* record) {
    record->pos = pos;
    uint64_t header_length = 0;
    HETSLAM_RETURN_IF_ERROR(Header(pos, end, &header_length, &record->fields));
    uint32_t data_length = 0;
    if (!ReadU32(pos + 4 + header_length, &data_length)) return Truncated(pos, "its data length");
    record->data = pos + 8 + header_length;
    record->end = record->data + data_length;
    if (record->end > end) return Truncated(pos, "its data (" + std::to_string(data_length) + " bytes)");
    const auto op = record->fields.find("op");
    if (op == record->fields.end() || op->second.size() != 1) return Bad(pos, "no one-byte op field");
    record->op = static_cast<uint8_t>(op->second[0]);
    if (record->op == 0x07) {
      std::map<std::string, std::string> connection;
      HETSLAM_RETURN_IF_ERROR(HeaderBytes(record->data, data_length, pos, &connection));
    }
    return Status::Ok();
  }

  template <typename T>
  static bool Field(const Record& record, const std::string& name, T* value) {
    const auto it = record.fields.find(name);
    if (it == record.fields.end() || it->second.size() != sizeof(T)) return false;
    std::memcpy(value, it->second.data(), sizeof(T));
    return true;
  }

  // The header of the record at `pos` (its 4-byte length, then the fields), within `end`.
  Status Header(uint64_t pos, uint64_t end, uint64_t* header_length, std::map<std::string, std::string>* fields) {
    uint32_t length = 0;
    if (pos + 4 > end || !ReadU32(pos, &length)) return Truncated(pos, "its header length");
    if (pos + 4 + length + 4 > end) return Truncated(pos, "its header (" + std::to_string(length) + " bytes)");
    *header_length = length;
    return HeaderBytes(pos + 4, length, pos, fields);
  }

  // Fields of a header of `length` bytes at `at`, of the record at `record` (for messages).
  Status HeaderBytes(uint64_t at, uint64_t length, uint64_t record, std::map<std::string, std::string>* fields) {
    constexpr uint64_t kMaxHeaderBytes = 64u << 20;  // far above any real header
    if (length > kMaxHeaderBytes) return Bad(record, "a header of " + std::to_string(length) + " bytes");
    std::string bytes(length, '\0');
    if (length > 0 && !ReadBytes(at, length, &bytes[0])) return Truncated(record, "its header");
    uint64_t k = 0;
    while (k < length) {
      if (k + 4 > length) return Bad(record, "a header field length cut by the end of its header");
      uint32_t field_length = 0;
      std::memcpy(&field_length, bytes.data() + k, 4);
      k += 4;
      if (field_length > length - k) {
        return Bad(record, "a header field of " + std::to_string(field_length) + " bytes in a header of " +
                               std::to_string(length));
      }
      const std::string field = bytes.substr(k, field_length);
      const size_t equals = field.find('=');
      if (equals == std::string::npos) return Bad(record, "a header field without '='");
      (*fields)[field.substr(0, equals)] = field.substr(equals + 1);
      k += field_length;
    }
    return Status::Ok();
  }

  bool ReadU32(uint64_t at, uint32_t* value) {
    unsigned char b[4];
    if (!ReadBytes(at, 4, reinterpret_cast<char*>(b))) return false;
    *value = uint32_t{b[0]} | uint32_t{b[1]} << 8 | uint32_t{b[2]} << 16 | uint32_t{b[3]} << 24;
    return true;
  }

  // `n` bytes at `at` of the bytes being walked: the decompressed chunk when there is one, else
  // the file.
  bool ReadBytes(uint64_t at, uint64_t n, char* out) {
    if (chunk_bytes_ != nullptr) {
      if (at > chunk_size_ || n > chunk_size_ - at) return false;
      std::memcpy(out, chunk_bytes_ + at, n);
      return true;
    }
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(at));
    return static_cast<bool>(in_.read(out, static_cast<std::streamsize>(n)));
  }

  // "the record at byte 4117", or inside a decompressed chunk "the record at byte 96 of the lz4
  // chunk at byte 4117 (decompressed)".
  std::string RecordAt(uint64_t record) const {
    std::string where = "the record at byte " + std::to_string(record);
    if (chunk_bytes_ != nullptr) {
      where += " of the " + chunk_compression_ + " chunk at byte " + std::to_string(chunk_pos_) + " (decompressed, " +
               std::to_string(chunk_size_) + " bytes)";
    }
    return where;
  }

  Status Truncated(uint64_t record, const std::string& what) {
    return Status::Error(path_ + ": the ROS bag's " + RecordAt(record).substr(4) +
                         " runs past the end of its file or chunk with " + what + " (the file has " +
                         std::to_string(size_) + " bytes: truncated or corrupt; a truncated recording may be "
                         "repaired with `rosbag reindex`)");
  }
  Status Bad(uint64_t record, const std::string& what) {
    return Status::Error(path_ + ": corrupt ROS bag: " + RecordAt(record) + " has " + what);
  }

  const std::string path_;
  std::ifstream in_;
  uint64_t size_ = 0;
  // While CheckCompressedChunk walks a decompressed chunk: its bytes, size, position in the file
  // and compression.
  const char* chunk_bytes_ = nullptr;
  uint64_t chunk_size_ = 0;
  uint64_t chunk_pos_ = 0;
  std::string chunk_compression_;
};

// Walks the lengths of a serialized ROS 1 message: a uint32 length precedes every string and
// variable-length array.
class SerializedWalker {
 public:
  explicit SerializedWalker(const std::vector<uint8_t>& bytes) : bytes_(bytes) {}
  bool Fixed(uint64_t n) {
    if (n > bytes_.size() - at_) return false;
    at_ += n;
    return true;
  }
  // A string or array of `element_bytes` per element.
  bool Array(uint64_t element_bytes, uint32_t* count = nullptr) {
    uint32_t n = 0;
    if (4 > bytes_.size() - at_) return false;
    std::memcpy(&n, bytes_.data() + at_, 4);
    at_ += 4;
    if (count != nullptr) *count = n;
    return Fixed(uint64_t{n} * element_bytes);
  }
  bool Header() { return Fixed(12) && Array(1); }  // seq, stamp; frame_id

 private:
  const std::vector<uint8_t>& bytes_;
  uint64_t at_ = 0;
};

// "" when every length inside the serialized message `bytes` of `datatype` fits in the
// message, else why not. roscpp's deserializer resizes a string or array to the length the
// message claims before it checks that the bytes are there: a LaserScan claiming 1.8e9 ranges
// allocated 7.3 GB (the ros_bag fuzzer, issue #16). Only the types this reader instantiates.
std::string SerializedLengthsError(const std::string& datatype, const std::vector<uint8_t>& bytes) {
  SerializedWalker w(bytes);
  bool fits = true;
  if (datatype == "sensor_msgs/LaserScan") {
    fits = w.Header() && w.Fixed(7 * 4) && w.Array(4) && w.Array(4);  // 7 float32; ranges, intensities
  } else if (datatype == "sensor_msgs/Imu") {
    fits = w.Header() && w.Fixed(32 + 72 + 24 + 72 + 24 + 72);
  } else if (datatype == "nav_msgs/Odometry") {
    fits = w.Header() && w.Array(1) && w.Fixed(344 + 336);  // child_frame_id; pose, twist with covariances
  } else if (datatype == "geometry_msgs/Twist") {
    fits = w.Fixed(48);
  } else if (datatype == "geometry_msgs/TwistStamped") {
    fits = w.Header() && w.Fixed(48);
  } else if (datatype == "sensor_msgs/Image") {
    fits = w.Header() && w.Fixed(8) && w.Array(1) && w.Fixed(5) && w.Array(1);  // size; encoding; endian, step; data
  } else if (datatype == "tf2_msgs/TFMessage") {
    uint32_t transforms = 0;
    fits = w.Array(0, &transforms);
    for (uint32_t k = 0; fits && k < transforms; ++k) fits = w.Header() && w.Array(1) && w.Fixed(56);
  }
  if (fits) return "";
  return "a string or array length longer than the message's " + std::to_string(bytes.size()) + " bytes";
}

// Reads one bag; exceptions of the library propagate to ReadRosBag, which turns them into a
// Status.
class BagReader {
 public:
  BagReader(const std::string& path, const RosBagReadOptions& options, RosBagContents* contents)
      : path_(path), options_(options), contents_(contents) {}

  Status Read() {
    HETSLAM_RETURN_IF_ERROR(BagRecordCheck(path_).Run());
    rosbag::Bag bag;
    bag.open(path_, rosbag::bagmode::Read);
    const std::vector<TopicInfo> topics = ListTopics(bag);
    std::vector<std::string> notes;
    HETSLAM_RETURN_IF_ERROR(ChooseTopic(path_, options_.scan_topic, kScanKind, topics, &scan_topic_, &notes));
    HETSLAM_RETURN_IF_ERROR(ChooseTopic(path_, options_.imu_topic, kImuKind, topics, &imu_topic_, &notes));
    HETSLAM_RETURN_IF_ERROR(ChooseTopic(path_, options_.odom_topic, kOdomKind, topics, &odom_topic_, &notes));
    HETSLAM_RETURN_IF_ERROR(ChooseTopic(path_, options_.cmd_topic, kCmdKind, topics, &cmd_topic_, &notes));
    if (!options_.image_directory.empty()) {
      HETSLAM_RETURN_IF_ERROR(ChooseTopic(path_, options_.image_topic, kImageKind, topics, &image_topic_, &notes));
      std::error_code ec;
      std::filesystem::create_directories(options_.image_directory, ec);
      if (ec) return Status::Error("cannot create image folder '" + options_.image_directory + "': " + ec.message());
    }
    for (const std::string& note : notes) Warn(note);
    for (const TopicInfo& t : topics) {
      if (t.topic == kTfStaticTopic && t.datatype == kTfMessageType) has_tf_static_ = true;
    }
    auto& params = contents_->params;
    params["scan_topic"] = scan_topic_;
    params["imu_topic"] = imu_topic_.empty() ? "none" : imu_topic_;
    params["odom_topic"] = odom_topic_.empty() ? "none" : odom_topic_;
    params["cmd_topic"] = cmd_topic_.empty() ? "none" : cmd_topic_;
    params["image_topic"] = image_topic_.empty() ? "none" : image_topic_;

    // Static transforms first: a laser's mount may be latched after its first scans.
    if (has_tf_static_) {
      rosbag::View tf_view(bag, rosbag::TopicQuery(kTfStaticTopic));
      for (const rosbag::MessageInstance& m : tf_view) {
        if (const auto tf = Instantiate<tf2_msgs::TFMessage>(m)) transforms_.Add(*tf);
      }
    }

    // One pass over every message, so that a message's number is its position in the bag.
    rosbag::View view(bag);
    int number = 0;
    for (const rosbag::MessageInstance& m : view) {
      ++number;
      const std::string& topic = m.getTopic();
      Status status;
      if (topic == scan_topic_) {
        status = AddScan(m, number);
      } else if (topic == imu_topic_) {
        status = AddImu(m, number);
      } else if (topic == odom_topic_) {
        status = AddOdometry(m, number);
      } else if (topic == cmd_topic_) {
        status = AddCommand(m, number);
      } else if (topic == image_topic_) {
        status = AddImage(m, number);
      }
      if (!status.ok()) return status;
    }
    bag.close();
    if (contents_->lasers.empty()) {
      return Status::Error(path_ + ": topic '" + scan_topic_ + "' holds no usable laser scans (the bag has: " +
                           TopicList(topics) + ")");
    }
    return Status::Ok();
  }

 private:
  std::string Where(int number, const rosbag::MessageInstance& m) const {
    return path_ + ": message " + std::to_string(number) + " (" + m.getTopic() + ")";
  }

  // Each kind keeps the bag's order (ReadMeasurementLog does not re-sort a kind); a header stamp
  // before its predecessor's is reported once per topic.
  void CheckOrder(const rosbag::MessageInstance& m, int number, double stamp_seconds) {
    auto [it, inserted] = last_stamps_.emplace(m.getTopic(), stamp_seconds);
    if (inserted) return;
    if (stamp_seconds < it->second && backwards_reported_.emplace(m.getTopic(), true).second) {
      Warn(Where(number, m) + ": header stamp " + std::to_string(stamp_seconds) + " is before the previous one's (" +
           std::to_string(it->second) + "); kept in bag order");
    }
    it->second = stamp_seconds;
  }

  void Warn(const std::string& text) {
    if (static_cast<int>(contents_->warnings.size()) < options_.max_warnings_kept) contents_->warnings.push_back(text);
  }

  // A message that cannot be used: skipped with a count when lenient, else the read's error.
  Status Bad(int number, const rosbag::MessageInstance& m, const std::string& why) {
    const std::string text = Where(number, m) + ": " + why;
    if (!options_.lenient) return Status::Error(text);
    ++contents_->malformed_messages_skipped;
    Warn(text);
    return Status::Ok();
  }

  template <typename Message>
  boost::shared_ptr<Message> Instantiate(const rosbag::MessageInstance& m) {
    layout_error_.clear();
    // Another md5sum: the library's answer (null for a type this build does not know).
    if (m.getMD5Sum() != ros::message_traits::MD5Sum<Message>::value()) return m.instantiate<Message>();
    // The message's bytes, read once: the lengths inside them checked first
    // (SerializedLengthsError), then deserialized from the same bytes.
    std::vector<uint8_t> bytes(m.size());
    ros::serialization::OStream out(bytes.data(), static_cast<uint32_t>(bytes.size()));
    m.write(out);
    layout_error_ = SerializedLengthsError(ros::message_traits::DataType<Message>::value(), bytes);
    if (!layout_error_.empty()) return nullptr;
    auto message = boost::make_shared<Message>();
    ros::serialization::IStream in(bytes.data(), static_cast<uint32_t>(bytes.size()));
    ros::serialization::deserialize(in, *message);
    return message;
  }

  Status WrongType(int number, const rosbag::MessageInstance& m, const char* expected) {
    if (!layout_error_.empty()) return Bad(number, m, layout_error_);
    return Bad(number, m,
               "holds " + m.getDataType() + " (md5 " + m.getMD5Sum() + "), which is not the " + expected +
                   " this build knows");
  }

  // The mount of `frame` in base_frame from /tf_static, cached per frame; identity (with one
  // warning) when /tf_static does not connect them. *found (optional) says which.
  Eigen::Isometry3d MountOf(const std::string& raw_frame, const char* what, bool* found = nullptr) {
    const std::string frame = StripLeadingSlashes(raw_frame);
    auto cached = mounts_.find(frame);
    if (cached == mounts_.end()) {
      Eigen::Isometry3d base_T_frame = Eigen::Isometry3d::Identity();
      const std::string base = StripLeadingSlashes(options_.base_frame);
      const bool connected = transforms_.Lookup(base, frame, &base_T_frame);
      if (!connected) {
        Warn(path_ + ": no /tf_static transform from '" + base + "' to the " + what + " frame '" + frame +
             "': the " + what + " is taken as mounted at the body origin, level and facing forward");
      }
      cached = mounts_.emplace(frame, std::make_pair(base_T_frame, connected)).first;
    }
    if (found != nullptr) *found = cached->second.second;
    return cached->second.first;
  }

  Status AddScan(const rosbag::MessageInstance& m, int number) {
    const auto msg = Instantiate<sensor_msgs::LaserScan>(m);
    if (msg == nullptr) return WrongType(number, m, "sensor_msgs/LaserScan");
    if (!(std::isfinite(msg->angle_min) && std::isfinite(msg->angle_increment) && msg->angle_increment != 0.0f)) {
      return Bad(number, m, "angle_min " + std::to_string(msg->angle_min) + " / angle_increment " +
                                std::to_string(msg->angle_increment) + " do not define the beam angles");
    }
    if (msg->ranges.empty()) return Bad(number, m, "scan has no ranges");
    if (!(std::isfinite(msg->range_max) && msg->range_max > msg->range_min && msg->range_min >= 0.0f)) {
      return Bad(number, m, "range_min " + std::to_string(msg->range_min) + " / range_max " +
                                std::to_string(msg->range_max) + " are not a valid interval");
    }
    LaserReading reading;
    reading.line_number = number;
    LaserScan& scan = reading.scan;
    scan.stamp_seconds = SecondsOf(msg->header.stamp, m);
    scan.angles_radians = EvenlySpacedAngles(static_cast<int>(msg->ranges.size()), msg->angle_min, msg->angle_increment);
    scan.ranges_meters.assign(msg->ranges.begin(), msg->ranges.end());
    scan.range_min_meters = msg->range_min;
    scan.range_max_meters = msg->range_max;
    bool from_tf_static = false;
    scan.robot_T_sensor = options_.robot_T_laser.has_value() ? *options_.robot_T_laser
                                                             : MountOf(msg->header.frame_id, "laser", &from_tf_static);
    if (contents_->params.count("laser_frame") == 0) {
      contents_->params["laser_frame"] = StripLeadingSlashes(msg->header.frame_id);
      contents_->params["laser_mount"] =
          options_.robot_T_laser.has_value() ? "options" : (from_tf_static ? "tf_static" : "identity");
    }
    CheckOrder(m, number, scan.stamp_seconds);
    contents_->lasers.push_back(std::move(reading));
    return Status::Ok();
  }

  Status AddImu(const rosbag::MessageInstance& m, int number) {
    const auto msg = Instantiate<sensor_msgs::Imu>(m);
    if (msg == nullptr) return WrongType(number, m, "sensor_msgs/Imu");
    const Eigen::Matrix3d base_R_imu = MountOf(msg->header.frame_id, "IMU").linear();
    MargSample sample;
    sample.line_number = number;
    sample.stamp_seconds = SecondsOf(msg->header.stamp, m);
    const auto& w = msg->angular_velocity;
    const auto& a = msg->linear_acceleration;
    sample.gyro_radps = base_R_imu * Eigen::Vector3d(w.x, w.y, w.z);
    sample.accel_mps2 = base_R_imu * Eigen::Vector3d(a.x, a.y, a.z);
    sample.has_magnetometer = false;
    if (!(sample.gyro_radps.allFinite() && sample.accel_mps2.allFinite())) {
      return Bad(number, m, "angular_velocity or linear_acceleration is not finite");
    }
    // orientation_covariance[0] == -1 means "no orientation estimate" (sensor_msgs/Imu).
    if (msg->orientation_covariance[0] != -1.0) {
      const Eigen::Quaterniond world_q_imu = ToEigen(msg->orientation);
      if (std::isfinite(world_q_imu.norm()) && world_q_imu.norm() > 0.5) {
        const Eigen::Matrix3d world_R_base = world_q_imu.normalized().toRotationMatrix() * base_R_imu.transpose();
        const Eigen::Vector3d rpy = RollPitchYawFromRotation(world_R_base);
        AttitudeReading attitude;
        attitude.stamp_seconds = sample.stamp_seconds;
        attitude.roll_radians = rpy.x();
        attitude.pitch_radians = rpy.y();
        attitude.yaw_radians = rpy.z();
        attitude.line_number = number;
        contents_->attitudes.push_back(attitude);
      }
    }
    CheckOrder(m, number, sample.stamp_seconds);
    contents_->marg.push_back(sample);
    return Status::Ok();
  }

  Status AddOdometry(const rosbag::MessageInstance& m, int number) {
    const auto msg = Instantiate<nav_msgs::Odometry>(m);
    if (msg == nullptr) return WrongType(number, m, "nav_msgs/Odometry");
    const Eigen::Quaterniond q = ToEigen(msg->pose.pose.orientation);
    if (!(std::isfinite(q.norm()) && q.norm() > 0.5 && std::isfinite(msg->pose.pose.position.x) &&
          std::isfinite(msg->pose.pose.position.y))) {
      return Bad(number, m, "odometry pose is not finite or its quaternion is not a rotation");
    }
    OdometryReading reading;
    reading.line_number = number;
    reading.stamp_seconds = SecondsOf(msg->header.stamp, m);
    const double yaw = RollPitchYawFromRotation(q.normalized().toRotationMatrix()).z();
    reading.pose = Pose2(msg->pose.pose.position.x, msg->pose.pose.position.y, yaw);
    CheckOrder(m, number, reading.stamp_seconds);
    contents_->odometry.push_back(reading);
    return Status::Ok();
  }

  Status AddCommand(const rosbag::MessageInstance& m, int number) {
    VelocityCommand command;
    command.line_number = number;
    const geometry_msgs::Twist* twist = nullptr;
    boost::shared_ptr<geometry_msgs::Twist> bare;
    boost::shared_ptr<geometry_msgs::TwistStamped> stamped;
    if (m.getDataType() == "geometry_msgs/TwistStamped") {
      stamped = Instantiate<geometry_msgs::TwistStamped>(m);
      if (stamped == nullptr) return WrongType(number, m, "geometry_msgs/TwistStamped");
      twist = &stamped->twist;
      command.stamp_seconds = SecondsOf(stamped->header.stamp, m);
    } else {
      bare = Instantiate<geometry_msgs::Twist>(m);
      if (bare == nullptr) return WrongType(number, m, "geometry_msgs/Twist");
      twist = bare.get();
      command.stamp_seconds = m.getTime().toSec();  // a Twist has no header
    }
    command.forward_mps = twist->linear.x;
    command.left_mps = twist->linear.y;
    command.yaw_rate_radps = twist->angular.z;
    if (!(std::isfinite(command.forward_mps) && std::isfinite(command.left_mps) &&
          std::isfinite(command.yaw_rate_radps))) {
      return Bad(number, m, "command velocity is not finite");
    }
    CheckOrder(m, number, command.stamp_seconds);
    contents_->commands.push_back(command);
    return Status::Ok();
  }

  Status AddImage(const rosbag::MessageInstance& m, int number) {
    const auto msg = Instantiate<sensor_msgs::Image>(m);
    if (msg == nullptr) return WrongType(number, m, "sensor_msgs/Image");
    std::vector<uint8_t> grey;
    const std::string why = ImageToGrey(*msg, &grey);
    if (!why.empty()) return Bad(number, m, why);
    char name[32];
    std::snprintf(name, sizeof(name), "%08d.pgm", number);
    CameraImage image;
    image.line_number = number;
    image.stamp_seconds = SecondsOf(msg->header.stamp, m);
    image.path = (std::filesystem::path(options_.image_directory) / name).string();
    std::ofstream out(image.path, std::ios::binary);
    out << "P5\n" << msg->width << ' ' << msg->height << "\n255\n";
    out.write(reinterpret_cast<const char*>(grey.data()), static_cast<std::streamsize>(grey.size()));
    out.close();
    if (!out) return Status::Error("cannot write image '" + image.path + "'");
    CheckOrder(m, number, image.stamp_seconds);
    contents_->images.push_back(std::move(image));
    return Status::Ok();
  }

  const std::string path_;
  const RosBagReadOptions& options_;
  RosBagContents* contents_;
  std::string scan_topic_, imu_topic_, odom_topic_, cmd_topic_, image_topic_;
  bool has_tf_static_ = false;
  StaticTransforms transforms_;
  std::map<std::string, std::pair<Eigen::Isometry3d, bool>> mounts_;  // frame -> (base_T_frame, from tf)
  std::map<std::string, double> last_stamps_;       // topic -> last header stamp
  std::map<std::string, bool> backwards_reported_;  // topics whose stamps went backwards
  std::string layout_error_;  // why Instantiate refused the last message ("" when it did not)
};

// ros::Time holds unsigned 32-bit seconds.
bool RepresentableAsRosTime(double stamp_seconds) {
  return std::isfinite(stamp_seconds) && stamp_seconds >= 0.0 && stamp_seconds < 4294967295.0;
}

// ReadRosBag (core/ros_bag.h); core has checked the options and cleared *contents.
Status ReadBag(const std::string& path, const RosBagReadOptions& options, RosBagContents* contents) {
  // The library reports every problem of the file (cannot open, not a bag, truncated, a chunk
  // that does not decompress, a message shorter than its type) by throwing.
  try {
    return BagReader(path, options, contents).Read();
  } catch (const rosbag::BagUnindexedException&) {
    return Status::Error(path + ": the ROS bag has no index (truncated, or its recording was interrupted); "
                         "`rosbag reindex` may repair it");
  } catch (const std::exception& e) {
    return Status::Error(path + ": cannot read the ROS bag (truncated or corrupt?): " + e.what());
  } catch (...) {  // nothing may cross the plugin boundary but a Status
    return Status::Error(path + ": cannot read the ROS bag (truncated or corrupt?): an unknown exception");
  }
}

// WriteTrajectoryBag (core/ros_bag.h); core has checked the options.
Status WriteBag(const std::string& path, const std::vector<StampedPose2>& trajectory,
                const TrajectoryBagOptions& options) {
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const Pose2& pose = trajectory[i].pose;
    if (!RepresentableAsRosTime(trajectory[i].stamp_seconds) ||
        !(std::isfinite(pose.x()) && std::isfinite(pose.y()) && std::isfinite(pose.theta()))) {
      return Status::Error("cannot write '" + path + "': pose " + std::to_string(i) +
                           " has a stamp outside ROS time [0, 2^32) s or a non-finite value");
    }
  }
  try {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    nav_msgs::Path path_message;
    path_message.header.frame_id = options.frame_id;
    ros::Time record_time = ros::TIME_MIN;
    for (size_t i = 0; i < trajectory.size(); ++i) {
      geometry_msgs::PoseStamped pose;
      pose.header.seq = static_cast<uint32_t>(i);
      pose.header.stamp = ros::Time(trajectory[i].stamp_seconds);
      pose.header.frame_id = options.frame_id;
      pose.pose.position.x = trajectory[i].pose.x();
      pose.pose.position.y = trajectory[i].pose.y();
      const double half_yaw = 0.5 * trajectory[i].pose.theta();
      pose.pose.orientation.z = std::sin(half_yaw);
      pose.pose.orientation.w = std::cos(half_yaw);
      record_time = std::max(ros::TIME_MIN, pose.header.stamp);
      bag.write(options.pose_topic, record_time, pose);
      path_message.poses.push_back(pose);
    }
    if (!trajectory.empty()) path_message.header.stamp = path_message.poses.back().header.stamp;
    bag.write(options.path_topic, record_time, path_message);
    bag.close();
  } catch (const std::exception& e) {
    return Status::Error("cannot write ROS bag '" + path + "': " + e.what());
  } catch (...) {
    return Status::Error("cannot write ROS bag '" + path + "': an unknown exception");
  }
  return Status::Ok();
}

const RosBagPluginApi kApi{ros_bag_plugin::kAbiVersion, ros_bag_plugin::LayoutFingerprint(), __VERSION__, ReadBag,
                           WriteBag};

}  // namespace
}  // namespace hetslam

extern "C" const hetslam::RosBagPluginApi* hetslam_rosbag_plugin_api(void) {
  return &hetslam::kApi;
}
