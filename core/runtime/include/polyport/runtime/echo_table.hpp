// Loop prevention for models that hand a sender's own messages back to it and carry no
// sender identity polyport could test (LCM's UDP multicast loops every datagram back to the
// host's subscribers; a CAN interface loops every frame back to the host's other sockets).
// Before polyport sends a message on a channel it also receives, it records the message's
// fingerprint here, with how many of polyport's receivers will see it; each of those
// receivers, on a message whose fingerprint is pending, consumes one share and drops the
// message instead of forwarding it again. A message with the same bytes from someone else,
// arriving first, is dropped in the echo's place and the echo goes through instead: the same
// bytes are forwarded the same number of times either way. An entry lives kLifetime at most,
// so an echo that never comes (a lost datagram) does not suppress a later message.
//
// Threads: expect and forget run on any sending thread, consume on the receiving thread;
// lock-free (compare-and-swap on each slot), no allocation. A slot is found by the
// fingerprint's low bits with kProbe neighbours; when all are taken by live entries, expect
// returns false and that one echo will not be recognized (the caller counts it).
// Most receptions find the table empty (polyport sends nothing its own receivers on that
// channel or interface would see): empty() says so from one word, before the caller hashes
// the message and reads the clock, and consume() then touches no slot.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "polyport/base/clock.hpp"

