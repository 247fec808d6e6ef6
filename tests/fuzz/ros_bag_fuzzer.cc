// libFuzzer target: the ROS 1 bag reader (core/ros_bag.h), built only with the bag libraries.
// Once with default options (automatic topics, strict), once lenient with every topic named
// (the conventional names the automatic choice prefers) and images written to the scratch
// folder. Exceptions of rosbag_storage must come back as a Status, never escape.
// The plugin's code (core/ros_bag_plugin.cc) is linked into this program rather than opened with
// dlopen: libFuzzer's coverage and the sanitizers then see it like the rest of the program, and
// no plugin file is looked for (core/ros_bag_plugin.h, UseLinkedPlugin).
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/ros_bag.h"
#include "core/ros_bag_plugin.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  hetslam::ros_bag_plugin::UseLinkedPlugin(hetslam_rosbag_plugin_api());
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  const std::string path = fuzz::WriteScratchFile("x.bag", fuzz::AsText(data, size));
  {
    RosBagContents contents;
    (void)ReadRosBag(path, RosBagReadOptions(), &contents);
  }
  {
    RosBagReadOptions options;
    options.scan_topic = "/scan";
    options.imu_topic = "/imu/data";
    options.odom_topic = "/odom";
    options.cmd_topic = "/cmd_vel";
    options.image_topic = "/camera/image_raw";
    options.image_directory = fuzz::ScratchDir() + "/images";
    options.lenient = true;
    RosBagContents contents;
    (void)ReadRosBag(path, options, &contents);
  }
  return 0;
}
