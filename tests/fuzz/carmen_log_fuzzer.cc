// libFuzzer target: the CARMEN log reader, strict and lenient, then the measurement stream.
#include <cstddef>
#include <cstdint>

#include "core/carmen_log.h"
#include "core/measurement_log.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  const std::string path = fuzz::WriteScratchFile("log.clf", fuzz::AsText(data, size));
  for (const bool lenient : {false, true}) {
    CarmenReadOptions options;
    options.lenient = lenient;
    CarmenLog log;
    (void)ReadCarmenLog(path, options, &log);
    MeasurementLogOptions stream_options;
    stream_options.lenient = lenient;
    MeasurementLog stream;
    (void)ReadMeasurementLog(path, stream_options, &stream);
  }
  return 0;
}