namespace polyport {

class EchoTable {
 public:
  static constexpr std::size_t kSlots = 256;  // a power of two
  static constexpr std::size_t kProbe = 8;
  static constexpr Nanos kLifetime{1'000'000'000};

  // Records an echo to come (before the message is sent). `receivers`: how many of
  // polyport's receivers will each see it once; 0 records nothing.
  bool expect(std::uint64_t fingerprint, std::uint32_t receivers, MonoTime now) noexcept {
    if (receivers == 0) return true;
    fingerprint = usable(fingerprint);
    const std::size_t home = fingerprint & (kSlots - 1);
    for (std::size_t k = 0; k < kProbe; ++k) {
      Slot& slot = slots_[(home + k) & (kSlots - 1)];
      std::uint64_t current = slot.fingerprint.load(std::memory_order_acquire);
      const bool free = current == kFree ||
                        (current != kClaimed && slot.expires.load(std::memory_order_relaxed) <= now.ns);
      if (!free || !slot.fingerprint.compare_exchange_strong(current, kClaimed, std::memory_order_acquire)) continue;
      // Counted before the entry is published (and so before the message is sent): a
      // receiver that sees the echo sees the table non-empty. A reused expired entry was
      // counted already.
      if (current == kFree) occupied_.fetch_add(1, std::memory_order_relaxed);
      slot.remaining.store(receivers, std::memory_order_relaxed);
      slot.expires.store(now.ns + kLifetime.count, std::memory_order_relaxed);
      slot.fingerprint.store(fingerprint, std::memory_order_release);
      return true;
    }
    return false;
  }

  // No entry at all, live or expired: no message can be an echo now.
  bool empty() const noexcept { return occupied_.load(std::memory_order_acquire) == 0; }

  // On the receiving thread: true when this message is the echo of one polyport sent (one
  // share of its entry taken), to be dropped.
  bool consume(std::uint64_t fingerprint, MonoTime now) noexcept {
    if (empty()) return false;
    fingerprint = usable(fingerprint);
    const std::size_t home = fingerprint & (kSlots - 1);
    for (std::size_t k = 0; k < kProbe; ++k) {
      Slot& slot = slots_[(home + k) & (kSlots - 1)];
      // An expired entry (an echo that never came) stays counted until expect reuses its
      // slot: freeing it here could free a live entry that expect has just put in its place
      // with the same bytes (the CAS cannot tell the two apart), and lose that echo.
      if (slot.fingerprint.load(std::memory_order_acquire) != fingerprint) continue;
      if (slot.expires.load(std::memory_order_relaxed) <= now.ns) continue;  // expect reuses it
      std::uint32_t left = slot.remaining.load(std::memory_order_relaxed);
      while (left != 0 && !slot.remaining.compare_exchange_weak(left, left - 1, std::memory_order_acq_rel)) {
      }
      if (left == 0) continue;
      if (slot.fingerprint.load(std::memory_order_acquire) != fingerprint) {
        // expect reused the slot (the entry had just expired) between the checks above and the
        // share taken: the share was the new entry's; give it back.
        slot.remaining.fetch_add(1, std::memory_order_acq_rel);
        continue;
      }
      if (left == 1) {  // the last share: the slot is free again
        std::uint64_t expected = fingerprint;
        if (slot.fingerprint.compare_exchange_strong(expected, kFree, std::memory_order_acq_rel)) {
          occupied_.fetch_sub(1, std::memory_order_relaxed);
        }
      }
      return true;
    }
    return false;
  }

  // Takes back what expect recorded when the message could not be sent after all.
  void forget(std::uint64_t fingerprint) noexcept {
    fingerprint = usable(fingerprint);
    const std::size_t home = fingerprint & (kSlots - 1);
    for (std::size_t k = 0; k < kProbe; ++k) {
      Slot& slot = slots_[(home + k) & (kSlots - 1)];
      std::uint64_t expected = fingerprint;
      if (slot.fingerprint.compare_exchange_strong(expected, kFree, std::memory_order_acq_rel)) {
        occupied_.fetch_sub(1, std::memory_order_relaxed);
        return;
      }
    }
  }

 private:
  static constexpr std::uint64_t kFree = 0;
  static constexpr std::uint64_t kClaimed = 1;  // being written by expect
  static std::uint64_t usable(std::uint64_t fingerprint) noexcept {
    return fingerprint <= kClaimed ? fingerprint + 2 : fingerprint;
  }

  struct Slot {
    std::atomic<std::uint64_t> fingerprint{kFree};
    std::atomic<std::int64_t> expires{0};  // CLOCK_MONOTONIC ns
    std::atomic<std::uint32_t> remaining{0};
  };
  std::array<Slot, kSlots> slots_{};
  // Slots not free (claimed, live or expired): empty() reads it, in its own line.
  alignas(64) std::atomic<std::uint32_t> occupied_{0};
};

// A 64-bit fingerprint of a message's bytes (and length): not cryptographic, only unlikely to
// collide between two different messages in flight at once. Four independent lanes of eight
// bytes each, so that the multiplications of one 32-byte block overlap.
inline std::uint64_t message_fingerprint(const void* data, std::size_t size) noexcept {
  constexpr std::uint64_t kMul = 0x9E3779B97F4A7C15ull;
  constexpr std::uint64_t kMul2 = 0xC2B2AE3D27D4EB4Full;
  auto round = [](std::uint64_t h, std::uint64_t v) noexcept {
    h ^= v * kMul;
    h = (h << 31) | (h >> 33);
    return h * kMul2;
  };
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t lane[4] = {0x27D4EB2F165667C5ull ^ size, 0x165667B19E3779F9ull, 0x85EBCA77C2B2AE63ull,
                           0xFF51AFD7ED558CCDull};
  std::size_t i = 0;
  for (; i + 32 <= size; i += 32) {
    std::uint64_t v[4];
    std::memcpy(v, p + i, sizeof v);
    for (int k = 0; k < 4; ++k) lane[k] = round(lane[k], v[k]);
  }
  for (int k = 0; i + 8 <= size; i += 8, ++k) {
    std::uint64_t v;
    std::memcpy(&v, p + i, 8);
    lane[k] = round(lane[k], v);
  }
  if (i < size) {
    std::uint64_t v = 0;
    std::memcpy(&v, p + i, size - i);
    lane[3] = round(lane[3], v ^ 0xFF);
  }
  std::uint64_t h = round(round(lane[0], lane[1]), round(lane[2], lane[3])) ^ (size * kMul);
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  return h ^ (h >> 32);
}

}  // namespace polyport
