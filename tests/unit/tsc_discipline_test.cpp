// TscDiscipline (polyport/base/tsc_discipline.hpp), driven with made-up pairs: a TSC at
// 2.3 GHz and a CLOCK_MONOTONIC that drifts from it, jumps, or stops being paired with it.
// Whatever happens, the lines it publishes join where the last one stood and never go back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "polyport/base/tsc_discipline.hpp"

namespace polyport::detail {
namespace {

constexpr double kTicksPerNs = 2.3;
constexpr std::int64_t kInterval = 250'000'000;
constexpr std::int64_t kBracket = 120;  // ticks: a vDSO read

// The TSC and CLOCK_MONOTONIC of a made-up machine: the TSC ticks at kTicksPerNs; the kernel's
// clock runs `ppm` fast of it (NTP's frequency correction) and may be stepped.
struct Machine {
  double tsc = 1e12;
  double mono_ns = 5e9;
  double ppm = 0;

  void run(std::int64_t ns) {
    tsc += static_cast<double>(ns) * kTicksPerNs;
    mono_ns += static_cast<double>(ns) * (1.0 + ppm * 1e-6);
  }
  TscPoint pair(std::int64_t bracket = kBracket, std::int64_t held_up_ns = 0) const {
    return TscPoint{std::llround(tsc), bracket, std::llround(mono_ns) + held_up_ns, 1'700'000'000'000'000'000};
  }
  std::int64_t publish_tsc() const { return std::llround(tsc) + 500; }  // the update took ≈ 200 ns
};

// Drives one discipline and checks, at every update, that the new line takes over where the
// published one stands (or above it, on a step ahead) and that both have a positive slope.
class Driven {
 public:
  explicit Driven(Machine& machine) : machine_(machine) {
    const TscPoint anchor = machine_.pair();
    machine_.run(50'000'000);
    Result<TscLine> first = discipline_.begin(anchor, machine_.pair());
    EXPECT_TRUE(first) << first.error().message;
    published_ = discipline_.line();
  }

  TscDiscipline::Update next(std::int64_t bracket = kBracket, std::int64_t held_up_ns = 0) {
    machine_.run(kInterval);
    const std::int64_t publish = machine_.publish_tsc();
    Result<TscDiscipline::Update> update = discipline_.update(machine_.pair(bracket, held_up_ns), publish, kInterval);
    EXPECT_TRUE(update) << update.error().message;
    if (!update) return {};
    {
      const TscLine& line = update.value().line;
      EXPECT_GE(line.at(publish), published_.at(publish)) << "the clock went back where the new line took over";
      if (update.value().outcome != TscDiscipline::Outcome::stepped) {
        EXPECT_EQ(line.at(publish), published_.at(publish));
      }
      EXPECT_GT(line.per_tick_q32, 0U);
      published_ = line;
    }
    return update.value();
  }

  // The published line's error now: CLOCK_MONOTONIC − the line.
  std::int64_t error_ns() const { return machine_.pair().mono_ns - published_.at(machine_.pair().tsc); }
  TscDiscipline& discipline() { return discipline_; }

