// The plugin loader (core/plugin_loader.h): candidates in order, the variable alone when set,
// every failure named with its path and reason, a table refused by its check not used.
#include "core/plugin_loader.h"

#include <dlfcn.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "glog/logging.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

// The table of tests/core/plugin_loader_test_module.cc, the same type (global, same name) as
// there, so that its entry point is called with its true type.
struct TestPluginTable {
  uint32_t abi_version;
  uint64_t layout_fingerprint;
  const char* compiler;
  int (*answer)();
};

namespace hetslam {
namespace {

using ::testing::HasSubstr;
constexpr auto kCall = &CallPluginEntryPoint<TestPluginTable>;

const std::string kModule = HETSLAM_TEST_PLUGIN_PATH;
constexpr char kEntry[] = "hetslam_test_plugin_api";

std::string CheckTestTable(const void* table) {
  const auto& t = *static_cast<const TestPluginTable*>(table);
  return PluginBuildMismatch(t.abi_version, 7, t.layout_fingerprint, 1234, t.compiler);
}

TEST(PluginLoaderTest, ATableThatPassesItsCheckIsReturnedWithItsPath) {
  const LoadedPluginTable loaded = LoadPluginTable({kModule}, kEntry, kCall, "test plugin", &CheckTestTable);
  ASSERT_NE(nullptr, loaded.table) << loaded.tried;
  EXPECT_EQ(kModule, loaded.path);
  EXPECT_EQ(42, static_cast<const TestPluginTable*>(loaded.table)->answer());
  EXPECT_EQ("", loaded.tried);
  // Bound lazily: the same table (the module is loaded once per process).
  const LoadedPluginTable lazy =
      LoadPluginTable({kModule}, kEntry, kCall, "test plugin", &CheckTestTable, PluginBinding::kLazy);
  EXPECT_EQ(loaded.table, lazy.table);
}

TEST(PluginLoaderTest, CandidatesAreTriedInOrderAndEachFailureIsNamed) {
  const std::string missing = "/nonexistent/libplugin.so";
  LoadedPluginTable loaded = LoadPluginTable({missing, kModule}, kEntry, kCall, "test plugin", &CheckTestTable);
  ASSERT_NE(nullptr, loaded.table) << loaded.tried;
  EXPECT_EQ(kModule, loaded.path);

  loaded = LoadPluginTable({missing, "/nonexistent/other.so"}, kEntry, kCall, "test plugin", &CheckTestTable);
  EXPECT_EQ(nullptr, loaded.table);
  EXPECT_THAT(loaded.tried, HasSubstr(missing + " (cannot open shared object file: No such file or directory)"));
  EXPECT_THAT(loaded.tried, HasSubstr(", /nonexistent/other.so ("));
  EXPECT_EQ("no candidate", LoadPluginTable({}, kEntry, kCall, "test plugin", &CheckTestTable).tried);
}

TEST(PluginLoaderTest, ATableOfAnotherBuildIsRefusedWithTheReason) {
  auto other_abi = [](const void* table) {
    const auto& t = *static_cast<const TestPluginTable*>(table);
    return PluginBuildMismatch(t.abi_version, 8, t.layout_fingerprint, 1234, t.compiler);
  };
  LoadedPluginTable loaded = LoadPluginTable({kModule}, kEntry, kCall, "test plugin", other_abi);
  EXPECT_EQ(nullptr, loaded.table);
  EXPECT_EQ(kModule + " (plugin ABI version 7, this hetslam needs 8: a plugin of another hetslam version)",
            loaded.tried);

  auto other_layout = [](const void* table) {
    const auto& t = *static_cast<const TestPluginTable*>(table);
    return PluginBuildMismatch(t.abi_version, 7, t.layout_fingerprint, 99, t.compiler);
  };
  loaded = LoadPluginTable({kModule}, kEntry, kCall, "test plugin", other_layout);
  EXPECT_EQ(nullptr, loaded.table);
  EXPECT_THAT(loaded.tried, HasSubstr("built from other hetslam headers than this program"));

  EXPECT_THAT(PluginBuildMismatch(1, 1, 2, 2, "some other compiler"),
              HasSubstr("built by compiler 'some other compiler', this program by '"));
  EXPECT_EQ("", PluginBuildMismatch(1, 1, 2, 2, __VERSION__));
}

TEST(PluginLoaderTest, AFileThatIsNotALibraryIsRefused) {
  const std::string path = ::testing::TempDir() + "/plugin_loader_test_" + std::to_string(getpid()) + ".so";
  std::ofstream(path) << "not an ELF file, long enough to have a header of one ..................";
  const LoadedPluginTable loaded = LoadPluginTable({path}, kEntry, kCall, "test plugin", &CheckTestTable);
  EXPECT_EQ(nullptr, loaded.table);
  EXPECT_THAT(loaded.tried, HasSubstr(path + " ("));
  EXPECT_THAT(loaded.tried, HasSubstr("ELF"));  // dlerror(): "invalid ELF header"
  std::remove(path.c_str());
}

TEST(PluginLoaderTest, ALibraryWithoutTheEntryPointIsRefused) {
  Dl_info info;  // glog's shared library: loads, but is no plugin
  bool (*glog_function)() = &google::IsGoogleLoggingInitialized;
  ASSERT_NE(0, dladdr(reinterpret_cast<void*>(glog_function), &info));
  const std::string glog = info.dli_fname;
  const LoadedPluginTable loaded = LoadPluginTable({glog}, kEntry, kCall, "test plugin", &CheckTestTable);
  EXPECT_EQ(nullptr, loaded.table);
  EXPECT_EQ(glog + " (no symbol hetslam_test_plugin_api: not a test plugin)", loaded.tried);
}

TEST(PluginLoaderTest, TheVariableIsTheOnlyCandidateWhenSet) {
  constexpr char kVariable[] = "HETSLAM_PLUGIN_LOADER_TEST_PLUGIN";
  ASSERT_EQ(0, setenv(kVariable, "/elsewhere/plugin.so", 1));
  EXPECT_EQ(std::vector<std::string>{"/elsewhere/plugin.so"}, PluginCandidatePaths(kVariable, {"/a.so", "/b.so"}));
  ASSERT_EQ(0, setenv(kVariable, "", 1));  // empty: as if unset
  EXPECT_EQ((std::vector<std::string>{"/a.so", "/b.so"}), PluginCandidatePaths(kVariable, {"/a.so", "/b.so"}));
  ASSERT_EQ(0, unsetenv(kVariable));
  EXPECT_EQ((std::vector<std::string>{"/a.so", "/b.so"}), PluginCandidatePaths(kVariable, {"/a.so", "/b.so"}));
}

}  // namespace
}  // namespace hetslam
