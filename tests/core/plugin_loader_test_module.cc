// A plugin for tests/core/plugin_loader_test.cc: exports one entry point returning a table whose
// first fields say which build it comes from (core/plugin_loader.h).
#include <cstdint>

struct TestPluginTable {
  uint32_t abi_version;
  uint64_t layout_fingerprint;
  const char* compiler;
  int (*answer)();
};

namespace {
int Answer() { return 42; }
const TestPluginTable kTable = {7, 1234, __VERSION__, &Answer};
}  // namespace

extern "C" __attribute__((visibility("default"))) const TestPluginTable* hetslam_test_plugin_api(void) {
  return &kTable;
}