 private:
  Machine& machine_;
  TscDiscipline discipline_;
  TscLine published_;
};

TEST(TscDiscipline, SteersOntoADriftingClockWithoutEverStepping) {
  Machine machine;
  machine.ppm = 40;
  Driven driven(machine);
  for (int i = 0; i < 80; ++i) {
    if (i == 40) machine.ppm = -30;  // NTP changed its mind
    EXPECT_EQ(driven.next().outcome, TscDiscipline::Outcome::steered) << "update " << i;
  }
  // The rate is measured over the last 4 s: 6 s after the change it is the new one, and the
  // error each interval left is steered out.
  EXPECT_LT(std::llabs(driven.error_ns()), 1'000);
  EXPECT_NEAR(driven.discipline().ns_per_tick(), (1.0 + machine.ppm * 1e-6) / kTicksPerNs, 1e-6 / kTicksPerNs);
}

TEST(TscDiscipline, ConvergesFromAFirstRateThatWasOff) {
  Machine machine;
  TscDiscipline discipline;
  const TscPoint anchor = machine.pair();
  machine.run(50'000'000);
  TscPoint late = machine.pair();
  late.mono_ns += 5'000;  // the first baseline's second read landed late: 100 ppm off
  ASSERT_TRUE(discipline.begin(anchor, late));
  machine.run(kInterval);
  TscLine published = discipline.line();
  std::int64_t last_error = 0;
  for (int i = 0; i < 40; ++i) {
    const std::int64_t publish = machine.publish_tsc();
    Result<TscDiscipline::Update> update = discipline.update(machine.pair(), publish, kInterval);
    ASSERT_TRUE(update) << update.error().message;
    EXPECT_EQ(update.value().outcome, TscDiscipline::Outcome::steered);
    EXPECT_EQ(update.value().line.at(publish), published.at(publish));
    published = update.value().line;
    last_error = update.value().error_ns;
    machine.run(kInterval);
  }
  EXPECT_LT(std::llabs(last_error), 200);
}

TEST(TscDiscipline, StepsAheadWhenFarBehind) {
  Machine machine;
  Driven driven(machine);
  for (int i = 0; i < 4; ++i) driven.next();
  machine.mono_ns += 30e6;  // the machine was paused; CLOCK_MONOTONIC counted it, the TSC not
  const TscDiscipline::Update step = driven.next();
  EXPECT_EQ(step.outcome, TscDiscipline::Outcome::stepped);
  EXPECT_NEAR(static_cast<double>(step.error_ns), 30e6, 1e3);
  EXPECT_LT(std::llabs(driven.error_ns()), 1'000);
  // The rate was not measured across the pause: the clock carries on steering, on time.
  for (int i = 0; i < 8; ++i) EXPECT_EQ(driven.next().outcome, TscDiscipline::Outcome::steered);
  EXPECT_LT(std::llabs(driven.error_ns()), 1'000);
}

TEST(TscDiscipline, SlewsBackRatherThanStepBackWhenFarAhead) {
  Machine machine;
  Driven driven(machine);
  for (int i = 0; i < 4; ++i) driven.next();
  machine.mono_ns -= 40e6;  // CLOCK_MONOTONIC fell 40 ms behind the TSC (checked as never back in next())
  int slewed = 0;
  int updates = 0;
  while (driven.next().outcome == TscDiscipline::Outcome::slewed && ++updates < 20) ++slewed;
  // At most 10 % slow: 25 ms per 250 ms interval, so two intervals of slewing, then steering.
  EXPECT_EQ(slewed, 2);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(driven.next().outcome, TscDiscipline::Outcome::steered);
  EXPECT_LT(std::llabs(driven.error_ns()), 1'000);
}

TEST(TscDiscipline, AWriterHeldUpBeforePublishingDoesNotSetTheClockBack) {
  Machine machine;
  TscDiscipline discipline;
  const TscPoint anchor = machine.pair();
  machine.run(50'000'000);
  ASSERT_TRUE(discipline.begin(anchor, machine.pair()));
  const TscLine published = discipline.line();
  machine.run(kInterval);
  machine.mono_ns -= 40e6;  // far ahead: the new line runs 10 % slow
  const std::int64_t publish = machine.publish_tsc();
  Result<TscDiscipline::Update> update = discipline.update(machine.pair(), publish, kInterval);
  ASSERT_TRUE(update);
  ASSERT_EQ(update.value().outcome, TscDiscipline::Outcome::slewed);
  const TscLine& slower = update.value().line;
  // Readers keep the old line until the writer switches them, 10 ms late here (preempted):
  // the slower line as computed would be 1 ms below what they last read; joined again at
  // the switch, it is not.
  const std::int64_t switched = publish + std::llround(10e6 * kTicksPerNs);
  EXPECT_LT(slower.at(switched), published.at(switched) - 900'000);
  const TscLine joined = TscDiscipline::rejoin(published, slower, switched);
  EXPECT_EQ(joined.at(switched), published.at(switched));
  EXPECT_EQ(joined.per_tick_q32, slower.per_tick_q32);
  EXPECT_GT(joined.at(switched + 1000), published.at(switched));
  // A line that is not below the old one at the switch is written as it is.
  const TscLine same = TscDiscipline::rejoin(published, slower, publish);
  EXPECT_EQ(same.base_tsc, slower.base_tsc);
  EXPECT_EQ(same.base_mono_ns, slower.base_mono_ns);
}

TEST(TscDiscipline, SkipsAPreemptedPairUnlessItKeepsHappening) {
  Machine machine;
  Driven driven(machine);
  for (int i = 0; i < 4; ++i) driven.next();
  // Preempted between the TSC reads: a wide bracket, its CLOCK_MONOTONIC read 0.4 ms late.
  const TscDiscipline::Update held_up = driven.next(kBracket * 500, 400'000);
  EXPECT_EQ(held_up.outcome, TscDiscipline::Outcome::skipped);
  EXPECT_LT(std::llabs(driven.error_ns()), 1'000);
  EXPECT_EQ(driven.next().outcome, TscDiscipline::Outcome::steered);
  // Brackets four times as wide as ever seen, for good (a loaded machine): after eight
  // skipped pairs they are used.
  std::vector<TscDiscipline::Outcome> outcomes;
  for (int i = 0; i < TscDiscipline::kMaxSkipsInARow + 1; ++i) outcomes.push_back(driven.next(kBracket * 5).outcome);
  for (int i = 0; i < TscDiscipline::kMaxSkipsInARow; ++i) EXPECT_EQ(outcomes[i], TscDiscipline::Outcome::skipped);
  EXPECT_EQ(outcomes.back(), TscDiscipline::Outcome::steered);
}

TEST(TscDiscipline, GivesUpOnATscThatGoesBack) {
  Machine machine;
  Driven driven(machine);
  driven.next();
  machine.tsc -= 1e6;
  Result<TscDiscipline::Update> update = driven.discipline().update(machine.pair(), machine.publish_tsc(), kInterval);
  ASSERT_FALSE(update);
  EXPECT_NE(update.error().message.find("went back"), std::string::npos) << update.error().message;
}

TEST(TscDiscipline, GivesUpOnATscWhoseRateChanged) {
  Machine machine;
  Driven driven(machine);
  for (int i = 0; i < 4; ++i) driven.next();
  machine.ppm = 20'000;  // the TSC now ticks 2 % slow of the kernel's clock
  // The first discontinuity could be a pause: a step. The second, measured from the first,
  // is a rate no TSC changes to.
  EXPECT_EQ(driven.next().outcome, TscDiscipline::Outcome::stepped);
  machine.run(kInterval);
  Result<TscDiscipline::Update> update = driven.discipline().update(machine.pair(), machine.publish_tsc(), kInterval);
  ASSERT_FALSE(update);
  EXPECT_NE(update.error().message.find("rate moved by 2.0"), std::string::npos) << update.error().message;
}

TEST(TscDiscipline, RefusesAFirstBaselineThatIsNoClock) {
  Machine machine;
  TscDiscipline discipline;
  const TscPoint anchor = machine.pair();
  EXPECT_FALSE(discipline.begin(anchor, anchor));
  machine.run(50'000'000);
  TscPoint slow = machine.pair();
  slow.tsc = anchor.tsc + (slow.tsc - anchor.tsc) / 1000;  // 2.3 MHz
  Result<TscLine> line = discipline.begin(anchor, slow);
  ASSERT_FALSE(line);
  EXPECT_NE(line.error().message.find("no CPU has"), std::string::npos) << line.error().message;
}

}  // namespace
}  // namespace polyport::detail
