#include "core/map_io.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <sstream>

#include "core/file_io.h"
#include "core/robot_log_text.h"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

constexpr double kMaxPicturePixels = 1e8;

// ---- PNG (ISO/IEC 15948) pieces: CRC-32 of chunks, Adler-32 of the zlib stream. ----

const std::array<uint32_t, 256>& Crc32Table() {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  return table;
}

uint32_t UpdateCrc32(uint32_t crc, const uint8_t* data, size_t size) {
  const auto& table = Crc32Table();
  for (size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return crc;
}

void AppendBigEndian32(uint32_t v, std::vector<uint8_t>* out) {
  out->push_back(static_cast<uint8_t>(v >> 24));
  out->push_back(static_cast<uint8_t>(v >> 16));
  out->push_back(static_cast<uint8_t>(v >> 8));
  out->push_back(static_cast<uint8_t>(v));
}

void AppendChunk(const char type[4], const uint8_t* data, size_t size, std::vector<uint8_t>* out) {
  AppendBigEndian32(static_cast<uint32_t>(size), out);
  const size_t type_at = out->size();
  out->insert(out->end(), type, type + 4);
  out->insert(out->end(), data, data + size);
  const uint32_t crc =
      UpdateCrc32(0xFFFFFFFFu, out->data() + type_at, size + 4) ^ 0xFFFFFFFFu;
  AppendBigEndian32(crc, out);
}

// Bits into a deflate stream, least significant first (RFC 1951 §3.1.1).
class DeflateBits {
 public:
  explicit DeflateBits(std::vector<uint8_t>* out) : out_(out) {}
  void Put(uint32_t value, int count) {
    bits_ |= static_cast<uint64_t>(value) << count_;
    count_ += count;
    while (count_ >= 8) {
      out_->push_back(static_cast<uint8_t>(bits_));
      bits_ >>= 8;
      count_ -= 8;
    }
  }
  // A Huffman code, which deflate packs most significant bit first.
  void PutCode(uint32_t code, int length) {
    uint32_t reversed = 0;
    for (int k = 0; k < length; ++k) reversed |= ((code >> k) & 1u) << (length - 1 - k);
    Put(reversed, length);
  }
  void Flush() {
    if (count_ > 0) out_->push_back(static_cast<uint8_t>(bits_));
    bits_ = 0;
    count_ = 0;
  }

 private:
  std::vector<uint8_t>* out_;
  uint64_t bits_ = 0;
  int count_ = 0;
};

// Literal/length symbol `symbol` (0..287) with the fixed Huffman code of RFC 1951 §3.2.6.
void PutFixedLiteral(int symbol, DeflateBits* bits) {
  if (symbol < 144) {
    bits->PutCode(0x30 + symbol, 8);
  } else if (symbol < 256) {
    bits->PutCode(0x190 + symbol - 144, 9);
  } else if (symbol < 280) {
    bits->PutCode(symbol - 256, 7);
  } else {
    bits->PutCode(0xC0 + symbol - 280, 8);
  }
}

// A PNG's raw stream read in place: scanlines of `stride` bytes, each the filter type 0 (None)
// and then its row of `pixels`. A position is a scanline and a column; Next steps along.
struct PngRawStream {
  const uint8_t* pixels;  // row `first_row`; the rows after it follow
  size_t row_bytes;
  size_t stride;  // row_bytes + 1
  size_t size;    // stride * rows (of the whole image)
  size_t first_row = 0;  // the first row `pixels` holds (PngRowWriter keeps a window of rows)
  struct Position {
    size_t row = 0, column = 0;
  };
  Position At(size_t i) const { return {i / stride, i % stride}; }
  const uint8_t* Row(size_t row) const { return pixels + (row - first_row) * row_bytes; }
  uint8_t Byte(const Position& p) const { return p.column == 0 ? 0 : Row(p.row)[p.column - 1]; }
  // How many bytes from index `at` equal those `distance` before them, at most `limit`
  // (distance <= at). Along stretches where both positions are inside a row's pixels the bytes
  // are compared in place, a filter byte (0) at a time elsewhere: the count a byte-by-byte walk
  // gives, without the position arithmetic per byte (the PNG was ~4% of a short run).
  size_t CommonLength(size_t at, size_t distance, size_t limit) const {
    Position p = At(at), q = At(at - distance);
    size_t n = 0;
    while (n < limit) {
      if (p.column == 0 || q.column == 0) {
        if (Byte(p) != Byte(q)) break;
        ++n;
        Step(&p, 1);
        Step(&q, 1);
        continue;
      }
      const size_t span = std::min({limit - n, stride - p.column, stride - q.column});
      const uint8_t* a = Row(p.row) + p.column - 1;
      const uint8_t* b = Row(q.row) + q.column - 1;
      const size_t same = static_cast<size_t>(std::mismatch(a, a + span, b).first - a);
      n += same;
      if (same < span) break;
      Step(&p, span);
      Step(&q, span);
    }
    return n;
  }
  // Moves `p` on by `count` bytes, at most to the end of its scanline.
  void Step(Position* p, size_t count) const {
    p->column += count;
    if (p->column == stride) {
      p->column = 0;
      ++p->row;
    }
  }
};

// One final deflate block with the fixed Huffman codes of the raw stream's bytes: each position
// takes the longer of the runs that repeat the previous byte (distance 1) or the byte one
// scanline back (the row above), when at least 3 long, else a literal. Maps are long runs of one
// grey and rows like the one above, so they shrink ~100x without a search. (The stream is
// walked by position, not by index: a division per byte read was ~3% of a short run.)
// Incremental: Encode goes as far as the rows given so far decide (a position's choice reads
// the scanline before it and up to 258 bytes after it), so an image can be encoded a band of
// rows at a time with the bytes of encoding it whole.
class FixedDeflater {
 public:
  explicit FixedDeflater(std::vector<uint8_t>* out) : bits_(out) {
    bits_.Put(1, 1);  // BFINAL
    bits_.Put(1, 2);  // BTYPE 01: fixed Huffman codes
  }
  // Encodes the positions whose bytes (and the 258 after them, or to the end) lie before
  // `available` (a raw-stream index; `raw` holds the rows from the one before position() on);
  // at the end of the stream, the end of the block.
  void Encode(const PngRawStream& raw, size_t available) {
    const size_t size = raw.size, row_distance = raw.stride;
    auto match_length = [&](size_t at, size_t distance) {
      if (distance == 0 || distance > at || distance > kWindow) return size_t{0};
      return raw.CommonLength(at, distance, std::min(kMaxMatch, size - at));
    };
    size_t& at = at_;
    while (at < size && at + std::min(kMaxMatch, size - at) <= available) {
      const size_t run = match_length(at, 1);
      const size_t above = row_distance > 1 ? match_length(at, row_distance) : 0;
      const size_t length = std::max(run, above);
      if (length < 3) {
        PutFixedLiteral(raw.Byte(raw.At(at)), &bits_);
        ++at;
        continue;
      }
      const size_t distance = above > run ? row_distance : 1;
      const int l =
          static_cast<int>(std::upper_bound(kLengthBase, kLengthBase + 29, static_cast<int>(length)) - kLengthBase) - 1;
      PutFixedLiteral(257 + l, &bits_);
      bits_.Put(static_cast<uint32_t>(length - kLengthBase[l]), kLengthExtra[l]);
      const int d = static_cast<int>(std::upper_bound(kDistanceBase, kDistanceBase + 30, static_cast<int>(distance)) -
                                     kDistanceBase) - 1;
      bits_.PutCode(static_cast<uint32_t>(d), 5);
      bits_.Put(static_cast<uint32_t>(distance - kDistanceBase[d]), kDistanceExtra[d]);
      at += length;
    }
    if (at == size && !finished_) {
      PutFixedLiteral(256, &bits_);  // end of block
      bits_.Flush();
      finished_ = true;
    }
  }
  // The first position not encoded yet.
  size_t position() const { return at_; }
  bool finished() const { return finished_; }

 private:
  static constexpr int kLengthBase[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                          31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
  static constexpr int kLengthExtra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                           2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
  static constexpr int kDistanceBase[30] = {1,   2,   3,   4,   5,    7,    9,    13,   17,   25,
                                            33,  49,  65,  97,  129,  193,  257,  385,  513,  769,
                                            1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
  static constexpr int kDistanceExtra[30] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                             6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};
  static constexpr size_t kMaxMatch = 258;
  static constexpr size_t kWindow = 32768;
  DeflateBits bits_;
  size_t at_ = 0;
  bool finished_ = false;
};

// ---- Map rendering shared by the PGM and the PNG. ----

// A rectangle of cells [min_x, max_x] x [min_y, max_y] (inclusive), possibly reaching
// outside the grid.
struct CellBox {
  long long min_x, min_y, max_x, max_y;
  long long width() const { return max_x - min_x + 1; }
  long long height() const { return max_y - min_y + 1; }
};

uint8_t StateGrey(CellState state) {
  switch (state) {
    case CellState::kOccupied:
      return kPgmOccupied;
    case CellState::kFree:
      return kPgmFree;
    case CellState::kUnknown:
      break;
  }
  return kPgmUnknown;
}

uint8_t CellGrey(const OccupancyGrid& grid, long long x, long long y) {
  const GridGeometry& g = grid.geometry();
  if (x < 0 || y < 0 || x >= g.width() || y >= g.height()) return kPgmUnknown;
  return StateGrey(grid.State(g.LinearIndex({static_cast<int>(x), static_cast<int>(y)})));
}

// Bounding box (cells) of the observed cells, found by scanning the grid. The grid's own
// observed_min()/observed_max() are not used: at the time of writing they always include
// cells (0..1, 0..1) (their empty-box sentinel {1,1}/{0,0} takes part in the min/max), which
// would stretch every map to the grid's corner. Returns false when no cell is observed.
bool ObservedBox(const OccupancyGrid& grid, CellIndex* lo, CellIndex* hi) {
  const GridGeometry& g = grid.geometry();
  bool any = false;
  for (int y = 0; y < g.height(); ++y) {
    for (int x = 0; x < g.width(); ++x) {
      if (grid.State(CellIndex{x, y}) == CellState::kUnknown) continue;
      if (!any) {
        *lo = *hi = CellIndex{x, y};
        any = true;
      } else {
        lo->x = std::min(lo->x, x);
        lo->y = std::min(lo->y, y);
        hi->x = std::max(hi->x, x);
        hi->y = std::max(hi->y, y);
      }
    }
  }
  return any;
}

// Grey picture of `box`, row 0 = box.max_y.
std::vector<uint8_t> RenderGrey(const OccupancyGrid& grid, const CellBox& box) {
  std::vector<uint8_t> pixels(static_cast<size_t>(box.width() * box.height()));
  size_t k = 0;
  for (long long y = box.max_y; y >= box.min_y; --y) {
    for (long long x = box.min_x; x <= box.max_x; ++x) pixels[k++] = CellGrey(grid, x, y);
  }
  return pixels;
}

std::string Basename(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// The folder part of `path` with its trailing slash ("" for a bare file name).
std::string Dirname(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

// Writes the P5 image (`pixels` row-major, row 0 on top) and its YAML, the one layout every
// map of hetslam is written in.
Status WritePgmYamlPair(const std::string& path_without_extension, long long width,
                        long long height, const std::vector<uint8_t>& pixels,
                        double resolution_meters, const Eigen::Vector2d& origin,
                        const std::vector<std::string>& yaml_comment_lines) {
  const std::string pgm_path = path_without_extension + ".pgm";
  const std::string yaml_path = path_without_extension + ".yaml";
  std::string pgm = "P5\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
  pgm.append(pixels.begin(), pixels.end());
  HETSLAM_RETURN_IF_ERROR(WriteFileBytes(pgm_path, pgm.data(), pgm.size()));

  std::ostringstream yaml;
  yaml.precision(10);
  for (const std::string& line : yaml_comment_lines) yaml << "# " << line << "\n";
  yaml << "image: " << Basename(pgm_path) << "\n"
       << "resolution: " << resolution_meters << "\n"
       << "origin: [" << origin.x() << ", " << origin.y() << ", 0.0]\n"
       << "negate: 0\n"
       << "occupied_thresh: 0.65\n"
       << "free_thresh: 0.196\n";
  const std::string text = yaml.str();
  return WriteFileBytes(yaml_path, text.data(), text.size());
}

// ---- Reading map_server maps. ----

struct MapYaml {
  std::string image;
  double resolution_meters = 0.0;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  bool negate = false;
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
};

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  const size_t end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

Status ParseMapYaml(const std::string& path, MapYaml* yaml) {
  std::ifstream in;
  HETSLAM_RETURN_IF_ERROR(robot_log_text::OpenForReading(path, &in));
  bool has_image = false, has_resolution = false, has_origin = false;
  std::string line;
  int line_number = 0;
  auto error = [&](const std::string& message) {
    return Status::Error(path + ":" + std::to_string(line_number) + ": " + message);
  };
  while (std::getline(in, line)) {
    ++line_number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    line = Trim(line);
    if (line.empty()) continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) return error("expected `key: value`, got '" + line + "'");
    const std::string key = Trim(line.substr(0, colon));
    std::string value = Trim(line.substr(colon + 1));
    if (value.size() >= 2 && (value.front() == '"' || value.front() == '\'') &&
        value.back() == value.front()) {
      value = value.substr(1, value.size() - 2);
    }
    double number = 0.0;
    if (key == "image") {
      if (value.empty()) return error("image names no file");
      yaml->image = value;
      has_image = true;
    } else if (key == "resolution") {
      if (!text_fields::ParseFiniteDouble(value, &number) || !(number > 0.0)) {
        return error("resolution must be a positive number of metres per cell, got '" + value +
                     "'");
      }
      yaml->resolution_meters = number;
      has_resolution = true;
    } else if (key == "origin") {
      std::vector<std::string> fields;
      std::string inside = value;
      if (inside.size() >= 2 && inside.front() == '[' && inside.back() == ']') {
        inside = inside.substr(1, inside.size() - 2);
      } else {
        return error("origin must be `[x, y, yaw]`, got '" + value + "'");
      }
      std::replace(inside.begin(), inside.end(), ',', ' ');
      text_fields::Split(inside, &fields);
      double xyz[3];
      if (fields.size() != 3 || !text_fields::ParseFiniteDouble(fields[0], &xyz[0]) ||
          !text_fields::ParseFiniteDouble(fields[1], &xyz[1]) ||
          !text_fields::ParseFiniteDouble(fields[2], &xyz[2])) {
        return error("origin must be `[x, y, yaw]` with three finite numbers, got '" + value +
                     "'");
      }
      if (xyz[2] != 0.0) {
        return error("origin yaw " + fields[2] + " is not supported (only 0: an unrotated map)");
      }
      yaml->origin = Eigen::Vector2d(xyz[0], xyz[1]);
      has_origin = true;
    } else if (key == "negate") {
      if (value != "0" && value != "1") return error("negate must be 0 or 1, got '" + value + "'");
      yaml->negate = value == "1";
    } else if (key == "occupied_thresh" || key == "free_thresh") {
      if (!text_fields::ParseFiniteDouble(value, &number) || number < 0.0 || number > 1.0) {
        return error(key + " must be a number in [0, 1], got '" + value + "'");
      }
      (key == "occupied_thresh" ? yaml->occupied_thresh : yaml->free_thresh) = number;
    } else if (key == "mode") {
      if (value != "trinary") {
        return error("mode '" + value + "' is not supported (only trinary)");
      }
    }
  }
  const char* missing = !has_image ? "image" : !has_resolution ? "resolution"
                                             : !has_origin     ? "origin"
                                                               : nullptr;
  if (missing != nullptr) return Status::Error(path + ": no '" + missing + "' key");
  if (!(yaml->free_thresh <= yaml->occupied_thresh)) {
    return Status::Error(path + ": free_thresh must not exceed occupied_thresh");
  }
  return Status::Ok();
}

struct PgmImage {
  int width = 0;
  int height = 0;
  int max_value = 255;
  std::vector<uint8_t> pixels;  // row-major, row 0 on top
};

// Binary PGM (P5) with 8-bit samples; '#' comments are allowed in the header.
Status ReadPgm(const std::string& path, PgmImage* image) {
  std::ifstream in;
  HETSLAM_RETURN_IF_ERROR(robot_log_text::OpenForReading(path, &in));  // text mode is binary on POSIX
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  size_t at = 0;
  // The next header token: white space and comments (to the end of the line) are skipped.
  auto token = [&]() {
    while (at < bytes.size()) {
      if (std::isspace(static_cast<unsigned char>(bytes[at]))) {
        ++at;
      } else if (bytes[at] == '#') {
        while (at < bytes.size() && bytes[at] != '\n') ++at;
      } else {
        break;
      }
    }
    const size_t begin = at;
    while (at < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[at]))) ++at;
    return bytes.substr(begin, at - begin);
  };
  const std::string magic = token();
  if (magic != "P5") {
    return Status::Error("'" + path + "' is not a binary PGM (P5) image (starts with '" +
                         magic.substr(0, 8) + "')");
  }
  long long numbers[3];
  const char* names[3] = {"width", "height", "max value"};
  for (int k = 0; k < 3; ++k) {
    const std::string field = token();
    if (!text_fields::ParseInteger(field, 1, k < 2 ? (1 << 30) : 255, &numbers[k])) {
      return Status::Error("'" + path + "': PGM " + names[k] + " '" + field +
                           "' is not an integer in [1, " +
                           (k < 2 ? std::string("2^30") : std::string("255")) + "]");
    }
  }
  if (numbers[0] * numbers[1] > 400000000LL) {
    return Status::Error("'" + path + "': PGM of " + std::to_string(numbers[0]) + " x " +
                         std::to_string(numbers[1]) + " pixels is over the limit of 4e8");
  }
  ++at;  // the single white space character before the raster
  const size_t size = static_cast<size_t>(numbers[0] * numbers[1]);
  if (at > bytes.size() || bytes.size() - at < size) {
    return Status::Error("'" + path + "': PGM raster is truncated (" +
                         std::to_string(at > bytes.size() ? 0 : bytes.size() - at) + " of " +
                         std::to_string(size) + " bytes)");
  }
  image->width = static_cast<int>(numbers[0]);
  image->height = static_cast<int>(numbers[1]);
  image->max_value = static_cast<int>(numbers[2]);
  image->pixels.assign(bytes.begin() + at, bytes.begin() + at + size);
  for (uint8_t v : image->pixels) {
    if (v > image->max_value) {
      return Status::Error("'" + path + "': a pixel value " + std::to_string(v) +
                           " exceeds the PGM's max value " + std::to_string(image->max_value));
    }
  }
  return Status::Ok();
}

}  // namespace

