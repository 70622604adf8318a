// EchoTable (polyport/runtime/echo_table.hpp), the loop prevention of LCM and CAN: what it
// drops, how often, and when it stops dropping.
#include "polyport/runtime/echo_table.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <thread>
#include <vector>

namespace polyport {
namespace {

constexpr MonoTime kNow{10'000'000'000};

std::uint64_t fingerprint_of(const char* text) { return message_fingerprint(text, std::strlen(text)); }

TEST(EchoTable, DropsAnExpectedEchoOncePerReceiver) {
  EchoTable table;
  const std::uint64_t f = fingerprint_of("pose 1");
  ASSERT_TRUE(table.expect(f, 2, kNow));
  EXPECT_TRUE(table.consume(f, kNow));
  EXPECT_TRUE(table.consume(f, kNow));
  EXPECT_FALSE(table.consume(f, kNow)) << "a third copy is not an echo of one send to two receivers";
}

TEST(EchoTable, NothingExpectedNothingDropped) {
  EchoTable table;
  EXPECT_FALSE(table.consume(fingerprint_of("pose 1"), kNow));
  ASSERT_TRUE(table.expect(fingerprint_of("pose 1"), 0, kNow));  // no receiver of polyport's
  EXPECT_FALSE(table.consume(fingerprint_of("pose 1"), kNow));
  ASSERT_TRUE(table.expect(fingerprint_of("pose 1"), 1, kNow));
  EXPECT_FALSE(table.consume(fingerprint_of("pose 2"), kNow)) << "other bytes";
}

TEST(EchoTable, AnEchoThatNeverCameStopsCountingAfterItsLifetime) {
  EchoTable table;
  const std::uint64_t f = fingerprint_of("lost");
  ASSERT_TRUE(table.expect(f, 1, kNow));
  EXPECT_FALSE(table.consume(f, kNow + EchoTable::kLifetime)) << "a later message with the same bytes goes through";
}

TEST(EchoTable, ForgetTakesBackAnEchoThatWasNotSent) {
  EchoTable table;
  const std::uint64_t f = fingerprint_of("failed send");
  ASSERT_TRUE(table.expect(f, 1, kNow));
  table.forget(f);
  EXPECT_FALSE(table.consume(f, kNow));
}

TEST(EchoTable, RepeatedIdenticalSendsAreEachDroppedOnce) {
  EchoTable table;
  const std::uint64_t f = fingerprint_of("same bytes");
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(table.expect(f, 1, kNow));
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(table.consume(f, kNow)) << i;
  EXPECT_FALSE(table.consume(f, kNow));
}

TEST(EchoTable, AFullNeighbourhoodRefusesAndSaysSo) {
  EchoTable table;
  const std::uint64_t f = fingerprint_of("crowded");
  for (std::size_t i = 0; i < EchoTable::kProbe; ++i) ASSERT_TRUE(table.expect(f, 1, kNow));
  EXPECT_FALSE(table.expect(f, 1, kNow));
  // Expired entries are taken again.
  EXPECT_TRUE(table.expect(f, 1, kNow + EchoTable::kLifetime));
}

TEST(EchoTable, FingerprintsTellLengthAndEveryByteApart) {
  const char a[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  char b[9];
  std::memcpy(b, a, sizeof a);
  b[8] = 10;
  EXPECT_NE(message_fingerprint(a, 9), message_fingerprint(b, 9));
  EXPECT_NE(message_fingerprint(a, 8), message_fingerprint(a, 9));
  EXPECT_EQ(message_fingerprint(a, 9), message_fingerprint(a, 9));
  const char zeros[2] = {0, 0};
  EXPECT_NE(message_fingerprint(zeros, 1), message_fingerprint(zeros, 2));
}

// Senders and receivers on several threads at once: every expected echo is found once.
TEST(EchoTable, ConcurrentSendersAndAReceiverLoseNoEcho) {
  EchoTable table;
  constexpr int kThreads = 2;
  constexpr int kPerThread = 2000;
  std::vector<std::thread> threads;
  std::atomic<int> dropped{0};
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        const std::uint64_t message[2] = {static_cast<std::uint64_t>(t), static_cast<std::uint64_t>(i)};
        const std::uint64_t f = message_fingerprint(message, sizeof message);
        ASSERT_TRUE(table.expect(f, 1, kNow));
        // The echo comes back at once, as on loopback.
        if (table.consume(f, kNow)) dropped.fetch_add(1);
      }
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(dropped.load(), kThreads * kPerThread);
  EXPECT_TRUE(table.empty()) << "every entry was consumed";
}

// empty() lets a receiver skip hashing a message: it must hold exactly while no entry could
// match, live or expired.
TEST(EchoTable, EmptyExactlyWhileNoEntryIsLeft) {
  EchoTable table;
  const std::uint64_t f = fingerprint_of("pose 1");
  EXPECT_TRUE(table.empty());
  ASSERT_TRUE(table.expect(f, 0, kNow));
  EXPECT_TRUE(table.empty()) << "no receiver of polyport's: nothing recorded";
  ASSERT_TRUE(table.expect(f, 2, kNow));
  EXPECT_FALSE(table.empty());
  EXPECT_TRUE(table.consume(f, kNow));
  EXPECT_FALSE(table.empty()) << "one share left";
  EXPECT_TRUE(table.consume(f, kNow));
  EXPECT_TRUE(table.empty());

  ASSERT_TRUE(table.expect(f, 1, kNow));
  table.forget(f);
  EXPECT_TRUE(table.empty()) << "forgotten";

  // An echo that never came: its entry stays until a new one takes the slot over.
  ASSERT_TRUE(table.expect(f, 1, kNow));
  EXPECT_FALSE(table.consume(f, kNow + EchoTable::kLifetime));
  EXPECT_FALSE(table.empty());
  ASSERT_TRUE(table.expect(f, 1, kNow + EchoTable::kLifetime));
  EXPECT_TRUE(table.consume(f, kNow + EchoTable::kLifetime));
  EXPECT_TRUE(table.empty()) << "the reused slot is counted once";
}

}  // namespace
}  // namespace polyport
