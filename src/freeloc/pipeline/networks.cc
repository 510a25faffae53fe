#include "freeloc/pipeline/networks.h"

#include "freeloc/core/logging.h"
#include "freeloc/core/module_loader.h"

namespace freeloc::pipeline {

const NetworksApi& Networks() {
  static const NetworksApi& api = []() -> const NetworksApi& {
    const bool linked = ModuleLoaded(kNetworksLibrary);
    const NetworksApi& a =
        LoadModuleTable<NetworksApi>(kNetworksLibrary, kNetworksEntry, kNetworksAbi, "running a network");
    if (!linked) FREELOC_LOG(DEBUG) << "loaded the networks module (LibTorch) from " << ModuleDirectory();
    return a;
  }();
  return api;
}

bool NetworksLoaded() { return ModuleLoaded(kNetworksLibrary); }

}  // namespace freeloc::pipeline