void TrajectoryColor(int index, uint8_t rgb[3]) {
  // Eight hues that stay distinct from each other and from the black/white/grey map.
  static const uint8_t kColors[8][3] = {
      {230, 25, 75},  {0, 130, 200},  {60, 180, 75},   {245, 130, 48},
      {145, 30, 180}, {240, 50, 230}, {170, 110, 40},  {0, 128, 128}};
  const int k = ((index % 8) + 8) % 8;
  std::copy(kColors[k], kColors[k] + 3, rgb);
}

Status WritePng(const std::string& path, int width, int height, int channels,
                const std::vector<uint8_t>& pixels) {
  if (width >= 1 && height >= 1 && (channels == 1 || channels == 3) &&
      pixels.size() != static_cast<size_t>(width) * channels * static_cast<size_t>(height)) {
    return Status::Error("cannot write '" + path + "': " + std::to_string(pixels.size()) +
                         " pixel bytes given for " + std::to_string(width) + " x " +
                         std::to_string(height) + " x " + std::to_string(channels));
  }
  return WritePngFromBuffer(path, width, height, channels, pixels.data());
}

// The writer's state. The raw stream (RFC 2083: each scanline its filter type 0, None, then its
// pixels) is read in place from a window of rows: the one before the deflater's position and
// those after it; the zlib stream (RFC 1950: CMF 0x78, deflate with a 32K window, FLG 0x01, no
// dictionary, 0x7801 a multiple of 31; then the Adler-32 of the raw stream, big endian) is
// written in IDAT chunks of 1 MiB as it fills them (the stream may be split anywhere).
struct PngRowWriter::State {
  static constexpr size_t kMaxChunk = 1 << 20;
  std::string path;
  std::FILE* file = nullptr;
  int height = 0;
  size_t row_bytes = 0;
  size_t stride = 0;
  size_t size = 0;
  int rows_added = 0;
  std::vector<uint8_t> window;  // rows [window_first_row, rows_added)
  size_t window_first_row = 0;
  std::vector<uint8_t> zlib = {0x78, 0x01};  // not yet written
  FixedDeflater deflater{&zlib};
  uint32_t adler_a = 1, adler_b = 0;
  size_t since_reduction = 0;

