// Loading hetslam's plugins: MODULE libraries that a library file dlopens the first time their
// code is needed, so that the heavy libraries a plugin links are mapped only into the processes
// that use them. Two exist: the ROS bag plugin (core/ros_bag_plugin.h: ROS, Python, Boost) and
// the map picture's drawing plugin (merger/map_picture_plugin.h: OpenCV with GL, X11 and TBB).
//
// A plugin exports one C function (its entry point) returning a table of function pointers
// whose first fields say which build it comes from. Each plugin's header defines its table, its
// ABI version and the check of a table against this build; this file finds the candidates,
// opens them in order and returns the first table that passes, or why none did.
#ifndef HETSLAM_CORE_PLUGIN_LOADER_H_
#define HETSLAM_CORE_PLUGIN_LOADER_H_

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <string>
#include <vector>

namespace hetslam {

struct LoadedPluginTable {
  const void* table = nullptr;  // the entry point's answer that passed the check; null when none did
  std::string path;             // the file that passed
  // When table is null: "tried A (why), B (why)", every candidate with dlerror()'s text or the
  // check it failed; "no candidate" when there was none.
  std::string tried;
};

// The paths to try: the value of the environment variable `variable` alone when it is set and
// not empty (the user's explicit choice: when it names a file that does not load, the error
// says so rather than another plugin being used silently), else `built_in` in order.
std::vector<std::string> PluginCandidatePaths(const char* variable, const std::vector<std::string>& built_in);

// When the plugin's calls into its libraries are bound. A missing library fails at dlopen either
// way, with its name.
enum class PluginBinding {
  kNow,   // every symbol at dlopen (RTLD_NOW): a missing one fails there, not at the first call
  kLazy,  // at the first call of each (RTLD_LAZY), as for a linked library: the symbol tables of
          // the plugin's libraries are not all read (OpenCV's: 0.4 MiB resident)
};

// Calls a plugin's entry point, the symbol found, with its true type `const Table* (*)()` (a call
// through another function type is undefined behaviour, which clang's sanitizer reports).
template <typename Table>
const void* CallPluginEntryPoint(void* symbol) {
  return reinterpret_cast<const Table* (*)()>(symbol)();
}

// dlopen(... | RTLD_LOCAL)s each candidate in order (RTLD_LOCAL: the plugin's libraries' symbols
// stay out of the program's namespace), calls `entry_point` through `call_entry` (e.g.
// CallPluginEntryPoint<RosBagPluginApi>) and passes its table to `check`,
// which returns "" when the table may be used, else why not. `kind` names the plugin in messages
// ("hetslam ROS bag plugin"). A file that opened but failed stays mapped (never dlclosed:
// libraries it brought in may have registered exit handlers), unused.
LoadedPluginTable LoadPluginTable(const std::vector<std::string>& candidates, const char* entry_point,
                                  const void* (*call_entry)(void* symbol), const char* kind,
                                  const std::function<std::string(const void* table)>& check,
                                  PluginBinding binding = PluginBinding::kNow);

// A fingerprint of the sizes and alignments of the types a plugin's table exchanges (FNV-1a),
// computed on each side of the boundary from the headers that side was compiled with: a field
// added to one of them on one side changes it (a reordering of same-size fields does not: the
// ABI version is for that).
constexpr uint64_t PluginLayoutFingerprint(std::initializer_list<uint64_t> sizes) {
  uint64_t hash = 14695981039346656037ull;
  for (const uint64_t value : sizes) hash = (hash ^ value) * 1099511628211ull;
  return hash;
}

// The usual check of a table's first fields: "" when they are this build's, else why not.
std::string PluginBuildMismatch(uint32_t abi_version, uint32_t expected_abi_version, uint64_t layout_fingerprint,
                                uint64_t expected_layout_fingerprint, const char* compiler);

}  // namespace hetslam

#endif  // HETSLAM_CORE_PLUGIN_LOADER_H_
