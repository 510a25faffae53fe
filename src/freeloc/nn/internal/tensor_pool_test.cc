// The tensor pool (tensor_pool.h): reuse by size, the cache cap, trimming, LibTorch's allocator behind it.
#include "freeloc/nn/internal/tensor_pool.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstring>
#include <new>
#include <thread>
#include <tuple>
#include <vector>

namespace freeloc::nn::internal {
namespace {

constexpr size_t kMiB = size_t{1} << 20;

TEST(TensorPool, ReusesAFreedBlockOfTheSameOrANearSize) {
  TensorPool pool(kMiB, 64 * kMiB);
  void* a = pool.Allocate(3 * kMiB);
  std::memset(a, 7, 3 * kMiB);  // writable
  pool.Free(a);
  EXPECT_EQ(pool.Allocate(3 * kMiB), a);  // the same size
  pool.Free(a);
  EXPECT_EQ(pool.Allocate(3 * kMiB - 100 * 1024), a);  // a little smaller: within 1/8
  void* b = pool.Allocate(3 * kMiB);                   // a busy block is never handed out twice
  EXPECT_NE(b, a);
  pool.Free(b);
  EXPECT_NE(pool.Allocate(kMiB), b);  // less than half: a block of its own, not a third of b
  const TensorPoolStats st = pool.Stats();
  EXPECT_EQ(st.hits, 2u);
  EXPECT_EQ(st.misses, 3u);
  EXPECT_EQ(st.cached_bytes, 3 * kMiB);
  EXPECT_TRUE(pool.Owns(a));
  int elsewhere = 0;
  EXPECT_FALSE(pool.Owns(&elsewhere));
  // Up to 1.5× the request: 3 MiB is too large for 1.9 MiB (a weight converted at load would hold it for good) and
  // serves 2.5 MiB.
  EXPECT_NE(pool.Allocate(kMiB * 19 / 10), b);
  EXPECT_EQ(pool.Allocate(kMiB * 5 / 2), b);
}

TEST(TensorPool, KeepsFreeBlocksUnderItsCapAndTrimsThemAll) {
  TensorPool pool(kMiB, 8 * kMiB);
  std::vector<void*> p;
  for (int i = 0; i < 5; ++i) p.push_back(pool.Allocate(4 * kMiB));
  EXPECT_EQ(pool.Stats().live_bytes, 20 * kMiB);
  for (void* q : p) pool.Free(q);
  TensorPoolStats st = pool.Stats();
  EXPECT_EQ(st.live_bytes, 0u);
  EXPECT_EQ(st.cached_bytes, 8 * kMiB);  // the two most recently freed
  EXPECT_TRUE(pool.Owns(p[4]) && pool.Owns(p[3]));
  EXPECT_FALSE(pool.Owns(p[0]));  // unmapped
  EXPECT_EQ(st.peak_bytes, 20 * kMiB);
  pool.Trim();
  st = pool.Stats();
  EXPECT_EQ(st.cached_bytes, 0u);
  EXPECT_FALSE(pool.Owns(p[4]));
}

// Between passes the cache stays, for the same model's next pass and for another's: blocks that fit are hits whoever
// freed them. What the slack allows idle is counted from the live high-water mark of the current owner's passes
// (since its Claim), not the process's: another model's larger pass does not let idle blocks pile up beside this one.
TEST(TensorPool, KeepsItsCacheAcrossPassesAndCountsTheSlackPerOwner) {
  TensorPool pool(kMiB, 64 * kMiB, 4 * kMiB);
  int a = 0, b = 0, c = 0;  // three "models"
  const auto pass = [&](const void* owner, size_t bytes) {
    pool.Claim(owner);
    void* x = pool.Allocate(bytes);
    pool.Free(x);
    pool.Keep(owner);
    return x;
  };
  void* big = pass(&a, 20 * kMiB);
  EXPECT_EQ(pass(&a, 20 * kMiB), big);  // the same model again: served from the cache
  EXPECT_EQ(pool.Stats().misses, 1u);
  EXPECT_TRUE(pool.Claim(&b));  // another model begins: the cache stays …
  EXPECT_EQ(pool.Stats().cached_bytes, 20 * kMiB);
  EXPECT_EQ(pool.Allocate(15 * kMiB), big);  // … and serves its requests that fit
  pool.Free(big);
  pool.Keep(&b);
  // A third model's pass needs a 2 MiB block: its live high-water mark is 2 MiB, and 20 idle + 2 > 2 + 4, so the
  // 20 MiB block goes; counted from the process's high-water mark (20) it would have stayed.
  EXPECT_TRUE(pool.Claim(&c));
  void* small = pool.Allocate(2 * kMiB);
  EXPECT_FALSE(pool.Owns(big));
  pool.Free(small);
  pool.Trim();
  EXPECT_EQ(pool.Stats().cached_bytes, 0u);
  // The same owner's high-water mark carries over its passes: after a's 20 MiB pass a 2 MiB block maps beside the
  // idle 20 MiB one (2 + 20 ≤ 20 + 4).
  void* big2 = pass(&a, 20 * kMiB);
  EXPECT_FALSE(pool.Claim(&a));
  void* small2 = pool.Allocate(2 * kMiB);
  EXPECT_TRUE(pool.Owns(big2));
  EXPECT_EQ(pool.Stats().cached_bytes, 20 * kMiB);
  pool.Free(small2);
}

// Idle blocks that a pass's sizes do not fit may add at most the slack to the pool's footprint: before a block is
// mapped, cached blocks go (least recently freed first) until live + cached + new ≤ live high-water + slack. Blocks
// that do fit are still reused, however large the cache.
TEST(TensorPool, IdleBlocksAddAtMostTheSlackToThePeak) {
  const auto run = [](size_t slack) {
    TensorPool pool(kMiB, 64 * kMiB, slack);
    void* a = pool.Allocate(8 * kMiB);
    void* b = pool.Allocate(8 * kMiB);
    pool.Free(a);
    pool.Free(b);  // live high-water 16 MiB, both cached
    std::vector<void*> small;
    for (int i = 0; i < 3; ++i) small.push_back(pool.Allocate(2 * kMiB));  // too small for an 8 MiB block
    const bool a_kept = pool.Owns(a), b_kept = pool.Owns(b);
    for (void* q : small) pool.Free(q);
    void* c = pool.Allocate(8 * kMiB);  // whichever 8 MiB block is left serves this
    pool.Free(c);
    return std::make_tuple(pool.Stats(), a_kept, b_kept);
  };
  const auto [bounded, a_kept, b_kept] = run(4 * kMiB);
  EXPECT_EQ(bounded.peak_live_bytes, 16 * kMiB);
  EXPECT_EQ(bounded.peak_bytes, 20 * kMiB);  // 16 + 2 + 2 while both 8 MiB blocks still fit under 16 + 4
  EXPECT_LE(bounded.peak_bytes, bounded.peak_live_bytes + 4 * kMiB);
  EXPECT_FALSE(a_kept);  // the third 2 MiB block needed room: the least recently freed went
  EXPECT_TRUE(b_kept);
  EXPECT_EQ(bounded.misses, 5u);  // a, b and the three small ones; c was b's block
  EXPECT_EQ(bounded.hits, 1u);
  const auto [unbounded, a_kept_u, b_kept_u] = run(SIZE_MAX);
  EXPECT_EQ(unbounded.peak_bytes, 22 * kMiB);  // without the slack the idle blocks stay under the cap alone
  EXPECT_TRUE(a_kept_u && b_kept_u);
}

TEST(TensorPool, RefusesAnImpossibleSize) {
  TensorPool pool(kMiB, 8 * kMiB);
  EXPECT_THROW(pool.Allocate(SIZE_MAX - 10), std::bad_alloc);
  EXPECT_THROW(pool.Allocate(size_t{1} << 62), std::bad_alloc);  // more than any machine maps
  EXPECT_EQ(pool.Stats().live_bytes, 0u);
}

TEST(TensorPool, ManyThreadsAllocateAndFreeConsistently) {
  TensorPool pool(kMiB, 16 * kMiB);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&pool, t] {
      for (int i = 0; i < 200; ++i) {
        const size_t n = (1 + (i + t) % 3) * kMiB;
        auto* p = static_cast<unsigned char*>(pool.Allocate(n));
        p[0] = p[n - 1] = static_cast<unsigned char>(i);
        EXPECT_EQ(p[n - 1], static_cast<unsigned char>(i));
        pool.Free(p);
      }
    });
  for (auto& th : threads) th.join();
  const TensorPoolStats st = pool.Stats();
  EXPECT_EQ(st.live_bytes, 0u);
  EXPECT_LE(st.cached_bytes, 16 * kMiB);
  EXPECT_EQ(st.hits + st.misses, 800u);
}