  void AddToAdler(const uint8_t* bytes, size_t n) {
    constexpr uint32_t kAdlerMod = 65521;
    // 5552: the most bytes for which b cannot overflow 32 bits between two reductions.
    constexpr size_t kAdlerRun = 5552;
    while (n > 0) {
      const size_t run = std::min(n, kAdlerRun - since_reduction);
      for (size_t k = 0; k < run; ++k) {
        adler_a += bytes[k];
        adler_b += adler_a;
      }
      bytes += run;
      n -= run;
      since_reduction += run;
      if (since_reduction == kAdlerRun) {
        adler_a %= kAdlerMod;
        adler_b %= kAdlerMod;
        since_reduction = 0;
      }
    }
  }
  void WriteChunk(const char type[4], const uint8_t* data, size_t n) {
    std::vector<uint8_t> chunk;
    chunk.reserve(n + 12);
    AppendChunk(type, data, n, &chunk);
    std::fwrite(chunk.data(), 1, chunk.size(), file);
  }
  // Writes the zlib bytes that fill whole chunks (all of them when `last`).
  void WriteFullChunks(bool last) {
    size_t at = 0;
    while (zlib.size() - at >= kMaxChunk || (last && at < zlib.size())) {
      const size_t n = std::min(kMaxChunk, zlib.size() - at);
      WriteChunk("IDAT", zlib.data() + at, n);
      at += n;
    }
    zlib.erase(zlib.begin(), zlib.begin() + static_cast<std::ptrdiff_t>(at));
  }
};

