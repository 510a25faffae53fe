// DUSt3R as a pipeline stage: the model as the matching module's pointmap function (plain, or caching the encoder
// pass of every reference-side input so a scene's reference — and each of its masked instances — is encoded once).
// The per-process model cache is in models.h. Light header: the LibTorch model stays behind a forward declaration.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/matching/instance.h"

namespace freeloc::nn {
class Dust3rModel;
}  // namespace freeloc::nn

namespace freeloc::networks {

// Runs `model` on a preprocessed pair and returns its pointmaps (view 2's points in view 1's frame) on the host;
// a MASt3R model's descriptors too when `descriptors` is set.
matching::PointmapFn Dust3rPointmapFn(std::shared_ptr<nn::Dust3rModel> model, bool descriptors = false);

// The same function, but the first (reference) view's encoder output is kept and reused whenever the same input
// comes again (compared by content: a hash, then the full data). `Clear` forgets them (a new scene). Queries are
// encoded every time. Not thread-safe; one per scene worker.
class CachingDust3r {
 public:
  // `descriptors`: also compute a MASt3R model's descriptors (the matcher matches by descriptors).
  explicit CachingDust3r(std::shared_ptr<nn::Dust3rModel> model, bool descriptors = false);
  ~CachingDust3r();
  CachingDust3r(const CachingDust3r&) = delete;
  CachingDust3r& operator=(const CachingDust3r&) = delete;

  matching::PointmapFn Fn();  // valid while this object lives
  matching::PairPointmaps Run(const vision::Dust3rInput& ref, const vision::Dust3rInput& query);
  // Encodes a reference-side input now (once: later Runs with it reuse the encoding), so a scene's reference work
  // happens when the reference is set, not in its first query.
  void Prime(const vision::Dust3rInput& ref);
  // The last pair run again swapped — its query as view 1, its reference as view 2, both encodings reused — with
  // only head 1: pts1/conf1 are the query's points in the query's own camera frame (MASt3R's query depth,
  // docs/pipeline.md "The MASt3R routes"). Throws before any Run.
  matching::PairPointmaps RunSwappedLast();
  void Clear();
  int encoded() const { return encoded_; }  // reference-side encoder passes run
  int reused() const { return reused_; }    // reference-side encoder passes saved

 private:
  struct Entry;
  const Entry* Cached(const vision::Dust3rInput& ref);  // the entry of `ref`, encoding it when new (counted)
  std::shared_ptr<nn::Dust3rModel> model_;
  bool descriptors_ = false;
  std::vector<std::unique_ptr<Entry>> entries_;
  std::shared_ptr<const void> last_ref_, last_query_;  // encodings of the last Run
  int last_h_ = 0, last_w_ = 0;
  int encoded_ = 0, reused_ = 0;
};

}  // namespace freeloc::networks
