// The networks module's entry point (pipeline/networks.h), looked up by pipeline::Networks().
#include "freeloc/networks/bindings.h"
#include "freeloc/networks/commands.h"
#include "freeloc/networks/stages.h"
#include "freeloc/pipeline/networks.h"

namespace {
const freeloc::pipeline::NetworksApi kApi = {
    freeloc::pipeline::kNetworksAbi,      freeloc::pipeline::MakeNetworkMatcher,
    freeloc::pipeline::MakeNetworkDepthEstimator, freeloc::pipeline::Pointmap,
    freeloc::pipeline::Segment,           freeloc::pipeline::Depth,
    freeloc::pipeline::LoadBoundNetwork,  freeloc::pipeline::BoundNetworkFamily,
    freeloc::pipeline::RunBoundPointmaps, freeloc::pipeline::RunBoundDepth,
    freeloc::pipeline::RunBoundSegment,
};
}  // namespace

extern "C" __attribute__((visibility("default"))) const freeloc::pipeline::NetworksApi* freeloc_networks_v1() {
  return &kApi;
}