PngRowWriter::PngRowWriter() = default;

PngRowWriter::~PngRowWriter() {
  if (state_ != nullptr && state_->file != nullptr) {
    std::fclose(state_->file);
    std::remove(TemporaryPathFor(state_->path).c_str());
  }
}

Status PngRowWriter::Open(const std::string& path, int width, int height, int channels) {
  if (state_ != nullptr) return Status::Error("cannot write '" + path + "': the PNG writer is already in use");
  if (width < 1 || height < 1) {
    return Status::Error("cannot write '" + path + "': image size " + std::to_string(width) +
                         " x " + std::to_string(height) + " is empty or negative");
  }
  if (channels != 1 && channels != 3) {
    return Status::Error("cannot write '" + path + "': channels must be 1 or 3 (got " +
                         std::to_string(channels) + ")");
  }
  auto state = std::make_unique<State>();
  state->path = path;
  state->height = height;
  state->row_bytes = static_cast<size_t>(width) * channels;
  state->stride = state->row_bytes + 1;
  state->size = state->stride * static_cast<size_t>(height);
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "wb", &state->file));
  static constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::fwrite(kSignature, 1, sizeof(kSignature), state->file);
  std::vector<uint8_t> header;
  AppendBigEndian32(static_cast<uint32_t>(width), &header);
  AppendBigEndian32(static_cast<uint32_t>(height), &header);
  header.push_back(8);                        // bit depth
  header.push_back(channels == 1 ? 0 : 2);    // colour type: greyscale or truecolour
  header.push_back(0);                        // compression: deflate
  header.push_back(0);                        // filter method 0
  header.push_back(0);                        // no interlace
  state->WriteChunk("IHDR", header.data(), header.size());
  state_ = std::move(state);
  return Status::Ok();
}

