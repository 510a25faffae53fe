// Fast reciprocal NN (mast3r/fast_nn.py fast_reciprocal_NNs, naver/mast3r f5209af).
//
// Exactness of the screened lookups. For a query q and database points x_j let s_j = q·x_j (real numbers) and ŝ_j
// the kernel's screened value with |ŝ_j − s_j| ≤ ε(q) for every j (bounds below). Let m = max ŝ_j. The exact
// arg-max j* satisfies ŝ_j* ≥ s_j* − ε ≥ s_jm − ε ≥ m − 2ε, so every point with ŝ_j ≥ m − 2ε is kept as a candidate
// and j* is among them. Candidates are scored with the exact similarity (double products of floats are exact; the
// sum runs in a fixed order, so it is the same number the brute-force path computes) and combined with ⊕ (larger
// value, then smaller index), which gives the exhaustive answer.
//   int8 (VNNI): q̃ = round(q·s_q)/s_q with s_q = 127/max|q_i| per query, x̃ likewise with one s_x for the
//     database; the integer dot product is exact, and |q·x − q̃·x̃| ≤ ‖q‖₁·0.5/s_x + (‖x‖₁ + D·0.5/s_x)·0.5/s_q.
//   float32: a D-term float sum (any order, with or without FMA) is within γ_D·Σ|q_i x_i| ≤ γ_D·‖q‖₂·‖x‖₂ of the
//     real value, γ_D = D·u/(1 − D·u), u = 2⁻²⁴.
#include "freeloc/matching/fast_nn.h"

// GCC 12's _mm512_max_epi32 passes _mm512_undefined_epi32() as a masked-off source, which -Wmaybe-uninitialized
// reports as a use of an uninitialised value; the lanes are never read.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <thread>

#include "freeloc/core/checked_math.h"
#include "freeloc/core/error.h"

namespace freeloc::matching {

void FastNnOptions::Validate() const {
  FREELOC_CHECK(subsample >= 1, "subsample: " << subsample << " must be >= 1 (the seed grid step of fast NN)");
  FREELOC_CHECK(max_rounds >= 1 && max_rounds <= 1000, "fast NN: max_rounds " << max_rounds << " must be in 1..1000");
  FREELOC_CHECK(threads >= 0, "matching: threads must be >= 0");
}

void DescriptorMatchFilter::Validate() const {
  FREELOC_CHECK(border >= 0, "border: " << border << " must be >= 0 pixels");
  FREELOC_CHECK(std::isfinite(min_conf), "min_conf: must be a finite number");
}

bool CpuHasVnni() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
         __builtin_cpu_supports("avx512vnni");
#else
  return false;
#endif
}

namespace {

constexpr int kLanes = 16;        // database points per block
constexpr int kRows = 8;          // queries per register block
constexpr int kTileBlocks = 256;  // blocks per cache tile (4096 points)
// int8 layout: a block is a 4×4-pixel square; a super-block (the unit the bound prunes) a kSuperPx × kSuperPx tile.
constexpr int kSuperPx = 8;
constexpr int kSuperBlocks = (kSuperPx / 4) * (kSuperPx / 4);

// The exact similarity: float products are exact in double; the sum runs in index order.
inline double ExactDot(const float* a, const float* b, int D) {
  double s = 0;
  for (int d = 0; d < D; ++d) s += static_cast<double>(a[d]) * static_cast<double>(b[d]);
  return s;
}

// (v, i) ⊕ (bv, bi): the larger value; on equal values the smaller index. NaN never wins.
inline bool Better(double v, int i, double bv, int bi) { return v > bv || (v == bv && bi >= 0 && i < bi); }

struct Candidate {
  int q;
  int idx;
  double val;  // the screened similarity, in the kernel's units
};

void CheckView(const DescriptorView& v, const char* which) {
  FREELOC_CHECK(
      v.desc != nullptr && v.height > 0 && v.width > 0 && v.dim > 0,
      "fast NN: " << which << " descriptors are empty (" << v.width << "x" << v.height << "x" << v.dim << ")");
  const int64_t pixels = CheckedMul(v.height, v.width, "descriptor map");
  FREELOC_CHECK(pixels < (int64_t{1} << 30), "fast NN: " << which << " has " << pixels << " pixels; too many");
  (void)CheckedMul(pixels, v.dim, "descriptor map");
}

int Threads(int t) { return std::max(1, t > 0 ? t : static_cast<int>(std::thread::hardware_concurrency())); }

// work(t) for t = 0 … nt − 1, on nt threads (the calling one alone when nt is 1).
template <typename Fn>
void RunOnThreads(int nt, const Fn& work) {
  if (nt == 1) return work(0);
  std::vector<std::thread> pool;
  for (int t = 0; t < nt; ++t) pool.emplace_back(work, t);
  for (auto& th : pool) th.join();
}

// One view's descriptors as the searched database, packed once per pair and direction.
class Database {
 public:
  Database(const DescriptorView& v, NnKernel kernel)
      : x_(v.desc), M_(v.height * v.width), D_(v.dim), W_(v.width), H_(v.height) {
    valid_.assign(static_cast<size_t>(M_), 1);
    for (int j = 0; j < M_; ++j) {
      const float* p = x_ + static_cast<size_t>(j) * D_;
      double l1 = 0, l2 = 0, amax = 0;
      bool ok = true;
      for (int d = 0; d < D_; ++d) {
        if (!std::isfinite(p[d])) ok = false;
        l1 += std::abs(p[d]);
        l2 += static_cast<double>(p[d]) * p[d];
        amax = std::max(amax, static_cast<double>(std::abs(p[d])));
      }
      if (!ok) {
        valid_[static_cast<size_t>(j)] = 0;
        ++invalid_;
        continue;
      }
      l1max_ = std::max(l1max_, l1);
      l2max_ = std::max(l2max_, std::sqrt(l2));
      absmax_ = std::max(absmax_, amax);
    }
    nblk_ = (M_ + kLanes - 1) / kLanes;
    int8_ = kernel == NnKernel::kInt8Vnni || (kernel == NnKernel::kAuto && CpuHasVnni());
    if (int8_) {
      PackInt8();
      PackSample8();
    } else {
      PackFloat();
    }
  }

