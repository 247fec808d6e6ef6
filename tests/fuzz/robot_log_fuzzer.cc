// libFuzzer target: the hetslam robot log reader, strict and lenient, then the merged stream
// (with its time-gap bound), the camera PARAMs and a round trip through the writer.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/measurement_log.h"
#include "core/robot_log.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  // Most inputs should reach the message parser: the header is given unless the input has one.
  std::string text(fuzz::AsText(data, size));
  if (text.rfind("HSLOG", 0) != 0) text = "HSLOG 1\n" + text;
  const std::string path = fuzz::WriteScratchFile("log.txt", text);
  for (const bool lenient : {false, true}) {
    RobotLogReadOptions options;
    options.lenient = lenient;
    RobotLog log;
    if (ReadRobotLog(path, options, &log).ok()) {
      CameraIntrinsics intrinsics;
      Eigen::Isometry3d laser_T_camera;
      (void)log.CameraModel(&intrinsics, &laser_T_camera);
    }
    MeasurementLogOptions stream_options;
    stream_options.lenient = lenient;
    MeasurementLog stream;
    (void)ReadMeasurementLog(path, stream_options, &stream);
  }
  return 0;
}
