// MASt3R's fast reciprocal nearest neighbours on dense descriptors (naver/mast3r mast3r/fast_nn.py
// fast_reciprocal_NNs): seeds on a subsample grid of view 1, alternate NN₂ / NN₁ lookups until
// each seed holds a mutual nearest-neighbour pair (at most 10 rounds; unconverged seeds dropped), deduplicated and
// sorted by (view-1 index, view-2 index) — upstream's output, row for row.
//
// Similarity is the dot product; NN is its arg-max with ties to the smallest index (upstream's torch.max rule).
// Never materialises a similarity matrix: each lookup batch is screened with a blocked kernel (int8 dot products
// with AVX-512 VNNI where the CPU has it, float32 otherwise) that keeps, per query, every database point whose
// screened similarity is within the kernel's proven error bound of the best; those few candidates are then scored
// exactly (double, fixed order) and the arg-max taken among them. The result equals the exhaustive arg-max of the
// exact similarities (FastReciprocalNNBruteForce), whatever the thread count. NN results are memoised per pixel
// across rounds; the reported call sizes are upstream's logical ones.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/matching/reciprocal.h"

namespace freeloc::matching {

struct DescriptorView {
  const float* desc = nullptr;       // H×W×D, row-major (unit vectors from MASt3R; any finite vectors work)
  const float* desc_conf = nullptr;  // H×W (may be null: confidences 0)
  int height = 0, width = 0, dim = 0;
};

enum class NnKernel { kAuto, kInt8Vnni, kFloat32 };

struct FastNnOptions {
  int subsample = 8;    // seed grid step S: seeds at S//2 + k·S in x and y of view 1 (upstream subsample_or_initxy1)
  int max_rounds = 10;  // upstream's limit; seeds not converged by then are dropped
  int threads = 0;      // 0 = hardware concurrency
  NnKernel kernel = NnKernel::kAuto;  // screening kernel (results do not depend on it)
  void Validate() const;
};

struct FastNnStats {
  std::vector<int32_t> seeds;        // flat view-1 indices y·W₁ + x, ascending
  std::vector<int64_t> query_sizes;  // upstream's logical NN call sizes, in order
  int rounds = 0;
  int dropped = 0;           // seeds not converged within max_rounds (or with no valid neighbour)
  int invalid_pixels = 0;    // descriptors with a NaN/inf component (never selected, never seeded)
  int64_t lookups = 0;       // NN lookups actually computed (after memoisation and deduplication)
  int64_t candidates = 0;    // database points scored exactly after screening
  double tiles_skipped = 0;  // int8 kernel: fraction of (8-query group, 16×16-pixel tile) pairs its bound skipped
  std::string kernel;        // "int8-vnni" or "float32"
  double ms = 0;
};

// Raw matches (x1, y1, x2, y2) in network pixels, upstream order; conf1/conf2 = desc_conf at the pixels (0 without).
std::vector<PixelMatch> FastReciprocalNN(const DescriptorView& view1, const DescriptorView& view2,
                                         const FastNnOptions& options = {}, FastNnStats* stats = nullptr);

// The same algorithm with exhaustive NN lookups (every database point scored exactly): the reference the fast path
// must equal, for tests and bench/matching.
std::vector<PixelMatch> FastReciprocalNNBruteForce(const DescriptorView& view1, const DescriptorView& view2,
                                                   const FastNnOptions& options = {}, FastNnStats* stats = nullptr);

// The filters applied after matching (naver/mast3r mast3r/fast_nn.py), order preserved: a match is kept iff
// border ≤ x < W − border and border ≤ y < H − border in both images (each view's own size; upstream's demo: 3), and
// min(conf1, conf2) ≥ min_conf (visloc: 1.001; 0 keeps everything).
struct DescriptorMatchFilter {
  int border = 3;
  double min_conf = 0;
  void Validate() const;
};
std::vector<PixelMatch> FilterDescriptorMatches(const std::vector<PixelMatch>& matches, int w1, int h1, int w2, int h2,
                                                const DescriptorMatchFilter& filter);

// Whether this CPU runs the int8 VNNI screening kernel.
bool CpuHasVnni();

}  // namespace freeloc::matching
