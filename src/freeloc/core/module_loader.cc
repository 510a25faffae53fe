#include "freeloc/core/module_loader.h"

#include <dlfcn.h>

#include <mutex>

#include "freeloc/core/error.h"

namespace freeloc {

std::string ModuleDirectory() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&ModuleDirectory), &info) == 0 || info.dli_fname == nullptr) return "";
  const std::string self = info.dli_fname;
  const size_t slash = self.rfind('/');
  return slash == std::string::npos ? "." : self.substr(0, slash);
}

bool ModuleLoaded(const std::string& library) {
  void* h = dlopen(library.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (h) dlclose(h);  // drops the reference RTLD_NOLOAD took
  return h != nullptr;
}

void* LoadModuleEntry(const std::string& library, const char* entry, const std::string& purpose) {
  static std::mutex mu;
  std::lock_guard<std::mutex> lock(mu);
  // Modules stay loaded for the life of the process (their handles are never closed).
  void* h = dlopen(library.c_str(), RTLD_NOW | RTLD_NOLOAD | RTLD_GLOBAL);
  std::string errors;
  if (!h) {
    const std::string dir = ModuleDirectory();
    if (!dir.empty()) {
      h = dlopen((dir + "/" + library).c_str(), RTLD_NOW | RTLD_GLOBAL);
      if (!h) {
        const char* e = dlerror();
        errors = e ? e : "not found";
      }
    }
  }
  if (!h) {
    h = dlopen(library.c_str(), RTLD_NOW | RTLD_GLOBAL);
    if (!h) {
      const char* e = dlerror();
      errors += std::string(errors.empty() ? "" : "; ") + (e ? e : "not found");
    }
  }
  FREELOC_CHECK(h != nullptr, purpose << " needs " << library << ", which cannot be loaded (" << errors
                                      << "); the freeloc installation is incomplete: reinstall it so that " << library
                                      << " sits beside libfreeloc_core.so");
  dlerror();
  void* f = dlsym(h, entry);
  FREELOC_CHECK(f != nullptr, library << " has no " << entry << "; it belongs to another freeloc version: reinstall");
  return f;
}

}  // namespace freeloc