TEST(TensorPool, BacksLibTorchsLargeCpuTensors) {
  InstallTensorPool();
  TensorPool* pool = InstalledTensorPool();
  if (!pool) GTEST_SKIP() << "FREELOC_TENSOR_POOL=off";
  const torch::Tensor small = torch::ones({16});
  EXPECT_FALSE(pool->Owns(small.data_ptr()));  // LibTorch's own allocator
  size_t cached;
  {
    torch::Tensor big = torch::arange(1 << 20, torch::kFloat32);  // 4 MiB
    EXPECT_TRUE(pool->Owns(big.data_ptr()));
    EXPECT_EQ(big[123456].item<float>(), 123456.0f);
    EXPECT_EQ((big + 1).to(torch::kFloat64).sum().item<double>(), (double(1 << 20) * ((1 << 20) + 1)) / 2);
    cached = pool->Stats().cached_bytes;
  }
  EXPECT_GE(pool->Stats().cached_bytes, cached);  // freed into the cache (or evicted under the cap)
  const torch::Tensor again = torch::zeros({1 << 20});
  EXPECT_TRUE(pool->Owns(again.data_ptr()));
  EXPECT_EQ(again.abs().sum().item<float>(), 0.0f);  // zeros() fills a reused block
  pool->Trim();
  EXPECT_EQ(pool->Stats().cached_bytes, 0u);
  EXPECT_TRUE(pool->Owns(again.data_ptr()));  // a live tensor keeps its block
}

}  // namespace
}  // namespace freeloc::nn::internal
