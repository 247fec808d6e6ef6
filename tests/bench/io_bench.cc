// Reading logs (issue #15: "reading the log" is a stage of every run):
//   BM_ParseDouble          one number of a log line as core/text_fields.h parses it (std::from_chars,
//                           strtod's double); arg 0: a range "4.123", 1: a timestamp "976052857.337284".
//   BM_Strtod               the same numbers through strtod, as before session 20.
//   BM_ReadCarmenLog        a synthetic CARMEN log of 1000 FLASER lines of 360 ranges (an Intel-sized
//                           log, written once to a temporary file) read whole by ReadCarmenLog.
// Run: build/tests/bench_io_bench
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "benchmark/benchmark.h"
#include "core/carmen_log.h"
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

}  // namespace
}  // namespace hetslam

BENCHMARK_MAIN();
