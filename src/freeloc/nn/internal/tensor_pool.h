// LibTorch's CPU allocator for large tensors: freed blocks are kept by size and handed to the next tensor of (nearly)
// that size, instead of glibc's heap. A network pass allocates the same few sizes again and again (every block of a
// ViT, every iteration of a GRU); glibc serves them from one heap where a long-lived tensor pins the memory around it
// (freed but resident: 0.5 GB of a bf16 `seed` query's peak), or, above its mmap threshold, maps and faults them in
// anew each time. Here a block is mapped once, reused while the pass runs (by requests up to its size and down to two
// thirds of it) and by the passes after it, and unmapped when the cache of free blocks outgrows its cap or its idle
// slack (least recently freed first) or on Trim (nn::ReleaseFreedMemory()). Small tensors stay with LibTorch's own
// allocator.
#pragma once

#include <cstddef>
#include <cstdint>
#include <list>
#include <map>
#include <mutex>
#include <unordered_map>

namespace freeloc::nn::internal {

struct TensorPoolStats {
  size_t live_bytes = 0;       // in blocks handed out
  size_t cached_bytes = 0;     // in free blocks kept for reuse
  size_t peak_bytes = 0;       // the most live + cached at once
  size_t peak_live_bytes = 0;  // the most live at once
  uint64_t hits = 0, misses = 0;
};

class TensorPool {
 public:
  // Requests below `min_bytes` are not the pool's (Owns() is false for them: the caller's other allocator serves
  // them); free blocks beyond `cache_cap_bytes` are unmapped. `idle_slack_bytes` bounds what idle blocks may add to
  // the pool's footprint: before a block is mapped, cached blocks are unmapped (least recently freed first) until
  // live + cached + the new block ≤ the high-water mark of live bytes (since the owner last changed: Claim) +
  // idle_slack_bytes. The pool's peak is then at most that high-water mark + idle_slack_bytes whatever the cap, so
  // the cap can be large enough for a whole pass of the same network to be served from its previous pass's blocks
  // without idle blocks raising the peak of a pass whose sizes they do not fit. SIZE_MAX: no such bound.
  TensorPool(size_t min_bytes, size_t cache_cap_bytes, size_t idle_slack_bytes = SIZE_MAX);
  ~TensorPool();
  TensorPool(const TensorPool&) = delete;
  TensorPool& operator=(const TensorPool&) = delete;

  size_t min_bytes() const { return min_bytes_; }
  // A block of at least n bytes (n ≥ min_bytes), 4096-aligned; throws std::bad_alloc when the system has none.
  void* Allocate(size_t n);
  // Back to the cache; p must come from Allocate.
  void Free(void* p);
  bool Owns(void* p) const;
  // Unmaps every free block.
  void Trim();
  // `owner`'s pass (a model's) just ended; its free blocks stay cached for the next pass — the same network asks for
  // the same sizes, served without page faults.
  void Keep(const void* owner);
  // A pass of `owner` begins. The cache stays whoever left it: blocks of the right sizes serve this pass too, and the
  // slack rule bounds what the others add to the peak. Returns whether the owner changed.
  bool Claim(const void* owner);
  TensorPoolStats Stats() const;

 private:
  struct Block {
    size_t bytes = 0;
    // While free: its entries in free_lru_ and free_by_size_.
    std::list<void*>::iterator lru;
    std::multimap<size_t, void*>::iterator by_size;
  };
  void EvictOver(size_t cap);  // mu_ held

  const size_t min_bytes_, cap_, slack_;
  mutable std::mutex mu_;
  std::unordered_map<void*, Block> blocks_;  // every mapped block
  std::multimap<size_t, void*> free_by_size_;
  std::list<void*> free_lru_;    // most recently freed first
  const void* owner_ = nullptr;  // whose blocks the cache holds (Keep / Claim); null: nobody's
  // The live high-water mark the slack is counted from: since the current owner's first pass began (Claim) or the
  // last Trim — not the process's, which a larger pass of another model (the reference side) may have set.
  size_t pass_high_ = 0;
  TensorPoolStats stats_;
};

// The process's pool behind LibTorch's CPU allocator (tensors of 1 MiB and more; a cache of free blocks up to 1 GiB,
// idle blocks at most 192 MiB beyond the live high-water mark).
// Installed once, by ApplyRuntime for CPU models; FREELOC_TENSOR_POOL=off leaves LibTorch's allocator alone.
TensorPool* InstalledTensorPool();  // null until installed
void InstallTensorPool();

}  // namespace freeloc::nn::internal