  int size() const { return M_; }
  int dim() const { return D_; }
  bool valid(int j) const { return valid_[static_cast<size_t>(j)] != 0; }
  int invalid() const { return invalid_; }
  const float* row(int j) const { return x_ + static_cast<size_t>(j) * D_; }
  bool int8() const { return int8_; }

  // Arg-max of the exact similarity over the database for each query row (n × D floats); −1 for a query with a
  // non-finite component or a database without valid points.
  void Nearest(const std::vector<const float*>& queries, int threads, std::vector<int>* out,
               int64_t* candidates) const {
    const int n = static_cast<int>(queries.size());
    out->assign(static_cast<size_t>(n), -1);
    if (n == 0 || invalid_ == M_) return;
    std::vector<char> qok(static_cast<size_t>(n), 1);
    for (int i = 0; i < n; ++i)
      for (int d = 0; d < D_; ++d)
        if (!std::isfinite(queries[static_cast<size_t>(i)][d])) qok[static_cast<size_t>(i)] = 0;
    const int nt = std::min(Threads(threads), std::max(1, (int8_ ? nblk8_ : nblk_) / 64));
    std::vector<std::vector<Candidate>> cand(static_cast<size_t>(nt));
    std::vector<double> best_screen(static_cast<size_t>(n), -std::numeric_limits<double>::infinity());
    std::vector<double> thr(static_cast<size_t>(n));
    if (int8_)
      ScreenInt8All(queries, nt, &cand, &best_screen, &thr);
    else
      ScreenFloatAll(queries, nt, &cand, &best_screen, &thr);
    // Exact scoring of the candidates within 2ε of the best screened value, each thread its own list, combined with ⊕
    // (any order gives the same answer).
    std::vector<std::vector<double>> bv(
        static_cast<size_t>(nt), std::vector<double>(static_cast<size_t>(n), -std::numeric_limits<double>::infinity()));
    std::vector<std::vector<int>> bi(static_cast<size_t>(nt), std::vector<int>(static_cast<size_t>(n), -1));
    std::vector<int64_t> scored_t(static_cast<size_t>(nt), 0);
    RunOnThreads(nt, [&](int t) {
      std::vector<double>& v_t = bv[static_cast<size_t>(t)];
      std::vector<int>& i_t = bi[static_cast<size_t>(t)];
      for (const Candidate& c : cand[static_cast<size_t>(t)]) {
        const size_t q = static_cast<size_t>(c.q);
        if (!qok[q] || !valid(c.idx) || c.val < best_screen[q] - thr[q]) continue;
        const double v = ExactDot(queries[q], row(c.idx), D_);
        ++scored_t[static_cast<size_t>(t)];
        if (Better(v, c.idx, v_t[q], i_t[q])) {
          v_t[q] = v;
          i_t[q] = c.idx;
        }
      }
    });
    int64_t scored = 0;
    for (int t = 0; t < nt; ++t) {
      scored += scored_t[static_cast<size_t>(t)];
      for (int q = 0; q < n; ++q) {
        const double v = bv[static_cast<size_t>(t)][static_cast<size_t>(q)];
        const int i = bi[static_cast<size_t>(t)][static_cast<size_t>(q)];
        if (i >= 0 && (t == 0 || Better(v, i, bv[0][static_cast<size_t>(q)], bi[0][static_cast<size_t>(q)]))) {
          bv[0][static_cast<size_t>(q)] = v;
          bi[0][static_cast<size_t>(q)] = i;
        }
      }
    }
    *out = bi[0];
    for (int i = 0; i < n; ++i)
      if (!qok[static_cast<size_t>(i)]) (*out)[static_cast<size_t>(i)] = -1;
    if (candidates) *candidates += scored;
  }

  // Brute force: every valid point scored exactly, in index order.
  int NearestExhaustive(const float* q) const {
    for (int d = 0; d < D_; ++d)
      if (!std::isfinite(q[d])) return -1;
    double bv = -std::numeric_limits<double>::infinity();
    int bi = -1;
    for (int j = 0; j < M_; ++j) {
      if (!valid(j)) continue;
      const double v = ExactDot(q, row(j), D_);
      if (Better(v, j, bv, bi)) {
        bv = v;
        bi = j;
      }
    }
    return bi;
  }

