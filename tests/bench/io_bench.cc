// Reading logs (issue #15: "reading the log" is a stage of every run):
//   BM_ParseDouble          one number of a log line as core/text_fields.h parses it (std::from_chars,
//                           strtod's double); arg 0: a range "4.123", 1: a timestamp "976052857.337284".
//   BM_Strtod               the same numbers through strtod, as before session 20.
//   BM_ReadCarmenLog        a synthetic CARMEN log of 1000 FLASER lines of 360 ranges (an Intel-sized
//                           log, written once to a temporary file) read whole by ReadCarmenLog.
//   BM_WritePng             an Intel-sized map picture (1708 x 1672 RGB: runs of greys, rows like
//                           the one above, a few strokes) written as a PNG; arg 0: whole
//                           (WritePngFromBuffer), else in bands of that many rows (PngRowWriter,
//                           as the map picture is written since session 29: the same bytes).
// Run: build/tests/bench_io_bench
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "benchmark/benchmark.h"
#include "core/carmen_log.h"
#include "core/map_io.h"
#include "core/text_fields.h"

namespace hetslam {
namespace {

const std::vector<std::string>& Numbers(int kind) {
  static const auto* ranges = [] {
    auto* v = new std::vector<std::string>();
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> range(0.2, 30.0);
    char text[32];
    for (int i = 0; i < 1024; ++i) {
      std::snprintf(text, sizeof(text), "%.3f", range(rng));
      v->push_back(text);
    }
    return v;
  }();
  static const auto* stamps = [] {
    auto* v = new std::vector<std::string>();
    char text[32];
    for (int i = 0; i < 1024; ++i) {
      std::snprintf(text, sizeof(text), "%.6f", 976052857.337284 + 0.1337 * i);
      v->push_back(text);
    }
    return v;
  }();
  return kind == 0 ? *ranges : *stamps;
}

void BM_ParseDouble(benchmark::State& state) {
  const std::vector<std::string>& numbers = Numbers(static_cast<int>(state.range(0)));
  size_t i = 0;
  double sum = 0.0;
  for (auto _ : state) {
    double v = 0.0;
    text_fields::ParseDouble(numbers[i++ & 1023], &v);
    sum += v;
  }
  benchmark::DoNotOptimize(sum);
}
BENCHMARK(BM_ParseDouble)->Arg(0)->Arg(1);

void BM_Strtod(benchmark::State& state) {
  const std::vector<std::string>& numbers = Numbers(static_cast<int>(state.range(0)));
  size_t i = 0;
  double sum = 0.0;
  for (auto _ : state) sum += std::strtod(numbers[i++ & 1023].c_str(), nullptr);
  benchmark::DoNotOptimize(sum);
}
BENCHMARK(BM_Strtod)->Arg(0)->Arg(1);

void BM_ReadCarmenLog(benchmark::State& state) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("hetslam_io_bench_" + std::to_string(::getpid()) + ".clf");
  {
    std::ofstream out(path);
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> range(0.2, 30.0);
    char text[32];
    for (int scan = 0; scan < 1000; ++scan) {
      out << "FLASER 360";
      for (int i = 0; i < 360; ++i) {
        std::snprintf(text, sizeof(text), " %.3f", range(rng));
        out << text;
      }
      const double t = 976052857.337284 + 0.1 * scan;
      std::snprintf(text, sizeof(text), "%.6f", t);
      out << " 1.0 2.0 0.1 1.0 2.0 0.1 " << text << " host " << text << "\n";
    }
  }
  int64_t bytes = static_cast<int64_t>(std::filesystem::file_size(path));
  for (auto _ : state) {
    CarmenLog log;
    const Status status = ReadCarmenLog(path.string(), CarmenReadOptions(), &log);
    if (!status.ok() || log.lasers.size() != 1000) {
      state.SkipWithError(status.ok() ? "wrong number of scans" : status.message().c_str());
      break;
    }
    benchmark::DoNotOptimize(log.lasers.data());
  }
  state.SetBytesProcessed(state.iterations() * bytes);
  std::filesystem::remove(path);
}
BENCHMARK(BM_ReadCarmenLog)->Unit(benchmark::kMillisecond);

// A map-like RGB picture: cell runs of a few greys two pixels tall, a diagonal stroke.
const std::vector<uint8_t>& MapLikePicture(int width, int height) {
  static const auto* pixels = [width, height] {
    auto* p = new std::vector<uint8_t>(static_cast<size_t>(width) * height * 3);
    std::mt19937 rng(3);
    const uint8_t greys[] = {255, 255, 255, 205, 52};
    std::uniform_int_distribution<int> pick(0, 4), run(1, 60);
    for (int y = 0; y < height; y += 2) {
      uint8_t* row = p->data() + static_cast<size_t>(y) * width * 3;
      for (int x = 0; x < width;) {
        const int end = std::min(width, x + 2 * run(rng));
        const uint8_t grey = greys[pick(rng)];
        std::fill(row + 3 * x, row + 3 * end, grey);
        x = end;
      }
      if (y + 1 < height) std::copy(row, row + 3 * width, row + 3 * width);
    }
    for (int y = 0; y < height; ++y) {
      const int x = y * (width - 3) / height;
      uint8_t* pixel = p->data() + (static_cast<size_t>(y) * width + x) * 3;
      for (int k = 0; k < 3; ++k) pixel[3 * k] = 230, pixel[3 * k + 1] = 20, pixel[3 * k + 2] = 60;
    }
    return p;
  }();
  return *pixels;
}

void BM_WritePng(benchmark::State& state) {
  constexpr int kWidth = 1708, kHeight = 1672;
  const std::vector<uint8_t>& pixels = MapLikePicture(kWidth, kHeight);
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("hetslam_io_bench_" + std::to_string(::getpid()) + ".png")).string();
  const int band = static_cast<int>(state.range(0));
  for (auto _ : state) {
    Status status;
    if (band == 0) {
      status = WritePngFromBuffer(path, kWidth, kHeight, 3, pixels.data());
    } else {
      PngRowWriter writer;
      status = writer.Open(path, kWidth, kHeight, 3);
      for (int y = 0; y < kHeight && status.ok(); y += band) {
        status = writer.AddRows(pixels.data() + static_cast<size_t>(y) * kWidth * 3, std::min(band, kHeight - y));
      }
      if (status.ok()) status = writer.Finish();
    }
    if (!status.ok()) {
      state.SkipWithError(status.message().c_str());
      break;
    }
  }
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(pixels.size()));
  std::filesystem::remove(path);
}
BENCHMARK(BM_WritePng)->Arg(0)->Arg(102)->Arg(16)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hetslam

BENCHMARK_MAIN();
