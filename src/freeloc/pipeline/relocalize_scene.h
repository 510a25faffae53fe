// A map-free scene through the Relocalizer (relocalizer.h): the reference's work once, then every query — or, on the
// Multi Frame track, every evaluated frame fused from its window (multi_frame.h). What `freeloc run`
// (run_controller.h), Python's run_scene and the benchmarks call per scene.
#pragma once

#include <functional>
#include <vector>

#include "freeloc/io/mapfree.h"
#include "freeloc/matching/correspondences.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::pipeline {

// The queries (indices into scene.queries) a run answers: every one (track single-frame), or the evaluated frames
// of the Multi Frame track (linear positions 9, 19, …; io/mapfree.h MultiFrameWindows). Throws naming a frame that
// the Multi Frame track cannot order.
std::vector<size_t> AnsweredQueries(const io::MapfreeScene& scene, const PipelineOptions& options);

// Every query of a map-free scene through `reloc` (multi-frame: every evaluated frame, fused from its window,
// pipeline/multi_frame.h); the reference's image, depth, encodings and instances are
// computed once. A failing reference fails every query of the scene; a failing query fails alone (status kError,
// `message` naming the file and the cause) — any exception, LibTorch's included. `on_query` (optional) is called
// after each query.
// `on_matches` (optional) receives each query's correspondences (original pixels) before `on_query`.
using MatchesCallback = std::function<void(const QueryResult&, const matching::Correspondences&)>;
std::vector<QueryResult> RelocalizeScene(const io::MapfreeScene& scene, Relocalizer& reloc,
                                         const std::function<void(const QueryResult&)>& on_query = nullptr,
                                         const MatchesCallback& on_matches = nullptr);
// The same with a Relocalizer made from `options`; `stats` (optional) receives the scene's cache counters.
std::vector<QueryResult> RelocalizeScene(const io::MapfreeScene& scene, const PipelineOptions& options,
                                         CacheStats* stats = nullptr,
                                         const std::function<void(const QueryResult&)>& on_query = nullptr);

}  // namespace freeloc::pipeline
