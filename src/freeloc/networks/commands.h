// The network commands' work (pipeline/networks.h: PointmapCommand, SegmentCommand, DepthCommand).
#pragma once

#include "freeloc/pipeline/networks.h"

namespace freeloc::pipeline {

int Pointmap(const PointmapCommand& command);
int Segment(const SegmentCommand& command);
int Depth(const DepthCommand& command);

}  // namespace freeloc::pipeline
