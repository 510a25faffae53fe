// The built-in stages (stages.h) and the factories that make them from PipelineOptions: SIFT and precomputed
// matchers, provided and no depth, the pose room's solver fronts; the network stages through Networks()
// (networks.h), which loads the networks module.
#include <chrono>

#include "freeloc/core/error.h"
#include "freeloc/core/timing.h"
#include "freeloc/matching/sift.h"
#include "freeloc/pipeline/networks.h"
#include "freeloc/pipeline/stages.h"
#include "freeloc/pose/estimate_pose.h"

namespace freeloc::pipeline {

namespace {

// ----------------------------------------------------------------------------------------------------------------
// Matchers

class SiftMatcher : public Matcher {
 public:
  void SetReference(const Image& image, const Camera&, const std::vector<uint16_t>*) override {
    ref_ = matching::ExtractSift(image);
  }
  matching::Correspondences Match(const Image& query, const Camera&, const FrameInputs&, QueryResult* r) override {
    const auto t0 = std::chrono::steady_clock::now();
    auto c = matching::MatchSiftFeatures(ref_, matching::ExtractSift(query));
    r->timings.match_ms = MsSince(t0);
    return c;
  }

 private:
  matching::SiftFeatures ref_;
};

class PrecomputedMatcher : public Matcher {
 public:
  explicit PrecomputedMatcher(std::string name) : name_(std::move(name)) {}
  void SetReference(const Image&, const Camera&, const std::vector<uint16_t>*) override {}
  matching::Correspondences Match(const Image&, const Camera&, const FrameInputs& in, QueryResult*) override {
    FREELOC_CHECK(in.correspondences != nullptr, "matcher precomputed:" << name_ << " was given no correspondences");
    return matching::Correspondences::FromRows(*in.correspondences);
  }

 private:
  std::string name_;
};

// ----------------------------------------------------------------------------------------------------------------
// Depth

class NoDepth : public DepthEstimator {
 public:
  DepthMap Depth(const Image&, const Camera&, DepthMap) override { return {}; }
};

class ProvidedDepth : public DepthEstimator {
 public:
  DepthMap Depth(const Image&, const Camera&, DepthMap provided) override { return provided; }
  bool needs_provided() const override { return true; }
};

// ----------------------------------------------------------------------------------------------------------------
// Solvers: the pose room's fronts (pose/estimate_pose.h) as the PoseSolver stage.

class BuiltinPoseSolver : public PoseSolver {
 public:
  BuiltinPoseSolver(SolverKind solver, const SolveOptions& options) : solver_(solver), options_(options) {}
  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    static_cast<pose::PoseEstimate&>(*r) = pose::EstimatePose(solver_, options_, c, k_ref, k_query, d_ref, d_query);
    r->timings.solve_ms = MsSince(t0);
  }

 private:
  SolverKind solver_;
  pose::SolveOptions options_;
};

}  // namespace

std::unique_ptr<Matcher> MakeMatcher(const PipelineOptions& o) {
  switch (o.matcher.kind) {
    case MatcherKind::kSift: return std::make_unique<SiftMatcher>();
    case MatcherKind::kPrecomputed: return std::make_unique<PrecomputedMatcher>(o.matcher.correspondences);
    case MatcherKind::kDust3r:
    case MatcherKind::kDust3rInstances:
    case MatcherKind::kMast3r:
    case MatcherKind::kMast3rInstances:
      return Networks().make_matcher(o);  // loads the networks module (LibTorch) on first use
  }
  FREELOC_THROW("matcher: " << o.matcher.ToString() << " has no implementation");
}

std::unique_ptr<DepthEstimator> MakeDepthEstimator(const PipelineOptions& o) {
  switch (o.depth.kind) {
    case DepthKind::kMetric3d: return Networks().make_depth_estimator(o);
    case DepthKind::kProvided: return std::make_unique<ProvidedDepth>();
    case DepthKind::kNone: return std::make_unique<NoDepth>();
    case DepthKind::kMast3r: return std::make_unique<NoDepth>();  // the matcher's pair pass gives it (PairDepth)
  }
  FREELOC_THROW("depth: " << o.depth.ToString() << " has no implementation");
}

std::unique_ptr<PoseSolver> MakePoseSolver(const PipelineOptions& o) {
  return std::make_unique<BuiltinPoseSolver>(o.solver, o.solve);
}

}  // namespace freeloc::pipeline
