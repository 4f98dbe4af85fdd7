#include "continuum_module.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace demfem::app {

namespace {

namespace fs = std::filesystem;

// PETSc (initialised with MPI by deal.II in the module) replaces the handlers of SIGTERM, SIGHUP
// and others with its own, which end the process at once (exit 143, 129): without them the
// app's handlers (signals.hpp) stop a continuum run cleanly. Added to the user's PETSC_OPTIONS.
void keep_stop_signals() {
  const char* env = std::getenv("PETSC_OPTIONS");
  std::string opts = env ? env : "";
  if (opts.find("-no_signal_handler") != std::string::npos) return;
  opts += opts.empty() ? "-no_signal_handler" : " -no_signal_handler";
  ::setenv("PETSC_OPTIONS", opts.c_str(), 1);
}

const continuum::ModuleApi* open_module() {
  keep_stop_signals();
  std::vector<fs::path> tried;
  if (const char* env = std::getenv("DEMFEM_CONTINUUM_MODULE"); env && *env) {
    tried.emplace_back(env); // an explicit choice: nothing else is tried
  } else {
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) tried.push_back(self.parent_path() / continuum::kModuleFile);
#ifdef DEMFEM_CONTINUUM_MODULE_BUILD_PATH
    if (tried.empty() || tried.back() != fs::path(DEMFEM_CONTINUUM_MODULE_BUILD_PATH))
      tried.emplace_back(DEMFEM_CONTINUUM_MODULE_BUILD_PATH);
#endif
  }
  std::string why;
  for (const auto& p : tried) {
    // RTLD_GLOBAL: MPI opens its own components and expects its symbols to be visible to them.
    void* h = dlopen(p.c_str(), RTLD_NOW | RTLD_GLOBAL);
    if (!h) {
      const char* e = dlerror();
      why += "\n  " + (e ? std::string(e) : p.string() + ": cannot be opened"); // e names p
      continue;
    }
    using Entry = const continuum::ModuleApi* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(h, continuum::kModuleEntry));
    const continuum::ModuleApi* api = entry ? entry() : nullptr;
    if (!api) {
      why += fmt::format("\n  {}: no {} in it", p.string(), continuum::kModuleEntry);
      continue;
    }
    if (api->abi != continuum::kModuleAbi || api->size != sizeof(continuum::ModuleApi)) {
      why += fmt::format("\n  {}: built from another version of demfem (module interface {}, "
                         "this program {})",
                         p.string(), api->abi, continuum::kModuleAbi);
      continue;
    }
    return api; // the handle stays open for the life of the process
  }
  throw std::runtime_error(fmt::format(
      "the continuum solver module ({}) could not be loaded:{}\nIt is built with demfem (CMake "
      "target demfem_continuum_module) and installed beside the program; "
      "DEMFEM_CONTINUUM_MODULE=<path> names another one.",
      continuum::kModuleFile, why.empty() ? std::string("\n  (no path to try)") : why));
}

} // namespace

const continuum::ModuleApi& continuum_module() {
  static std::mutex m;
  static const continuum::ModuleApi* api = nullptr;
  const std::lock_guard<std::mutex> lock(m);
  if (!api) api = open_module(); // a failure is retried (and reported) at the next call
  return *api;
}

} // namespace demfem::app
