// The networks module's entry point (pipeline/networks.h), looked up by pipeline::Networks().
#include "freeloc/networks/bindings.h"
#include "freeloc/networks/commands.h"
#include "freeloc/networks/network_stages.h"
#include "freeloc/pipeline/networks.h"

namespace {
const freeloc::pipeline::NetworksApi kApi = {
    freeloc::pipeline::kNetworksAbi,
    freeloc::networks::MakeNetworkMatcher,
    freeloc::networks::MakeNetworkDepthEstimator,
    freeloc::networks::Pointmap,
    freeloc::networks::Segment,
    freeloc::networks::Depth,
    freeloc::networks::LoadBoundNetwork,
    freeloc::networks::BoundNetworkFamily,
    freeloc::networks::RunBoundPointmaps,
    freeloc::networks::RunBoundDepth,
    freeloc::networks::RunBoundSegment,
};
}  // namespace

extern "C" __attribute__((visibility("default"))) const freeloc::pipeline::NetworksApi* freeloc_networks_v1() {
  return &kApi;
}
