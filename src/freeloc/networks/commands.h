// The network commands' work (pipeline/networks.h: PointmapCommand, SegmentCommand, DepthCommand).
#pragma once

#include "freeloc/pipeline/networks.h"

namespace freeloc::networks {

int Pointmap(const pipeline::PointmapCommand& command);
int Segment(const pipeline::SegmentCommand& command);
int Depth(const pipeline::DepthCommand& command);

}  // namespace freeloc::networks