Status PngRowWriter::AddRows(const uint8_t* rows, int count) {
  if (state_ == nullptr || state_->file == nullptr) return Status::Error("PngRowWriter::AddRows before Open or after Finish");
  State& s = *state_;
  if (count < 0 || count > s.height - s.rows_added) {
    return Status::Error("cannot write '" + s.path + "': " + std::to_string(count) + " rows given with " +
                         std::to_string(s.height - s.rows_added) + " of " + std::to_string(s.height) + " left");
  }
  const uint8_t filter_none = 0;
  for (int r = 0; r < count; ++r) {
    const uint8_t* row = rows + static_cast<size_t>(r) * s.row_bytes;
    s.AddToAdler(&filter_none, 1);
    s.AddToAdler(row, s.row_bytes);
  }
  const size_t first_new_row = static_cast<size_t>(s.rows_added);
  s.rows_added += count;
  // The row above the deflater's position and those after it: what later positions read.
  auto needed_from = [&s] {
    const size_t row = s.deflater.position() / s.stride;
    return row > 0 ? row - 1 : 0;
  };
  if (s.window.empty()) {
    // No earlier row is kept (the first rows): read in place, so that a whole image given at
    // once is not copied; then keep the rows later ones need.
    PngRawStream raw{rows, s.row_bytes, s.stride, s.size};
    raw.first_row = first_new_row;
    s.deflater.Encode(raw, s.stride * static_cast<size_t>(s.rows_added));
    const size_t keep = std::max(first_new_row, needed_from());
    s.window.assign(rows + (keep - first_new_row) * s.row_bytes, rows + static_cast<size_t>(count) * s.row_bytes);
    s.window_first_row = keep;
  } else {
    // The rows before the one above the deflater's position are read no more.
    const size_t keep = std::max(s.window_first_row, needed_from());
    s.window.erase(s.window.begin(),
                   s.window.begin() + static_cast<std::ptrdiff_t>((keep - s.window_first_row) * s.row_bytes));
    s.window_first_row = keep;
    s.window.insert(s.window.end(), rows, rows + static_cast<size_t>(count) * s.row_bytes);
    PngRawStream raw{s.window.data(), s.row_bytes, s.stride, s.size};
    raw.first_row = s.window_first_row;
    s.deflater.Encode(raw, s.stride * static_cast<size_t>(s.rows_added));
  }
  s.WriteFullChunks(false);
  return Status::Ok();
}

