#include "freeloc/pipeline/networks.h"

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/module_loader.h"

namespace freeloc::pipeline {

const NetworksApi& Networks() {
  static const NetworksApi* api = [] {
    const bool linked = ModuleLoaded(kNetworksLibrary);
    using Entry = const NetworksApi* (*)();
    const auto entry =
        reinterpret_cast<Entry>(LoadModuleEntry(kNetworksLibrary, kNetworksEntry, "running a network"));
    const NetworksApi* a = entry();
    FREELOC_CHECK(a && a->abi == kNetworksAbi, kNetworksLibrary << " belongs to another freeloc version; reinstall");
    if (!linked) FREELOC_LOG(DEBUG) << "loaded the networks module (LibTorch) from " << ModuleDirectory();
    return a;
  }();
  return *api;
}

bool NetworksLoaded() { return ModuleLoaded(kNetworksLibrary); }

}  // namespace freeloc::pipeline
