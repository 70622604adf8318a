// Loop prevention for DDS: the writers polyport itself has on one topic of one participant,
// so that polyport's readers of that topic drop what those writers wrote. Without it a
// profile that bridges a topic in both directions (the topic's samples read into one port
// and some port's samples written back to the same topic) would read its own samples back
// and forward them again, forever: each DDS reader matches every writer of its topic,
// polyport's own included (in-process delivery, no network needed).
//
// Each vendor says what identifies a writer in a received sample's info: Cyclone the
// publication handle (the writer's instance handle, dds_get_instance_handle), Fast DDS the
// entity id of the GUID its publication handle holds (the prefix being the participant's).
// Either fits a nonzero 64-bit key.
//
// Threads: add / remove run on the control thread (writers are made and deleted there);
// contains runs on the SDK's delivery threads, lock-free and allocation-free: a handful of
// relaxed loads (a topic rarely has more than one or two writers of polyport's). A writer
// added after a sample of it was taken is not in the set for that sample; writers are added
// before they write, so that cannot happen for a sample they wrote.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace polyport::dds {

class OwnWriters {
 public:
  // More of polyport's writers on one topic of one participant than this are not guarded
  // (add returns false and the domain says so in describe).
  static constexpr std::size_t kCapacity = 16;

  bool add(std::uint64_t key) noexcept {
    if (key == 0) return false;
    for (std::size_t i = 0; i < kCapacity; ++i) {
      std::uint64_t empty = 0;
      if (keys_[i].compare_exchange_strong(empty, key, std::memory_order_release)) {
        std::size_t used = used_.load(std::memory_order_relaxed);
        while (used < i + 1 && !used_.compare_exchange_weak(used, i + 1, std::memory_order_release)) {
        }
        return true;
      }
    }
    return false;
  }

  void remove(std::uint64_t key) noexcept {
    if (key == 0) return;
    for (auto& slot : keys_) {
      std::uint64_t expected = key;
      if (slot.compare_exchange_strong(expected, 0, std::memory_order_release)) return;
    }
  }

  bool contains(std::uint64_t key) const noexcept {
    const std::size_t used = used_.load(std::memory_order_acquire);
    for (std::size_t i = 0; i < used; ++i) {
      if (keys_[i].load(std::memory_order_relaxed) == key) return true;
    }
    return false;
  }

 private:
  std::array<std::atomic<std::uint64_t>, kCapacity> keys_{};
  std::atomic<std::size_t> used_{0};  // slots at or above it were never used
};

}  // namespace polyport::dds