Status PngRowWriter::Finish() {
  if (state_ == nullptr || state_->file == nullptr) return Status::Error("PngRowWriter::Finish before Open or after Finish");
  State& s = *state_;
  if (s.rows_added != s.height) {
    return Status::Error("cannot write '" + s.path + "': " + std::to_string(s.rows_added) + " of " +
                         std::to_string(s.height) + " rows given");
  }
  CHECK(s.deflater.finished()) << "every row given but the deflate stream is not finished";
  constexpr uint32_t kAdlerMod = 65521;
  AppendBigEndian32(((s.adler_b % kAdlerMod) << 16) | (s.adler_a % kAdlerMod), &s.zlib);
  s.WriteFullChunks(true);
  s.WriteChunk("IEND", nullptr, 0);
  std::FILE* file = s.file;
  s.file = nullptr;
  return CommitWrittenFile(file, s.path);
}

Status WritePngFromBuffer(const std::string& path, int width, int height, int channels, const uint8_t* pixels) {
  PngRowWriter writer;
  HETSLAM_RETURN_IF_ERROR(writer.Open(path, width, height, channels));
  HETSLAM_RETURN_IF_ERROR(writer.AddRows(pixels, height));
  return writer.Finish();
}

Status WriteMapPgmYaml(const OccupancyGrid& grid, const std::string& path_without_extension) {
  CellIndex lo, hi;
  if (!ObservedBox(grid, &lo, &hi)) {
    return Status::Error("cannot write '" + path_without_extension +
                         ".pgm': the map has no observed cell");
  }
  const CellBox box{lo.x - kMapBorderCells, lo.y - kMapBorderCells, hi.x + kMapBorderCells,
                    hi.y + kMapBorderCells};
  const GridGeometry& g = grid.geometry();
  const Eigen::Vector2d origin =
      g.origin() + Eigen::Vector2d(box.min_x, box.min_y) * g.resolution_meters();
  return WritePgmYamlPair(path_without_extension, box.width(), box.height(),
                          RenderGrey(grid, box), g.resolution_meters(), origin, {});
}

