#include "core/plugin_loader.h"

#include <dlfcn.h>

#include <cstdlib>
#include <cstring>

namespace hetslam {
namespace {

// dlerror()'s text without the path it usually starts with (the message names the path).
std::string DlErrorText(const std::string& path) {
  const char* error = dlerror();
  std::string text = error != nullptr ? error : "unknown dlopen error";
  if (text.compare(0, path.size() + 2, path + ": ") == 0) text.erase(0, path.size() + 2);
  return text;
}

}  // namespace

std::vector<std::string> PluginCandidatePaths(const char* variable, const std::vector<std::string>& built_in) {
  const char* value = std::getenv(variable);
  if (value != nullptr && value[0] != '\0') return {value};
  return built_in;
}

LoadedPluginTable LoadPluginTable(const std::vector<std::string>& candidates, const char* entry_point,
                                  const void* (*call_entry)(void* symbol), const char* kind, const std::function<std::string(const void* table)>& check,
                                  PluginBinding binding) {
  LoadedPluginTable loaded;
  std::string tried;
  for (const std::string& path : candidates) {
    if (!tried.empty()) tried += ", ";
    tried += path;
    void* handle = dlopen(path.c_str(), (binding == PluginBinding::kNow ? RTLD_NOW : RTLD_LAZY) | RTLD_LOCAL);
    if (handle == nullptr) {
      tried += " (" + DlErrorText(path) + ")";
      continue;
    }
    dlerror();  // clear, so that a null dlsym answer is told apart below
    void* entry = dlsym(handle, entry_point);
    if (entry == nullptr) {
      tried += std::string(" (no symbol ") + entry_point + ": not a " + kind + ")";
      continue;
    }
    const void* table = call_entry(entry);
    const std::string mismatch = table != nullptr ? check(table) : "its table is null";
    if (!mismatch.empty()) {
      tried += " (" + mismatch + ")";
      continue;
    }
    loaded.table = table;
    loaded.path = path;
    return loaded;
  }
  loaded.tried = tried.empty() ? "no candidate" : tried;
  return loaded;
}

std::string PluginBuildMismatch(uint32_t abi_version, uint32_t expected_abi_version, uint64_t layout_fingerprint,
                                uint64_t expected_layout_fingerprint, const char* compiler) {
  if (abi_version != expected_abi_version) {
    return "plugin ABI version " + std::to_string(abi_version) + ", this hetslam needs " +
           std::to_string(expected_abi_version) + ": a plugin of another hetslam version";
  }
  if (layout_fingerprint != expected_layout_fingerprint) {
    return "built from other hetslam headers than this program (a stale plugin of an older build?)";
  }
  if (compiler == nullptr || std::strcmp(compiler, __VERSION__) != 0) {
    return std::string("built by compiler '") + (compiler != nullptr ? compiler : "?") + "', this program by '" +
           __VERSION__ + "'";
  }
  return "";
}

}  // namespace hetslam
