// --help for the example programs: the usage message and the program's own flags only (gflags'
// own --help also lists every glog and gflags flag, burying ours). --helpfull still lists all.
#ifndef HETSLAM_EXAMPLES_FLAG_HELP_H_
#define HETSLAM_EXAMPLES_FLAG_HELP_H_

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "gflags/gflags.h"

namespace hetslam {

// Call after gflags::SetUsageMessage and before gflags::ParseCommandLineFlags: when the
// arguments ask for help (--help, -help, -h), prints the usage and every flag defined in the
// calling program's source file (name, type, default, description), then exits with 0.
inline void PrintProgramHelpIfAsked(int argc, char** argv, const char* program_source_file) {
  bool asked = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    asked = asked || arg == "--help" || arg == "-help" || arg == "-h" || arg == "--h";
  }
  if (!asked) return;
  std::printf("%s\n\nFlags:\n", gflags::ProgramUsage());
  std::vector<gflags::CommandLineFlagInfo> flags;
  gflags::GetAllFlags(&flags);  // sorted by file, then name
  for (const gflags::CommandLineFlagInfo& flag : flags) {
    if (flag.filename != program_source_file) continue;
    std::string default_value = flag.default_value.empty() ? "\"\"" : flag.default_value;
    if (flag.type == "double") {
      char buffer[64];
      std::snprintf(buffer, sizeof(buffer), "%.10g", std::strtod(flag.default_value.c_str(), nullptr));
      default_value = buffer;
    }
    std::printf("  --%s (%s, default: %s)\n      %s\n", flag.name.c_str(), flag.type.c_str(),
                default_value.c_str(), flag.description.c_str());
  }
  std::printf("\nglog's logging flags (--v, --logtostderr, ...) are accepted too; --helpfull lists them.\n");
  std::exit(0);
}

}  // namespace hetslam

#endif  // HETSLAM_EXAMPLES_FLAG_HELP_H_