int GridLayer::CountCells(CellState state) const {
  return static_cast<int>(std::count(cells.begin(), cells.end(), state));
}

Status WriteMapPgmYaml(const GridLayer& layer, const std::string& path_without_extension,
                       const std::vector<std::string>& yaml_comment_lines) {
  const GridGeometry& g = layer.geometry;
  if (g.width() < 1 || g.height() < 1) {
    return Status::Error("cannot write '" + path_without_extension + ".pgm': the layer is empty (" +
                         std::to_string(g.width()) + " x " + std::to_string(g.height()) + ")");
  }
  CHECK_EQ(layer.cells.size(), static_cast<size_t>(g.num_cells()))
      << "GridLayer cells do not match its geometry";
  std::vector<uint8_t> pixels;
  pixels.reserve(layer.cells.size());
  for (int y = g.height() - 1; y >= 0; --y) {
    for (int x = 0; x < g.width(); ++x) pixels.push_back(StateGrey(layer.at({x, y})));
  }
  return WritePgmYamlPair(path_without_extension, g.width(), g.height(), pixels,
                          g.resolution_meters(), g.origin(), yaml_comment_lines);
}

Status ReadMapPgmYaml(const std::string& yaml_path, GridLayer* layer) {
  CHECK(layer != nullptr);
  MapYaml yaml;
  HETSLAM_RETURN_IF_ERROR(ParseMapYaml(yaml_path, &yaml));
  const std::string image_path =
      yaml.image.front() == '/' ? yaml.image : Dirname(yaml_path) + yaml.image;
  PgmImage image;
  HETSLAM_RETURN_IF_ERROR(ReadPgm(image_path, &image));
  GridLayer read = GridLayer::Filled(
      GridGeometry(yaml.origin, yaml.resolution_meters, image.width, image.height),
      CellState::kUnknown);
  for (int row = 0; row < image.height; ++row) {
    for (int x = 0; x < image.width; ++x) {
      const double v = 255.0 * image.pixels[static_cast<size_t>(row) * image.width + x] /
                       image.max_value;
      const double p = yaml.negate ? v / 255.0 : (255.0 - v) / 255.0;
      CellState state = CellState::kUnknown;
      if (p > yaml.occupied_thresh) {
        state = CellState::kOccupied;
      } else if (p < yaml.free_thresh) {
        state = CellState::kFree;
      }
      read.set({x, image.height - 1 - row}, state);
    }
  }
  *layer = std::move(read);
  return Status::Ok();
}