 private:
  // The int8 layout: kSuperPx × kSuperPx tiles (super-blocks) in row-major order, each of 4×4-pixel blocks (16 lanes),
  // so that a block and a super-block hold neighbouring pixels — MASt3R descriptors vary smoothly, and a
  // super-block's bound then prunes most of the map for each query (ScreenInt8RangeT). Codes round(x·s_x) + 128.
  void PackInt8() {
    D4_ = (D_ + 3) / 4;
    sx_ = absmax_ > 0 ? 127.0 / absmax_ : 1.0;
    const int tw = (W_ + kSuperPx - 1) / kSuperPx, th = (H_ + kSuperPx - 1) / kSuperPx;
    nsup_ = tw * th;
    nblk8_ = nsup_ * kSuperBlocks;
    const int Dp = D4_ * 4;
    packed8_.assign(static_cast<size_t>(nblk8_) * D4_ * 64, 128);
    pix_.assign(static_cast<size_t>(nblk8_) * kLanes, -1);
    sup_c_.assign(static_cast<size_t>(nsup_) * Dp, 0.f);
    sup_r_.assign(static_cast<size_t>(nsup_), -1.f);  // < 0: no valid pixel (never scanned for a real maximum)
    std::vector<int64_t> sum(static_cast<size_t>(nsup_) * Dp, 0);
    std::vector<int> count(static_cast<size_t>(nsup_), 0);
    const double inv_sx = 1.0 / sx_;
    for (int y = 0; y < H_; ++y)
      for (int x = 0; x < W_; ++x) {
        const int j = y * W_ + x;
        const int sb = (y / kSuperPx) * tw + x / kSuperPx;
        const int blk = sb * kSuperBlocks + ((y % kSuperPx) / 4) * (kSuperPx / 4) + (x % kSuperPx) / 4;
        const int lane = (y % 4) * 4 + x % 4;
        pix_[static_cast<size_t>(blk) * kLanes + lane] = j;
        if (!valid(j)) continue;
        const float* p = row(j);
        uint8_t* bp = packed8_.data() + static_cast<size_t>(blk) * D4_ * 64 + lane * 4;
        int64_t* sp = &sum[static_cast<size_t>(sb) * Dp];
        double e2 = 0, t2 = 0;
        for (int d = 0; d < D_; ++d) {
          const double v = p[d] * sx_;  // |rounding error| ≤ 0.5 (the bound's assumption)
          const int c = std::clamp(static_cast<int>(v + (v >= 0 ? 0.5 : -0.5)), -127, 127);
          bp[(d / 4) * 64 + d % 4] = static_cast<uint8_t>(c + 128);
          const double xt = c * inv_sx;
          e2 += (p[d] - xt) * (p[d] - xt);
          t2 += xt * xt;
          sp[d] += c;
        }
        ++count[static_cast<size_t>(sb)];
        ex2max_ = std::max(ex2max_, e2);  // max ‖x − x̃‖₂² and max ‖x̃‖₂² over the map (roots below)
        xt2max_ = std::max(xt2max_, t2);
      }
    ex2max_ = std::sqrt(ex2max_) * (1 + 1e-12);
    xt2max_ = std::sqrt(xt2max_) * (1 + 1e-12);
    // Super-block centroids and radii, in code units (the radius from the float centroid, rounded up).
    for (int sb = 0; sb < nsup_; ++sb) {
      if (!count[static_cast<size_t>(sb)]) continue;
      std::vector<float> c(static_cast<size_t>(Dp));
      for (int d = 0; d < Dp; ++d) {
        c[static_cast<size_t>(d)] = static_cast<float>(static_cast<double>(sum[static_cast<size_t>(sb) * Dp + d]) /
                                                       count[static_cast<size_t>(sb)]);
        sup_c_[static_cast<size_t>(d) * nsup_ + sb] = c[static_cast<size_t>(d)];  // dimension-major
      }
      // float arithmetic (24 squares of values below 255: relative error < 1e-5), covered by the rounding up below.
      float r2 = 0;
      for (int b = 0; b < kSuperBlocks; ++b) {
        const uint8_t* bp = packed8_.data() + (static_cast<size_t>(sb) * kSuperBlocks + b) * D4_ * 64;
        const int32_t* pb = &pix_[(static_cast<size_t>(sb) * kSuperBlocks + b) * kLanes];
        for (int l = 0; l < kLanes; ++l) {
          if (pb[l] < 0 || !valid(pb[l])) continue;
          float d2 = 0;
          for (int d = 0; d < D_; ++d) {
            const float diff = static_cast<float>(static_cast<int>(bp[(d / 4) * 64 + l * 4 + d % 4]) - 128) -
                               c[static_cast<size_t>(d)];
            d2 += diff * diff;
          }
          r2 = std::max(r2, d2);
        }
      }
      sup_r_[static_cast<size_t>(sb)] = static_cast<float>(std::sqrt(static_cast<double>(r2)) * (1 + 1e-4) + 1e-2);
    }
  }

  // Every kSampleStride-th block, screened first to give each query a running maximum close to its final one
  // (a real screened value, so never above it): far fewer stale candidates are recorded on the full scan.
  static constexpr int kSampleStride =
      8;  // 1/8 more screening; fewer stale records, more tiles skipped (bench/matching)
  void PackSample8() {
    const size_t bytes = static_cast<size_t>(D4_) * 64;
    for (int b = 0; b < nblk8_; b += kSampleStride) {
      sample8_.insert(sample8_.end(), packed8_.begin() + static_cast<ptrdiff_t>(b * bytes),
                      packed8_.begin() + static_cast<ptrdiff_t>((b + 1) * bytes));
      sample_pix_.insert(sample_pix_.end(), pix_.begin() + static_cast<ptrdiff_t>(b) * kLanes,
                         pix_.begin() + static_cast<ptrdiff_t>(b + 1) * kLanes);
    }
  }

  void PackFloat() {
    packedf_.assign(static_cast<size_t>(nblk_) * D_ * kLanes, 0.f);
    for (int j = 0; j < M_; ++j) {
      if (!valid(j)) continue;
      const float* p = row(j);
      float* blk = packedf_.data() + static_cast<size_t>(j / kLanes) * D_ * kLanes;
      for (int d = 0; d < D_; ++d) blk[d * kLanes + j % kLanes] = p[d];
    }
  }

  void ScreenInt8All(const std::vector<const float*>& queries, int nt, std::vector<std::vector<Candidate>>* cand,
                     std::vector<double>* best, std::vector<double>* thr) const;
  void ScreenFloatAll(const std::vector<const float*>& queries, int nt, std::vector<std::vector<Candidate>>* cand,
                      std::vector<double>* best, std::vector<double>* thr) const;

  const float* x_;
  int M_, D_, W_, H_;
  std::vector<char> valid_;
  int invalid_ = 0;
  double l1max_ = 0, l2max_ = 0, absmax_ = 0;
  int nblk_ = 0, D4_ = 0;
  bool int8_ = false;
  double sx_ = 1, ex2max_ = 0, xt2max_ = 0;
  std::vector<uint8_t> packed8_, sample8_;
  int nsup_ = 0, nblk8_ = 0;
  std::vector<int32_t> pix_, sample_pix_;
  std::vector<float> sup_c_, sup_r_;

