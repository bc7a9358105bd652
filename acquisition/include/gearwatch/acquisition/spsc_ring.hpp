#pragma once
// Lock-free single-producer / single-consumer ring of trivially copyable items.
// Overflow policy is explicit and counted: the producer's try_push() never blocks and returns
// false when the ring is full; the caller decides (live sources drop and count, file sources
// wait). Capacity is rounded up to a power of two; storage is allocated once.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <stdexcept>
#include <type_traits>

namespace gearwatch::acquisition {

template <typename T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "ring items are copied with plain assignment");

 public:
  explicit SpscRing(std::size_t min_capacity) {
    if (min_capacity < 2) throw std::invalid_argument("SpscRing capacity must be at least 2");
    std::size_t capacity = 2;
    while (capacity < min_capacity) capacity <<= 1;
    mask_ = capacity - 1;
    slots_ = std::make_unique<T[]>(capacity);
  }
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  std::size_t capacity() const noexcept { return mask_ + 1; }

  /// Producer side. Returns false (and counts an overflow) when full; never blocks.
  bool try_push(const T& item) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) {
        overflows_.fetch_add(1, std::memory_order_relaxed);
        return false;
      }
    }
    slots_[head & mask_] = item;
    head_.store(head + 1, std::memory_order_release);
    // The cached tail is only refreshed when the ring looks full, so it would overstate the fill;
    // read the consumer's real position (a relaxed load: an upper bound by at most a few items).
    const std::size_t fill = head + 1 - tail_.load(std::memory_order_relaxed);
    if (fill > high_water_.load(std::memory_order_relaxed)) high_water_.store(fill, std::memory_order_relaxed);
    return true;
  }

  /// Consumer side. Returns false when empty.
  bool try_pop(T& out) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    out = slots_[tail & mask_];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Approximate fill level; exact when called from either end with the other idle.
  std::size_t size() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  /// Pushes refused because the ring was full.
  std::uint64_t overflows() const noexcept { return overflows_.load(std::memory_order_relaxed); }
  /// Highest fill level seen by the producer after a push.
  std::size_t high_water() const noexcept { return high_water_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::size_t kLine = 64;
  alignas(kLine) std::atomic<std::size_t> head_{0};
  std::size_t tail_cache_ = 0;             // producer's view of tail
  std::atomic<std::uint64_t> overflows_{0};
  std::atomic<std::size_t> high_water_{0};
  alignas(kLine) std::atomic<std::size_t> tail_{0};
  std::size_t head_cache_ = 0;             // consumer's view of head
  alignas(kLine) std::size_t mask_ = 0;
  std::unique_ptr<T[]> slots_;
};

}  // namespace gearwatch::acquisition
