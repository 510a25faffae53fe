#include "freeloc/nn/internal/tensor_pool.h"

#include <c10/core/Allocator.h>
#include <c10/core/CPUAllocator.h>
#include <sys/mman.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <new>

#include "freeloc/core/env.h"

namespace freeloc::nn::internal {

namespace {

constexpr size_t kGranule = size_t{64} << 10;  // block sizes round up to 64 KiB
constexpr size_t kPoolMin = size_t{1} << 20;   // the installed pool's smallest request
// Its cache of free blocks: a MASt3R pass at 512×384 (≈ 460 MB of activations at its high-water mark) is served from
// the previous pass's blocks with 384 MiB, where 256 MiB left ≈ 300 MB to be mapped and faulted in again each pass
// (0.42 ms/MB on a 2-core EPYC VM: ≈ 2 % of a query). The slack keeps idle blocks from raising the peak of a pass
// they do not fit; counted from the current owner's high-water mark, it lets the cache stay across the models of a
// `seed` query (1 GiB: replaying a bf16 `seed` run's allocations, 11.4 instead of 12.8 GB mapped, the same pool peak).
constexpr size_t kPoolCache = size_t{1024} << 20;
constexpr size_t kPoolIdleSlack = size_t{192} << 20;

size_t RoundUp(size_t n) { return (n + kGranule - 1) / kGranule * kGranule; }

}  // namespace

TensorPool::TensorPool(size_t min_bytes, size_t cache_cap_bytes, size_t idle_slack_bytes)
    : min_bytes_(min_bytes), cap_(cache_cap_bytes), slack_(idle_slack_bytes) {}

TensorPool::~TensorPool() {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& [p, b] : blocks_) munmap(p, b.bytes);
}

void* TensorPool::Allocate(size_t n) {
  if (n > (SIZE_MAX >> 1)) throw std::bad_alloc();
  const size_t bytes = RoundUp(n);
  std::lock_guard<std::mutex> lock(mu_);
  // The smallest free block that fits, up to 1.5× the size: a block already resident serves the request, where a
  // new one would be faulted in while the other waits in the cache. (Up to 2× let long-lived tensors — weights
  // converted at load, a bf16 copy in its fp32 original's block — hold twice their size: replaying a bf16 `seed`
  // run's allocations, 1.5× lowers the pool's peak by 108 MB for 6 % more bytes mapped.)
  auto it = free_by_size_.lower_bound(bytes);
  if (it != free_by_size_.end() && it->first <= bytes + bytes / 2) {
    void* p = it->second;
    Block& b = blocks_.at(p);
    free_by_size_.erase(it);
    free_lru_.erase(b.lru);
    stats_.cached_bytes -= b.bytes;
    stats_.live_bytes += b.bytes;
    stats_.peak_live_bytes = std::max(stats_.peak_live_bytes, stats_.live_bytes);
    pass_high_ = std::max(pass_high_, stats_.live_bytes);
    ++stats_.hits;
    return p;
  }
  // None: make room under the cap for what is about to be mapped, and under the idle slack above the live high-water
  // mark (live + cached + new ≤ high-water + slack), then map.
  size_t keep = cap_ > bytes ? cap_ - bytes : 0;
  if (slack_ != SIZE_MAX) {
    const size_t high = std::max(pass_high_, stats_.live_bytes + bytes);
    const size_t room = high - stats_.live_bytes - bytes;  // ≥ 0 by the max above
    keep = std::min(keep, room > SIZE_MAX - slack_ ? SIZE_MAX : room + slack_);
  }
  EvictOver(keep);
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) {
    EvictOver(0);  // everything cached goes back; one more try
    p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
  }
  blocks_[p] = Block{bytes, {}, {}};
  stats_.live_bytes += bytes;
  stats_.peak_live_bytes = std::max(stats_.peak_live_bytes, stats_.live_bytes);
  pass_high_ = std::max(pass_high_, stats_.live_bytes);
  stats_.peak_bytes = std::max(stats_.peak_bytes, stats_.live_bytes + stats_.cached_bytes);
  ++stats_.misses;
  return p;
}

void TensorPool::Free(void* p) {
  std::lock_guard<std::mutex> lock(mu_);
  Block& b = blocks_.at(p);
  free_lru_.push_front(p);
  b.lru = free_lru_.begin();
  b.by_size = free_by_size_.emplace(b.bytes, p);
  stats_.live_bytes -= b.bytes;
  stats_.cached_bytes += b.bytes;
  EvictOver(cap_);
}

bool TensorPool::Owns(void* p) const {
  std::lock_guard<std::mutex> lock(mu_);
  return blocks_.count(p) > 0;
}

void TensorPool::Trim() {
  std::lock_guard<std::mutex> lock(mu_);
  EvictOver(0);
  owner_ = nullptr;
  pass_high_ = stats_.live_bytes;
}

void TensorPool::Keep(const void* owner) {
  std::lock_guard<std::mutex> lock(mu_);
  owner_ = owner;
}

bool TensorPool::Claim(const void* owner) {
  std::lock_guard<std::mutex> lock(mu_);
  const bool changed = owner_ != owner;
  if (changed) pass_high_ = stats_.live_bytes;
  owner_ = owner;
  return changed;
}

TensorPoolStats TensorPool::Stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stats_;
}

void TensorPool::EvictOver(size_t cap) {
  while (stats_.cached_bytes > cap && !free_lru_.empty()) {
    void* p = free_lru_.back();
    free_lru_.pop_back();
    const auto b = blocks_.find(p);
    const size_t bytes = b->second.bytes;
    free_by_size_.erase(b->second.by_size);
    blocks_.erase(b);
    munmap(p, bytes);
    stats_.cached_bytes -= bytes;
  }
}

namespace {

// Set once (InstallTensorPool) before any tensor of the pool exists; read by every allocation and by
// ReleaseFreedMemory on any thread.
std::atomic<TensorPool*> g_pool{nullptr};
c10::Allocator* g_fallback = nullptr;

void FreePooled(void* p) { g_pool.load(std::memory_order_acquire)->Free(p); }

// Deletes what either allocator made (raw_allocate's callers free through raw_deleter()).
void FreeAny(void* p) {
  if (!p) return;
  TensorPool* pool = g_pool.load(std::memory_order_acquire);
  if (pool->Owns(p)) {
    pool->Free(p);
  } else {
    g_fallback->raw_deleter()(p);
  }
}

class PoolAllocator final : public c10::Allocator {
 public:
  c10::DataPtr allocate(size_t n) const override {
    TensorPool* pool = g_pool.load(std::memory_order_acquire);
    if (n < pool->min_bytes()) return g_fallback->allocate(n);
    void* p = pool->Allocate(n);
    return {p, p, &FreePooled, c10::Device(c10::DeviceType::CPU)};
  }
  c10::DeleterFnPtr raw_deleter() const override { return g_fallback->raw_deleter() ? &FreeAny : nullptr; }
};

}  // namespace

TensorPool* InstalledTensorPool() { return g_pool.load(std::memory_order_acquire); }

void InstallTensorPool() {
  static std::once_flag once;
  std::call_once(once, [] {
    const char* env = EnvSwitch("FREELOC_TENSOR_POOL");
    if (env && std::strcmp(env, "off") == 0) return;
    g_fallback = c10::GetCPUAllocator();
    // Lives as long as the process: tensors may outlive any owner.
    g_pool.store(new TensorPool(kPoolMin, kPoolCache, kPoolIdleSlack), std::memory_order_release);
    static PoolAllocator allocator;
    c10::SetCPUAllocator(&allocator, /*priority=*/0);
  });
}

}  // namespace freeloc::nn::internal