 public:
  mutable int64_t tiles_scanned_ = 0, tiles_skipped_ = 0;  // int8: (row group, tile) pairs scanned and skipped
  std::vector<float> packedf_;
};

// ---------------------------------------------------------------------------------------------------------------
// int8 screening: u8 database codes (x̃·s_x + 128) against s8 query codes with vpdpbusd; the +128 bias adds
// 128·Σq8 to every value of a query, which comparisons within the query ignore.

// The slow path of a block whose screened values reach a query's limit: record the lanes at or above it and raise
// the query's running maximum. Rare after the first blocks.
// Only real, valid pixels are recorded and raise the running maximum (padding lanes and NaN pixels hold code 0, whose
// value is not a similarity of any candidate).
template <typename T>
void RecordLanes(const T* lanes, uint32_t mask, int b, const int32_t* pix, const char* valid, int M, int q, T* runmax,
                 const T* thr, std::vector<Candidate>* out) {
  for (int l = 0; l < kLanes; ++l) {
    if (!(mask >> l & 1)) continue;
    const int idx = pix ? pix[b * kLanes + l] : b * kLanes + l;  // pix: the int8 layout's lane → pixel table
    if (idx < 0 || idx >= M || !valid[idx] || !(lanes[l] >= runmax[q] - thr[q])) continue;
    out->push_back({q, idx, static_cast<double>(lanes[l])});
    if (lanes[l] > runmax[q]) runmax[q] = lanes[l];
  }
}

// What one int8 scan needs. The database is laid out in tiles: a block is a 4×4 pixel square (16 lanes), a super-block
// the blocks of a kSuperPx × kSuperPx tile; `pix` maps block·16 + lane to the pixel (−1: padding beyond the image
// edge).
struct Int8Scan {
  const uint8_t* packed;
  int D4;
  const int32_t* pix;  // block·16 + lane → pixel index, −1 for padding
  const char* valid;   // per pixel
  int M;
  const int32_t* q32;  // n (+ kRows padding) × D4 query words
  const int32_t* thr;
  int n;
  int32_t* runmax;
  std::vector<Candidate>* out;
  // Super-block pruning (null: scan every block): per super-block the centroid of its codes (Dp floats) and the
  // radius of its codes around it; per query its codes as floats, their norm and the u8 bias 128·Σq8.
  const float* sup_cT = nullptr;  // Dp × nsup, dimension-major
  int nsup = 0;
  const float* sup_r = nullptr;
  const float* qf = nullptr;
  const float* qn = nullptr;
  const float* qbias = nullptr;
  int Dp = 0;
  int64_t* tiles_scanned = nullptr;  // (row group, super-block) pairs scanned / skipped, for the statistics
  int64_t* tiles_skipped = nullptr;
};

// Blocks [b_from, b_to) for the query rows q0 … q0 + kRows − 1 (r of them real).
template <int kD4>
__attribute__((target("avx512f,avx512bw,avx512vnni"), always_inline)) inline void ScanBlocks(const Int8Scan& s, int q0,
                                                                                             int r, int32_t* limit,
                                                                                             int b_from, int b_to) {
  const int D4 = kD4 > 0 ? kD4 : s.D4;
  const int32_t* qb = s.q32 + static_cast<size_t>(q0) * D4;
  int b = b_from;
  // Two blocks per step: each broadcast query value feeds two multiply-adds.
  for (; b + 1 < b_to; b += 2) {
    const uint8_t* xb = s.packed + static_cast<size_t>(b) * D4 * 64;
    __m512i acc[2 * kRows];
    for (int i = 0; i < 2 * kRows; ++i) acc[i] = _mm512_set1_epi32(0);
#pragma GCC unroll 16
    for (int k = 0; k < D4; ++k) {
      const __m512i x0 = _mm512_loadu_si512(xb + k * 64);
      const __m512i x1 = _mm512_loadu_si512(xb + (D4 + k) * 64);
#pragma GCC unroll 16
      for (int i = 0; i < kRows; ++i) {
        const __m512i qv = _mm512_set1_epi32(qb[static_cast<size_t>(i) * D4 + k]);
        acc[i] = _mm512_dpbusd_epi32(acc[i], x0, qv);
        acc[kRows + i] = _mm512_dpbusd_epi32(acc[kRows + i], x1, qv);
      }
    }
    // Any lane of any row at or above its row's limit? (acc − limit, maximum over rows, one compare: no mask
    // registers live across the loop.)
    __m512i over = _mm512_sub_epi32(_mm512_max_epi32(acc[0], acc[kRows]), _mm512_set1_epi32(limit[0]));
#pragma GCC unroll 16
    for (int i = 1; i < kRows; ++i)
      over = _mm512_max_epi32(over,
                              _mm512_sub_epi32(_mm512_max_epi32(acc[i], acc[kRows + i]), _mm512_set1_epi32(limit[i])));
    if (__builtin_expect(_mm512_cmpge_epi32_mask(over, _mm512_set1_epi32(0)) == 0, 1)) continue;
    // Slow path. The accumulators go to memory here (with constant indices), so that the hot loop keeps them in
    // registers.
    alignas(64) int32_t all[2 * kRows][kLanes];
#pragma GCC unroll 16
    for (int i = 0; i < 2 * kRows; ++i) _mm512_store_si512(all[i], acc[i]);
    for (int i = 0; i < r; ++i)
      for (int half = 0; half < 2; ++half) {
        const int32_t* lanes = all[half * kRows + i];
        uint32_t mask = 0;
        for (int l = 0; l < kLanes; ++l) mask |= static_cast<uint32_t>(lanes[l] >= limit[i]) << l;
        if (!mask) continue;
        RecordLanes(lanes, mask, b + half, s.pix, s.valid, s.M, q0 + i, s.runmax, s.thr, s.out);
        limit[i] = s.runmax[q0 + i] - s.thr[q0 + i];
      }
  }
  for (; b < b_to; ++b) {
    const uint8_t* xb = s.packed + static_cast<size_t>(b) * D4 * 64;
    __m512i acc[kRows];
    for (int i = 0; i < kRows; ++i) acc[i] = _mm512_set1_epi32(0);
    for (int k = 0; k < D4; ++k) {
      const __m512i x = _mm512_loadu_si512(xb + k * 64);
      for (int i = 0; i < kRows; ++i)
        acc[i] = _mm512_dpbusd_epi32(acc[i], x, _mm512_set1_epi32(qb[static_cast<size_t>(i) * D4 + k]));
    }
    alignas(64) int32_t all[kRows][kLanes];
    for (int i = 0; i < kRows; ++i) _mm512_store_si512(all[i], acc[i]);
    for (int i = 0; i < r; ++i) {
      uint32_t mask = 0;
      for (int l = 0; l < kLanes; ++l) mask |= static_cast<uint32_t>(all[i][l] >= limit[i]) << l;
      if (!mask) continue;
      RecordLanes(all[i], mask, b, s.pix, s.valid, s.M, q0 + i, s.runmax, s.thr, s.out);
      limit[i] = s.runmax[q0 + i] - s.thr[q0 + i];
    }
  }
}

// Blocks [blk_begin, blk_end) for every query, in cache tiles of kTileBlocks blocks. With super-block data, a tile's
// super-block is skipped for a group of rows when, for each row, its bound q8·c + ‖q8‖·r (+ the u8 bias and a
// margin for the float arithmetic) — an upper bound of every value in it — is below the row's limit: then no value
// there can come within thr of the row's final maximum, which is at least its running maximum.
template <int kD4>
__attribute__((target("avx512f,avx512bw,avx512vnni"), always_inline)) inline void ScreenInt8RangeT(const Int8Scan& s,
                                                                                                   int blk_begin,
                                                                                                   int blk_end) {
  int32_t limit[kRows];
  for (int tb = blk_begin; tb < blk_end; tb += kTileBlocks) {
    const int te = std::min(blk_end, tb + kTileBlocks);
    for (int q0 = 0; q0 < s.n; q0 += kRows) {
      const int r = std::min(kRows, s.n - q0);
      // Padded rows (beyond n) never reach INT_MAX / 2 (and acc − limit cannot overflow: |acc| < 2²⁴).
      for (int i = 0; i < kRows; ++i) limit[i] = i < r ? s.runmax[q0 + i] - s.thr[q0 + i] : INT_MAX / 2;
      if (!s.sup_cT) {
        ScanBlocks<kD4>(s, q0, r, limit, tb, te);
        continue;
      }
      // The bounds of this tile range's super-blocks for the group's rows, vectorised over super-blocks (centroids
      // stored dimension-major); a super-block is scanned when any real row's bound reaches its limit.
      const int sb0 = tb / kSuperBlocks, sb1 = (te + kSuperBlocks - 1) / kSuperBlocks, nk = sb1 - sb0;
      static_assert(kTileBlocks / kSuperBlocks <= 64, "one bit per super-block of a tile range");
      uint64_t scan = 0;
      const float* rad = s.sup_r + sb0;
      // Per row: bound = (qn + rel)·r + base + rel·rel_c + Σ_d q_d·c_d (rel, the float-rounding margin).
      const float rel_c = 128.f * std::sqrt(static_cast<float>(s.Dp));
      float slope[kRows], icpt[kRows], lim[kRows];
      for (int i = 0; i < kRows; ++i) {
        const int qi = q0 + std::min(i, r - 1);
        const float qn = s.qn[qi], rel = 1e-4f * qn;
        slope[i] = qn + rel;
        icpt[i] = s.qbias[qi] + 8.f + rel * rel_c;
        lim[i] = i < r ? static_cast<float>(limit[i]) : 3e38f;
      }
      const float* qf = s.qf + static_cast<size_t>(q0) * s.Dp;
      const int rows_avail = std::min(kRows, s.n - q0);  // qf rows that exist (the rest repeat the last real one)
      for (int k = 0; k < nk; k += 16) {
        const __mmask16 in = nk - k >= 16 ? 0xffff : static_cast<__mmask16>((1u << (nk - k)) - 1);
        const __m512 rk = _mm512_maskz_loadu_ps(in, rad + k);
        __m512 acc[kRows];
#pragma GCC unroll 16
        for (int i = 0; i < kRows; ++i) acc[i] = _mm512_fmadd_ps(_mm512_set1_ps(slope[i]), rk, _mm512_set1_ps(icpt[i]));
        for (int d = 0; d < s.Dp; ++d) {
          const __m512 c = _mm512_maskz_loadu_ps(in, s.sup_cT + static_cast<size_t>(d) * s.nsup + sb0 + k);
#pragma GCC unroll 16
          for (int i = 0; i < kRows; ++i)
            acc[i] = _mm512_fmadd_ps(_mm512_set1_ps(qf[static_cast<size_t>(std::min(i, rows_avail - 1)) * s.Dp + d]), c,
                                     acc[i]);
        }
        __mmask16 hit = 0;
#pragma GCC unroll 16
        for (int i = 0; i < kRows; ++i)
          hit = static_cast<__mmask16>(hit | _mm512_mask_cmp_ps_mask(in, acc[i], _mm512_set1_ps(lim[i]), _CMP_GE_OQ));
        // Empty super-blocks (radius < 0) are never scanned.
        hit = static_cast<__mmask16>(hit & _mm512_mask_cmp_ps_mask(in, rk, _mm512_set1_ps(0.f), _CMP_GE_OQ));
        scan |= static_cast<uint64_t>(hit) << k;
      }
      for (int k = 0; k < nk; ++k) {
        const int sb = sb0 + k;
        if (scan >> k & 1) {
          ScanBlocks<kD4>(s, q0, r, limit, sb * kSuperBlocks, std::min(te, (sb + 1) * kSuperBlocks));
          ++*s.tiles_scanned;
        } else {
          ++*s.tiles_skipped;
        }
      }
    }
  }
}

// Each query's best screened value over the threads' block ranges.
template <typename T>
void MergeRunningMax(const std::vector<std::vector<T>>& runmax, std::vector<double>* best) {
  for (const auto& per_thread : runmax)
    for (size_t i = 0; i < per_thread.size(); ++i)
      (*best)[i] = std::max((*best)[i], static_cast<double>(per_thread[i]));
}

__attribute__((target("avx512f,avx512bw,avx512vnni"))) void ScreenInt8Range(const Int8Scan& s, int blk_begin,
                                                                            int blk_end) {
  switch (s.D4) {
    case 2: return ScreenInt8RangeT<2>(s, blk_begin, blk_end);  // D ≤ 8
    case 4: return ScreenInt8RangeT<4>(s, blk_begin, blk_end);  // D ≤ 16
    case 6: return ScreenInt8RangeT<6>(s, blk_begin, blk_end);  // D ≤ 24 (released)
    case 8: return ScreenInt8RangeT<8>(s, blk_begin, blk_end);  // D ≤ 32
    default: return ScreenInt8RangeT<0>(s, blk_begin, blk_end);
  }
}

void Database::ScreenInt8All(const std::vector<const float*>& queries, int nt,
                             std::vector<std::vector<Candidate>>* cand, std::vector<double>* best,
                             std::vector<double>* thr) const {
  const int n = static_cast<int>(queries.size());
  std::vector<int32_t> q32(static_cast<size_t>(n + kRows) * D4_, 0);
  std::vector<int32_t> thr_i(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const float* q = queries[static_cast<size_t>(i)];
    double amax = 0, l1 = 0;
    for (int d = 0; d < D_; ++d) {
      amax = std::max(amax, static_cast<double>(std::abs(q[d])));
      l1 += std::abs(q[d]);
    }
    if (!std::isfinite(amax)) amax = 0, l1 = 0;  // a non-finite query: its answer is −1 anyway
    const double sq = amax > 0 ? 127.0 / amax : 1.0;
    auto* bytes = reinterpret_cast<int8_t*>(q32.data() + static_cast<size_t>(i) * D4_);
    double eq2 = 0, q2 = 0;
    for (int d = 0; d < D_; ++d) {
      const float v = std::isfinite(q[d]) ? q[d] : 0.f;
      bytes[d] = static_cast<int8_t>(std::clamp<long>(std::lround(v * sq), -127, 127));
      eq2 += (v - bytes[d] / sq) * (v - bytes[d] / sq);
      q2 += static_cast<double>(v) * v;
    }
    // ε(q) in real units — each of the two terms by the smaller of two valid bounds: |q·(x − x̃)| ≤ ‖q‖₁·0.5/s_x and
    // ≤ ‖q‖₂·max‖x − x̃‖₂; |(q − q̃)·x̃| ≤ max‖x̃‖₁·0.5/s_q and ≤ ‖q − q̃‖₂·max‖x̃‖₂ — then 2ε in integer units
    // (s_q·s_x per unit), rounded up with a margin.
    const double eps = std::min(l1 * 0.5 / sx_, std::sqrt(q2) * ex2max_) +
                       std::min((l1max_ + D_ * 0.5 / sx_) * 0.5 / sq, std::sqrt(eq2) * xt2max_);
    const double t = std::ceil(2 * eps * sq * sx_ * (1 + 1e-9)) + 2;
    thr_i[static_cast<size_t>(i)] = static_cast<int32_t>(std::min(t, 4.0e8));
    (*thr)[static_cast<size_t>(i)] = thr_i[static_cast<size_t>(i)];
  }
  // The queries' codes as floats, their norms and u8 biases, for the super-block bounds.
  const int Dp = D4_ * 4;
  std::vector<float> qf(static_cast<size_t>(n) * Dp, 0.f), qn(static_cast<size_t>(n)), qbias(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto* bytes = reinterpret_cast<const int8_t*>(q32.data() + static_cast<size_t>(i) * D4_);
    double n2 = 0, sum = 0;
    for (int d = 0; d < Dp; ++d) {
      qf[static_cast<size_t>(i) * Dp + d] = bytes[d];
      n2 += bytes[d] * bytes[d];
      sum += bytes[d];
    }
    qn[static_cast<size_t>(i)] = static_cast<float>(std::sqrt(n2));
    qbias[static_cast<size_t>(i)] = static_cast<float>(128 * sum);
  }
  std::vector<std::vector<int32_t>> runmax(static_cast<size_t>(nt),
                                           std::vector<int32_t>(static_cast<size_t>(n), INT_MIN / 2));
  std::vector<int64_t> scanned(static_cast<size_t>(nt), 0), skipped(static_cast<size_t>(nt), 0);
  auto work = [&](int t) {
    // Whole super-blocks per thread.
    const int b0 = static_cast<int>(static_cast<int64_t>(nsup_) * t / nt) * kSuperBlocks;
    const int b1 = static_cast<int>(static_cast<int64_t>(nsup_) * (t + 1) / nt) * kSuperBlocks;
    int32_t* rm = runmax[static_cast<size_t>(t)].data();
    // The sampled blocks of this range first: a running maximum close to the final one, so that the full scan
    // records few stale candidates and skips more tiles (what the sample records is discarded; the full scan visits
    // those blocks again).
    std::vector<Candidate> discard;
    const int s0 = (b0 + kSampleStride - 1) / kSampleStride, s1 = (b1 + kSampleStride - 1) / kSampleStride;
    const Int8Scan sample{sample8_.data(), D4_, sample_pix_.data(), valid_.data(), M_, q32.data(), thr_i.data(), n, rm,
                          &discard};
    ScreenInt8Range(sample, s0, s1);
    Int8Scan full{packed8_.data(),
                  D4_,
                  pix_.data(),
                  valid_.data(),
                  M_,
                  q32.data(),
                  thr_i.data(),
                  n,
                  rm,
                  &(*cand)[static_cast<size_t>(t)]};
    full.sup_cT = sup_c_.data();
    full.nsup = nsup_;
    full.sup_r = sup_r_.data();
    full.qf = qf.data();
    full.qn = qn.data();
    full.qbias = qbias.data();
    full.Dp = Dp;
    full.tiles_scanned = &scanned[static_cast<size_t>(t)];
    full.tiles_skipped = &skipped[static_cast<size_t>(t)];
    ScreenInt8Range(full, b0, b1);
  };
  RunOnThreads(nt, work);
  MergeRunningMax(runmax, best);
  for (int t = 0; t < nt; ++t) {
    tiles_scanned_ += scanned[static_cast<size_t>(t)];
    tiles_skipped_ += skipped[static_cast<size_t>(t)];
  }
}

// ---------------------------------------------------------------------------------------------------------------
// float32 screening (any x86-64 or other CPU): the same blocked scan with float accumulators.

typedef float V8f __attribute__((vector_size(32)));

// kFloatRows queries × 16 lanes of float accumulators (GCC vector extensions: AVX2 + FMA or AVX-512 where the CPU has
// it, SSE2 otherwise).
constexpr int kFloatRows = 4;
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void ScreenFloatRange(
    const float* packed, int D, int blk_begin, int blk_end, int M, const char* valid, const float* qs, const float* thr,
    int n, float* runmax, std::vector<Candidate>* out) {
  alignas(64) float lanes[kLanes];
  float limit[kFloatRows];
  for (int tb = blk_begin; tb < blk_end; tb += kTileBlocks) {
    const int te = std::min(blk_end, tb + kTileBlocks);
    for (int q0 = 0; q0 < n; q0 += kFloatRows) {
      const int r = std::min(kFloatRows, n - q0);
      const float* qb = qs + static_cast<size_t>(q0) * D;
      for (int i = 0; i < kFloatRows; ++i)
        limit[i] = i < r ? runmax[q0 + i] - thr[q0 + i] : std::numeric_limits<float>::infinity();
      for (int b = tb; b < te; ++b) {
        const float* xb = packed + static_cast<size_t>(b) * D * kLanes;
        V8f lo[kFloatRows] = {}, hi[kFloatRows] = {};
        for (int d = 0; d < D; ++d) {
          V8f x0, x1;
          std::memcpy(&x0, xb + d * kLanes, 32);
          std::memcpy(&x1, xb + d * kLanes + 8, 32);
#pragma GCC unroll 4
          for (int i = 0; i < kFloatRows; ++i) {
            const float qd = qb[static_cast<size_t>(i) * D + d];
            lo[i] += qd * x0;
            hi[i] += qd * x1;
          }
        }
        for (int i = 0; i < r; ++i) {
          const V8f mx = lo[i] > hi[i] ? lo[i] : hi[i];
          float best = mx[0];
          for (int l = 1; l < 8; ++l) best = mx[l] > best ? mx[l] : best;
          if (!(best >= limit[i])) continue;
          std::memcpy(lanes, &lo[i], 32);
          std::memcpy(lanes + 8, &hi[i], 32);
          RecordLanes(lanes, 0xffffu, b, nullptr, valid, M, q0 + i, runmax, thr, out);
          limit[i] = runmax[q0 + i] - thr[q0 + i];
        }
      }
    }
  }
}

void Database::ScreenFloatAll(const std::vector<const float*>& queries, int nt,
                              std::vector<std::vector<Candidate>>* cand, std::vector<double>* best,
                              std::vector<double>* thr) const {
  const int n = static_cast<int>(queries.size());
  std::vector<float> qs(static_cast<size_t>(n + kFloatRows) * D_, 0.f);
  std::vector<float> thr_f(static_cast<size_t>(n));
  const double u = std::ldexp(1.0, -24), gamma = D_ * u / (1 - D_ * u);
  for (int i = 0; i < n; ++i) {
    const float* q = queries[static_cast<size_t>(i)];
    double l2 = 0;
    for (int d = 0; d < D_; ++d) {
      qs[static_cast<size_t>(i) * D_ + d] = std::isfinite(q[d]) ? q[d] : 0.f;
      if (std::isfinite(q[d])) l2 += static_cast<double>(q[d]) * q[d];
    }
    // 2ε, plus the rounding of `runmax − thr` itself (relative 2⁻²³ of the values compared).
    const double eps = gamma * std::sqrt(l2) * l2max_;
    const double t = 2 * eps * 1.01 + 4 * u * std::sqrt(l2) * l2max_ + 1e-30;
    thr_f[static_cast<size_t>(i)] = static_cast<float>(t);
    (*thr)[static_cast<size_t>(i)] = static_cast<float>(t) * 1.0000005;
  }
  std::vector<std::vector<float>> runmax(
      static_cast<size_t>(nt), std::vector<float>(static_cast<size_t>(n), -std::numeric_limits<float>::max()));
  auto work = [&](int t) {
    const int b0 = static_cast<int>(static_cast<int64_t>(nblk_) * t / nt);
    const int b1 = static_cast<int>(static_cast<int64_t>(nblk_) * (t + 1) / nt);
    ScreenFloatRange(packedf_.data(), D_, b0, b1, M_, valid_.data(), qs.data(), thr_f.data(), n,
                     runmax[static_cast<size_t>(t)].data(), &(*cand)[static_cast<size_t>(t)]);
  };
  RunOnThreads(nt, work);
  MergeRunningMax(runmax, best);
}

// ---------------------------------------------------------------------------------------------------------------
// The iteration (naver/mast3r mast3r/fast_nn.py): per seed the current pair (p1, p2), the previous one (o1, o2),
// active.

std::vector<PixelMatch> Run(const DescriptorView& v1, const DescriptorView& v2, const FastNnOptions& o,
                            FastNnStats* stats_out, bool exhaustive) {
  o.Validate();
  CheckView(v1, "view 1");
  CheckView(v2, "view 2");
  FREELOC_CHECK(v1.dim == v2.dim, "fast NN: descriptor sizes differ (" << v1.dim << " and " << v2.dim << ")");
  const auto t0 = std::chrono::steady_clock::now();
  FastNnStats st;
  const NnKernel kernel = exhaustive ? NnKernel::kFloat32 : o.kernel;
  // Both databases packed at once (one on a helper thread when there are two threads or more).
  std::unique_ptr<Database> pack1;
  std::thread packer;
  if (Threads(o.threads) > 1) packer = std::thread([&] { pack1 = std::make_unique<Database>(v1, kernel); });
  const Database db2(v2, kernel);  // answers NN₂ (view-1 queries)
  if (packer.joinable())
    packer.join();
  else
    pack1 = std::make_unique<Database>(v1, kernel);
  const Database& db1 = *pack1;  // answers NN₁  // db2 answers NN₂ (view-1 queries), db1 answers NN₁
  st.kernel = exhaustive ? "exhaustive" : db2.int8() ? "int8-vnni" : "float32";
  st.invalid_pixels = db1.invalid() + db2.invalid();
  const int W1 = v1.width, H1 = v1.height, S = o.subsample;
  for (int y = S / 2; y < H1; y += S)
    for (int x = S / 2; x < W1; x += S) st.seeds.push_back(y * W1 + x);
  const size_t n = st.seeds.size();
  std::vector<int> p1(st.seeds.begin(), st.seeds.end()), o1 = p1, p2(n, -1), o2(n, -1);
  std::vector<char> active(n, 1), dropped(n, 0);
  for (size_t s = 0; s < n; ++s)
    if (!db1.valid(p1[s])) {  // never seed an invalid pixel
      active[s] = 0;
      dropped[s] = 1;
    }
  // Memoised lookups: NN₂ of a view-1 pixel, NN₁ of a view-2 pixel (−2 = not computed yet).
  std::vector<int> nn2(static_cast<size_t>(db1.size()), -2), nn1(static_cast<size_t>(db2.size()), -2);
  auto lookup = [&](const std::vector<int>& from, const DescriptorView& qv, const Database& db,
                    std::vector<int>* memo) {
    std::vector<int> todo;
    for (int p : from)
      if ((*memo)[static_cast<size_t>(p)] == -2) {
        (*memo)[static_cast<size_t>(p)] = -3;  // queued (deduplicates this call)
        todo.push_back(p);
      }
    std::vector<const float*> rows;
    for (int p : todo) rows.push_back(qv.desc + static_cast<size_t>(p) * qv.dim);
    std::vector<int> res(todo.size(), -1);
    if (exhaustive) {
      for (size_t i = 0; i < todo.size(); ++i) res[i] = db.NearestExhaustive(rows[i]);
    } else {
      db.Nearest(rows, o.threads, &res, &st.candidates);
    }
    for (size_t i = 0; i < todo.size(); ++i) (*memo)[static_cast<size_t>(todo[i])] = res[i];
    st.lookups += static_cast<int64_t>(todo.size());
  };
  while (true) {
    std::vector<int> from;
    for (size_t s = 0; s < n; ++s)
      if (active[s]) from.push_back(p1[s]);
    if (from.empty()) break;
    st.query_sizes.push_back(static_cast<int64_t>(from.size()));
    lookup(from, v1, db2, &nn2);
    for (size_t s = 0; s < n; ++s) {
      if (!active[s]) continue;
      p2[s] = nn2[static_cast<size_t>(p1[s])];
      if (p2[s] < 0) {
        active[s] = 0;
        dropped[s] = 1;
      } else if (p2[s] == o2[s]) {
        active[s] = 0;
      }
    }
    from.clear();
    for (size_t s = 0; s < n; ++s)
      if (active[s]) from.push_back(p2[s]);
    if (!from.empty()) {
      st.query_sizes.push_back(static_cast<int64_t>(from.size()));
      lookup(from, v2, db1, &nn1);
      for (size_t s = 0; s < n; ++s) {
        if (!active[s]) continue;
        p1[s] = nn1[static_cast<size_t>(p2[s])];
        if (p1[s] < 0) {
          active[s] = 0;
          dropped[s] = 1;
        } else if (p1[s] == o1[s]) {
          active[s] = 0;
        }
      }
    }
    ++st.rounds;
    if (st.rounds >= o.max_rounds) break;
    o1 = p1;
    o2 = p2;
  }
  // Converged seeds: deduplicated and sorted by (p1, p2) — upstream's int64 view p1·2³² + p2.
  std::vector<uint64_t> keys;
  for (size_t s = 0; s < n; ++s) {
    if (active[s] || dropped[s]) {
      ++st.dropped;
      continue;
    }
    keys.push_back(static_cast<uint64_t>(p1[s]) << 32 | static_cast<uint32_t>(p2[s]));
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<PixelMatch> out;
  out.reserve(keys.size());
  for (uint64_t k : keys) {
    const int a = static_cast<int>(k >> 32), b = static_cast<int>(k & 0xffffffffu);
    PixelMatch m;
    m.x1 = a % W1;
    m.y1 = a / W1;
    m.x2 = b % v2.width;
    m.y2 = b / v2.width;
    m.conf1 = v1.desc_conf ? v1.desc_conf[a] : 0.f;
    m.conf2 = v2.desc_conf ? v2.desc_conf[b] : 0.f;
    out.push_back(m);
  }
  const int64_t sc = db1.tiles_scanned_ + db2.tiles_scanned_, sk = db1.tiles_skipped_ + db2.tiles_skipped_;
  st.tiles_skipped = sc + sk > 0 ? static_cast<double>(sk) / static_cast<double>(sc + sk) : 0.0;
  st.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (stats_out) *stats_out = std::move(st);
  return out;
}

}  // namespace

std::vector<PixelMatch> FastReciprocalNN(const DescriptorView& view1, const DescriptorView& view2,
                                         const FastNnOptions& options, FastNnStats* stats) {
  return Run(view1, view2, options, stats, false);
}

std::vector<PixelMatch> FastReciprocalNNBruteForce(const DescriptorView& view1, const DescriptorView& view2,
                                                   const FastNnOptions& options, FastNnStats* stats) {
  return Run(view1, view2, options, stats, true);
}

std::vector<PixelMatch> FilterDescriptorMatches(const std::vector<PixelMatch>& matches, int w1, int h1, int w2, int h2,
                                                const DescriptorMatchFilter& f) {
  f.Validate();
  const int b = f.border;
  std::vector<PixelMatch> out;
  for (const PixelMatch& m : matches) {
    if (m.x1 < b || m.x1 >= w1 - b || m.y1 < b || m.y1 >= h1 - b) continue;
    if (m.x2 < b || m.x2 >= w2 - b || m.y2 < b || m.y2 >= h2 - b) continue;
    if (f.min_conf > 0 && !(std::min(m.conf1, m.conf2) >= f.min_conf)) continue;
    out.push_back(m);
  }
  return out;
}

}  // namespace freeloc::matching