Status WriteMapPng(const OccupancyGrid& grid, const std::vector<std::vector<Pose2>>& trajectories,
                   const std::string& path) {
  const GridGeometry& g = grid.geometry();
  const double resolution = g.resolution_meters();
  // Picture bounds in (unbounded) cell coordinates, computed in double first so that a far
  // away pose cannot overflow an int.
  double lo_x = std::numeric_limits<double>::infinity(), lo_y = lo_x;
  double hi_x = -lo_x, hi_y = -lo_x;
  CellIndex observed_lo, observed_hi;
  if (ObservedBox(grid, &observed_lo, &observed_hi)) {
    lo_x = observed_lo.x;
    lo_y = observed_lo.y;
    hi_x = observed_hi.x;
    hi_y = observed_hi.y;
  }
  for (size_t t = 0; t < trajectories.size(); ++t) {
    for (size_t k = 0; k < trajectories[t].size(); ++k) {
      const Pose2& pose = trajectories[t][k];
      if (!pose.ToVector().allFinite()) {
        return Status::Error("cannot write '" + path + "': trajectory " + std::to_string(t) +
                             " pose " + std::to_string(k) + " is not finite");
      }
      const Eigen::Vector2d c = (pose.translation() - g.origin()) / resolution;
      lo_x = std::min(lo_x, std::floor(c.x()));
      lo_y = std::min(lo_y, std::floor(c.y()));
      hi_x = std::max(hi_x, std::floor(c.x()));
      hi_y = std::max(hi_y, std::floor(c.y()));
    }
  }
  if (!(lo_x <= hi_x && lo_y <= hi_y)) {
    return Status::Error("cannot write '" + path + "': no observed cell and no pose to draw");
  }
  const double pixels_needed =
      (hi_x - lo_x + 1 + 2 * kMapBorderCells) * (hi_y - lo_y + 1 + 2 * kMapBorderCells);
  if (pixels_needed > kMaxPicturePixels) {
    return Status::Error("cannot write '" + path + "': the picture would have " +
                         std::to_string(pixels_needed) + " pixels (limit 1e8); is a pose far "
                         "away from the map?");
  }
  const CellBox box{static_cast<long long>(lo_x) - kMapBorderCells,
                    static_cast<long long>(lo_y) - kMapBorderCells,
                    static_cast<long long>(hi_x) + kMapBorderCells,
                    static_cast<long long>(hi_y) + kMapBorderCells};
  const int width = static_cast<int>(box.width());
  const int height = static_cast<int>(box.height());
  const std::vector<uint8_t> grey = RenderGrey(grid, box);
  std::vector<uint8_t> rgb(grey.size() * 3);
  for (size_t i = 0; i < grey.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = grey[i];

  auto put = [&](long long col, long long row, const uint8_t color[3]) {
    if (col < 0 || row < 0 || col >= width || row >= height) return;
    uint8_t* p = &rgb[3 * (static_cast<size_t>(row) * width + col)];
    p[0] = color[0];
    p[1] = color[1];
    p[2] = color[2];
  };
  // Pixel of a world point: column = cell x - min_x, row = max_y - cell y (row 0 on top).
  auto to_pixel = [&](const Pose2& pose, long long* col, long long* row) {
    const Eigen::Vector2d c = (pose.translation() - g.origin()) / resolution;
    *col = static_cast<long long>(std::floor(c.x())) - box.min_x;
    *row = box.max_y - static_cast<long long>(std::floor(c.y()));
  };

  for (size_t t = 0; t < trajectories.size(); ++t) {
    const std::vector<Pose2>& poses = trajectories[t];
    if (poses.empty()) continue;
    uint8_t color[3];
    TrajectoryColor(static_cast<int>(t), color);
    // Polyline by Bresenham's algorithm between consecutive poses.
    for (size_t k = 0; k + 1 < poses.size(); ++k) {
      long long x0, y0, x1, y1;
      to_pixel(poses[k], &x0, &y0);
      to_pixel(poses[k + 1], &x1, &y1);
      const long long dx = std::llabs(x1 - x0), dy = -std::llabs(y1 - y0);
      const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
      long long err = dx + dy;
      while (true) {
        put(x0, y0, color);
        if (x0 == x1 && y0 == y1) break;
        const long long e2 = 2 * err;
        if (e2 >= dy) {
          err += dy;
          x0 += sx;
        }
        if (e2 <= dx) {
          err += dx;
          y0 += sy;
        }
      }
    }
    // Start marker: a disc of radius 3 px in the trajectory colour inside a black ring.
    long long sc, sr;
    to_pixel(poses.front(), &sc, &sr);
    const uint8_t black[3] = {0, 0, 0};
    for (int dr = -4; dr <= 4; ++dr) {
      for (int dc = -4; dc <= 4; ++dc) {
        const int d2 = dr * dr + dc * dc;
        if (d2 <= 9) {
          put(sc + dc, sr + dr, color);
        } else if (d2 <= 20) {
          put(sc + dc, sr + dr, black);
        }
      }
    }
  }
  return WritePng(path, width, height, 3, rgb);
}

}  // namespace hetslam
