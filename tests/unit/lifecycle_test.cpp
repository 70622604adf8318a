// The shared lifecycle and the periodic execution context.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

class Recorder final : public ComponentBase {
 public:
  ReturnCode onInitialize() override { return log("initialize"); }
  ReturnCode onActivated() override { return log("activated"); }
  ReturnCode onExecute() override {
    execute_thread.store(std::this_thread::get_id());
    if (throw_in_execute) throw std::runtime_error("boom");
    return log("execute", fail_execute ? ReturnCode::error : ReturnCode::ok);
  }
  void onStateUpdate() override { log("update"); }
  ReturnCode onDeactivated() override { return log("deactivated"); }
  ReturnCode onError() override { return log("error"); }
  ReturnCode onReset() override { return log("reset", fail_reset ? ReturnCode::error : ReturnCode::ok); }
  ReturnCode onFinalize() override { return log("finalize"); }

  ReturnCode log(const char* hook, ReturnCode code = ReturnCode::ok) {
    hooks.emplace_back(hook);
    return code;
  }
  std::vector<std::string> hooks;
  bool fail_execute = false;
  bool throw_in_execute = false;
  bool fail_reset = false;
  std::atomic<std::thread::id> execute_thread{};
};

using Hooks = std::vector<std::string>;

TEST(Lifecycle, NormalPathRunsTheHooksInOrder) {
  Recorder c;
  Lifecycle l(c);
  EXPECT_EQ(l.state(), LifecycleState::created);
  EXPECT_EQ(l.apply(LifecycleCommand::initialize), ReturnCode::ok);
  EXPECT_EQ(l.state(), LifecycleState::inactive);
  l.execute();  // inactive: nothing runs
  EXPECT_EQ(l.apply(LifecycleCommand::activate), ReturnCode::ok);
  EXPECT_EQ(l.state(), LifecycleState::active);
  l.execute();
  EXPECT_EQ(l.apply(LifecycleCommand::deactivate), ReturnCode::ok);
  EXPECT_EQ(l.apply(LifecycleCommand::finalize), ReturnCode::ok);
  EXPECT_EQ(l.state(), LifecycleState::finalized);
  EXPECT_EQ(c.hooks, (Hooks{"initialize", "activated", "execute", "update", "deactivated", "finalize"}));
  EXPECT_EQ(l.executions(), 1u);
}

TEST(Lifecycle, CommandsOutOfOrderAreRefused) {
  Recorder c;
  Lifecycle l(c);
  EXPECT_EQ(l.apply(LifecycleCommand::activate), ReturnCode::precondition_not_met);
  EXPECT_EQ(l.apply(LifecycleCommand::reset), ReturnCode::precondition_not_met);
  l.apply(LifecycleCommand::initialize);
  l.apply(LifecycleCommand::activate);
  EXPECT_EQ(l.apply(LifecycleCommand::initialize), ReturnCode::precondition_not_met);
  EXPECT_EQ(l.apply(LifecycleCommand::finalize), ReturnCode::precondition_not_met);  // deactivate first
  EXPECT_EQ(l.state(), LifecycleState::active);
}

TEST(Lifecycle, FailedExecuteEntersErrorAndResetReturnsToInactive) {
  Recorder c;
  Lifecycle l(c);
  l.apply(LifecycleCommand::initialize);
  l.apply(LifecycleCommand::activate);
  c.fail_execute = true;
  l.execute();
  EXPECT_EQ(l.state(), LifecycleState::error);
  EXPECT_EQ(l.errors(), 1u);
  c.hooks.clear();
  l.execute();  // in error: onError each cycle, no onExecute
  l.execute();
  EXPECT_EQ(c.hooks, (Hooks{"error", "error"}));

  c.fail_reset = true;  // RTC: a failing onReset leaves the component in error
  EXPECT_EQ(l.apply(LifecycleCommand::reset), ReturnCode::error);
  EXPECT_EQ(l.state(), LifecycleState::error);
  c.fail_reset = false;
  EXPECT_EQ(l.apply(LifecycleCommand::reset), ReturnCode::ok);
  EXPECT_EQ(l.state(), LifecycleState::inactive);
}

TEST(Lifecycle, ExceptionInExecuteIsAnErrorAndRecoverRestartsIt) {
  Recorder c;
  Lifecycle l(c);
  l.apply(LifecycleCommand::initialize);
  l.apply(LifecycleCommand::activate);
  c.throw_in_execute = true;
  l.execute();
  EXPECT_EQ(l.state(), LifecycleState::error);
  c.throw_in_execute = false;
  c.hooks.clear();
  EXPECT_EQ(l.apply(LifecycleCommand::recover), ReturnCode::ok);  // Orocos recover()
  EXPECT_EQ(l.state(), LifecycleState::active);
  EXPECT_EQ(c.hooks, (Hooks{"reset", "activated"}));
}

TEST(Lifecycle, NamesOfAllThreeModelsAreAccepted) {
  EXPECT_EQ(parse_lifecycle_state("Running"), LifecycleState::active);
  EXPECT_EQ(parse_lifecycle_state("ACTIVE_STATE"), LifecycleState::active);
  EXPECT_EQ(parse_lifecycle_state("Stopped"), LifecycleState::inactive);
  EXPECT_EQ(parse_lifecycle_state("READY"), LifecycleState::inactive);
  EXPECT_EQ(parse_lifecycle_state("PreOperational"), LifecycleState::created);
  EXPECT_EQ(parse_lifecycle_state("RunTimeError"), LifecycleState::error);
  EXPECT_EQ(parse_lifecycle_state("sideways"), std::nullopt);
  EXPECT_EQ(parse_lifecycle_command("startHook"), LifecycleCommand::activate);
  EXPECT_EQ(parse_lifecycle_command("onStart"), LifecycleCommand::activate);
  EXPECT_EQ(parse_lifecycle_command("configureHook"), LifecycleCommand::initialize);
  EXPECT_EQ(parse_lifecycle_command("onStop"), LifecycleCommand::deactivate);
  EXPECT_EQ(parse_lifecycle_command("cleanupHook"), LifecycleCommand::finalize);
  EXPECT_EQ(parse_lifecycle_command("onDestroy"), LifecycleCommand::finalize);
  EXPECT_EQ(parse_lifecycle_command("onRecover"), LifecycleCommand::recover);
  EXPECT_EQ(parse_lifecycle_command("jump"), std::nullopt);
}

TEST(ExecutionContext, RunsHooksOnItsOwnThreadAtItsPeriod) {
  Recorder c;
  Lifecycle l(c);
  ExecutionContext ec(ExecutionSettings{"test-ec", Nanos{1'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt});
  ec.add(l);
  std::vector<std::string> warnings;
  ec.start(warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(ec.command(l, LifecycleCommand::initialize), ReturnCode::ok);
  EXPECT_EQ(ec.command(l, LifecycleCommand::activate), ReturnCode::ok);
  ASSERT_TRUE(eventually([&] { return l.executions() >= 20; }));
  EXPECT_NE(c.execute_thread, std::this_thread::get_id());
  EXPECT_EQ(ec.timer_slack_ns(), 1);  // its thread asked for the minimum slack

  EXPECT_EQ(ec.command(l, LifecycleCommand::deactivate), ReturnCode::ok);
  const std::uint64_t executions = l.executions();
  const std::uint64_t cycles = ec.cycles();
  ASSERT_TRUE(eventually([&] { return ec.cycles() >= cycles + 5; }));
  EXPECT_EQ(l.executions(), executions);  // inactive: the context ticks, the component does not run
  ec.stop();
  EXPECT_GE(ec.wake_jitter().summarize().count, 20u);
  EXPECT_EQ(l.state(), LifecycleState::inactive);
}

TEST(ExecutionContext, RefusedRealtimePriorityFallsBackWithAWarning) {
  Recorder c;
  Lifecycle l(c);
  // Priority 99 under SCHED_FIFO needs CAP_SYS_NICE; either it is granted (and applied) or
  // the context says why not and still runs.
  ExecutionContext ec(ExecutionSettings{"rt-ec", Nanos{1'000'000}, SchedPolicy::fifo, 99, 0, Nanos{0}, std::nullopt});
  ec.add(l);
  std::vector<std::string> warnings;
  ec.start(warnings);
  ec.command(l, LifecycleCommand::initialize);
  ec.command(l, LifecycleCommand::activate);
  ASSERT_TRUE(eventually([&] { return l.executions() >= 5; }));
  ec.stop();
  if (ec.realtime_applied()) {
    EXPECT_TRUE(warnings.empty() || !ec.pinned());
  } else {
    ASSERT_FALSE(warnings.empty());
    EXPECT_NE(warnings.front().find("real-time priority 99 refused"), std::string::npos) << warnings.front();
  }
}

TEST(ExecutionContext, SpinTailRunsAtItsPeriodTakesCommandsAndStops) {
  // A 1 ms spin tail in a 2 ms period, and one that spins the whole period: both still run
  // their component every cycle, apply commands and stop when asked.
  for (const Nanos spin : {Nanos{1'000'000}, Nanos{2'000'000}}) {
    SCOPED_TRACE(spin.count);
    Recorder c;
    Lifecycle l(c);
    ExecutionSettings settings{"spin-ec", Nanos{2'000'000}, SchedPolicy::other, 0, std::nullopt, spin, std::nullopt};
    ExecutionContext ec(settings);
    EXPECT_EQ(ec.settings().spin, spin);
    ec.add(l);
    std::vector<std::string> warnings;
    ec.start(warnings);
    EXPECT_EQ(ec.command(l, LifecycleCommand::initialize), ReturnCode::ok);
    EXPECT_EQ(ec.command(l, LifecycleCommand::activate), ReturnCode::ok);
    ASSERT_TRUE(eventually([&] { return l.executions() >= 20; }));
    EXPECT_NE(c.execute_thread, std::this_thread::get_id());
    EXPECT_EQ(ec.command(l, LifecycleCommand::deactivate), ReturnCode::ok);
    const std::uint64_t executions = l.executions();
    const std::uint64_t cycles = ec.cycles();
    ASSERT_TRUE(eventually([&] { return ec.cycles() >= cycles + 5; }));
    EXPECT_EQ(l.executions(), executions);
    ec.stop();
    EXPECT_FALSE(ec.running());
    EXPECT_GE(ec.wake_jitter().summarize().count, 20u);
    EXPECT_EQ(l.state(), LifecycleState::inactive);
  }
}

// A real-time context and an ordinary thread that gives it commands, on one CPU: once the
// context has run a command it must sleep, not wait on the CPU for the caller to collect the
// result (the caller cannot run while it spins: the kernel's real-time throttling would let it
// in only after 0.95 s of spinning per command).
TEST(ExecutionContext, ARealTimeContextSleepsWhileAnOrdinaryCallerCollectsItsCommandsResult) {
  if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "needs two CPUs: the test's own thread stays off CPU 0";
  Recorder c;
  Lifecycle l(c);
  ExecutionContext ec(ExecutionSettings{"rt-cmd", Nanos{100'000'000}, SchedPolicy::fifo, 30, 0, Nanos{0}, std::nullopt});
  ec.add(l);
  std::vector<std::string> warnings;
  ec.start(warnings);
  if (!ec.realtime_applied() || !ec.pinned()) {
    ec.stop();
    GTEST_SKIP() << "SCHED_FIFO on CPU 0 not permitted here (root or CAP_SYS_NICE needed): "
                 << (warnings.empty() ? "" : warnings.front());
  }
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  std::thread caller([&] {
    cpu_set_t cpu0;
    CPU_ZERO(&cpu0);
    CPU_SET(0, &cpu0);
    ASSERT_EQ(pthread_setaffinity_np(pthread_self(), sizeof cpu0, &cpu0), 0);
    EXPECT_EQ(ec.command(l, LifecycleCommand::initialize), ReturnCode::ok);
    EXPECT_EQ(ec.command(l, LifecycleCommand::activate), ReturnCode::ok);
    EXPECT_EQ(ec.command(l, LifecycleCommand::deactivate), ReturnCode::ok);
  });
  caller.join();
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  ec.stop();
  const auto cpu_us = [](const rusage& r) {
    return (r.ru_utime.tv_sec + r.ru_stime.tv_sec) * 1'000'000L + r.ru_utime.tv_usec + r.ru_stime.tv_usec;
  };
  EXPECT_EQ(l.state(), LifecycleState::inactive);
  // Three commands cost microseconds; a context spinning until each caller runs again burns
  // most of a second per command. A tenth of that separates the two.
  EXPECT_LT(cpu_us(after) - cpu_us(before), 95'000L) << "the context spun while its caller could not run";
}

TEST(ExecutionContext, SpinTailIsAtMostThePeriod) {
  ExecutionContext longer(ExecutionSettings{"a", Nanos{1'000'000}, SchedPolicy::other, 0, std::nullopt,
                                            Nanos{5'000'000}, std::nullopt});
  EXPECT_EQ(longer.settings().spin, Nanos{1'000'000});
  ExecutionContext negative(ExecutionSettings{"b", Nanos{1'000'000}, SchedPolicy::other, 0, std::nullopt,
                                              Nanos{-1}, std::nullopt});
  EXPECT_EQ(negative.settings().spin, Nanos{0});
}

TEST(ExecutionContextPool, ComponentsWithDifferentSpinTailsDoNotShare) {
  ExecutionContextPool pool;
  ExecutionSettings plain{"a", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt};
  ExecutionSettings spin{"b", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{200'000}, std::nullopt};
  ExecutionSettings more{"c", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{300'000}, std::nullopt};
  EXPECT_NE(&pool.shared(plain), &pool.shared(spin));
  EXPECT_NE(&pool.shared(spin), &pool.shared(more));
  EXPECT_EQ(&pool.shared(spin), &pool.shared(spin));
  EXPECT_EQ(pool.shared(spin).settings().spin, Nanos{200'000});
  EXPECT_EQ(pool.contexts().size(), 3u);
}

TEST(ExecutionContextPool, ComponentsWithDifferentPhasesDoNotShare) {
  ExecutionContextPool pool;
  ExecutionSettings free{"a", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt};
  ExecutionSettings zero{"b", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, Nanos{0}};
  ExecutionSettings three{"c", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, Nanos{3'000'000}};
  EXPECT_NE(&pool.shared(free), &pool.shared(zero));  // phase 0 is on the grid, free is not
  EXPECT_NE(&pool.shared(zero), &pool.shared(three));
  EXPECT_EQ(&pool.shared(three), &pool.shared(three));
  EXPECT_EQ(pool.shared(three).settings().phase, Nanos{3'000'000});
  EXPECT_EQ(pool.contexts().size(), 3u);
}

TEST(ExecutionContext, FirstOnGridIsTheNextInstantOfPeriodTimesKPlusPhase) {
  const Nanos period{10'000'000};
  EXPECT_EQ(first_on_grid(MonoTime{1'003'000'000}, period, Nanos{3'000'000}), MonoTime{1'003'000'000});  // on it
  EXPECT_EQ(first_on_grid(MonoTime{1'003'000'001}, period, Nanos{3'000'000}), MonoTime{1'013'000'000});
  EXPECT_EQ(first_on_grid(MonoTime{1'002'999'999}, period, Nanos{3'000'000}), MonoTime{1'003'000'000});
  EXPECT_EQ(first_on_grid(MonoTime{1'000'000'001}, period, Nanos{0}), MonoTime{1'010'000'000});
  EXPECT_EQ(first_on_grid(MonoTime{2'000'000}, period, Nanos{9'999'999}), MonoTime{9'999'999});  // before the first
  EXPECT_EQ(first_on_grid(MonoTime{0}, period, Nanos{0}), MonoTime{0});
}

// Stamps each onExecute with mono_now(), into room reserved up front.
class Stamper final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    const std::size_t i = count.load(std::memory_order_relaxed);
    if (i < stamps.size()) {
      stamps[i] = mono_now().ns;
      count.store(i + 1, std::memory_order_release);
    }
    return ReturnCode::ok;
  }
  std::array<std::int64_t, 64> stamps{};
  std::atomic<std::size_t> count{0};
};

TEST(ExecutionContext, APhaseRunsTheCyclesOnTheGridOfThePeriod) {
  // Two contexts started together, phases 0 and 25 ms in a 50 ms period. Each runs at
  // k * 50 ms + its phase, late only by its wake-up: half a period apart however they were
  // started. (Free contexts started together would run at the same offset.)
  constexpr Nanos period{50'000'000};
  const std::array<Nanos, 2> phases{Nanos{0}, Nanos{25'000'000}};
  std::array<Stamper, 2> components;
  std::vector<std::unique_ptr<Lifecycle>> lifecycles;
  std::vector<std::unique_ptr<ExecutionContext>> contexts;
  std::vector<std::string> warnings;
  for (std::size_t i = 0; i < phases.size(); ++i) {
    lifecycles.push_back(std::make_unique<Lifecycle>(components[i]));
    contexts.push_back(std::make_unique<ExecutionContext>(
        ExecutionSettings{"phase-" + std::to_string(i), period, SchedPolicy::other, 0, std::nullopt, Nanos{0}, phases[i]}));
    contexts[i]->add(*lifecycles[i]);
  }
  for (auto& context : contexts) context->start(warnings);
  for (std::size_t i = 0; i < phases.size(); ++i) {
    EXPECT_EQ(contexts[i]->command(*lifecycles[i], LifecycleCommand::initialize), ReturnCode::ok);
    EXPECT_EQ(contexts[i]->command(*lifecycles[i], LifecycleCommand::activate), ReturnCode::ok);
  }
  ASSERT_TRUE(eventually([&] { return components[0].count.load() >= 9 && components[1].count.load() >= 9; },
                         std::chrono::seconds(10)));
  for (auto& context : contexts) context->stop();
  for (std::size_t i = 0; i < phases.size(); ++i) {
    SCOPED_TRACE(i);
    std::vector<std::int64_t> offsets;  // how far past its grid instant each cycle ran
    for (std::size_t k = 0; k < components[i].count.load(std::memory_order_acquire); ++k) {
      offsets.push_back(((components[i].stamps[k] - phases[i].count) % period.count + period.count) % period.count);
    }
    std::sort(offsets.begin(), offsets.end());
    // A fifth of the period: a wake-up on a busy machine, far from the other phase's 25 ms.
    EXPECT_LT(offsets[offsets.size() / 2], period.count / 5) << "median offset from the grid, ns";
  }
}

TEST(ExecutionContextPool, SharesContextsByPeriodAndPriority) {
  ExecutionContextPool pool;
  ExecutionSettings ten{"a", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt};
  ExecutionSettings five{"b", Nanos{5'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt};
  EXPECT_EQ(&pool.shared(ten), &pool.shared(ten));
  EXPECT_NE(&pool.shared(ten), &pool.shared(five));
  EXPECT_NE(&pool.exclusive(ten), &pool.shared(ten));
  EXPECT_EQ(pool.contexts().size(), 3u);
}

// A running context's member list is fixed: a component added while the application runs
// (a reload) gets a context of its own.
TEST(ExecutionContextPool, ARunningContextIsNotShared) {
  ExecutionContextPool pool;
  ExecutionSettings ten{"a", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt};
  ExecutionContext& first = pool.shared(ten);
  std::vector<std::string> warnings;
  pool.start_all(warnings);
  ExecutionContext& second = pool.shared(ten);
  EXPECT_NE(&first, &second);
  EXPECT_FALSE(second.running());
  pool.start_all(warnings);  // starts the new one, leaves the running one
  EXPECT_TRUE(first.running() && second.running());
  pool.stop_all();
}

// VmLck of this process, in KiB.
long locked_kib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmLck:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

TEST(ExecutionContextPool, ARealTimeContextLocksMemoryWhereTheLimitsAllow) {
  {
    ExecutionContextPool plain;
    plain.exclusive(ExecutionSettings{"other", Nanos{10'000'000}, SchedPolicy::other, 0, std::nullopt, Nanos{0}, std::nullopt});
    std::vector<std::string> warnings;
    plain.start_all(warnings);
    EXPECT_FALSE(plain.memory_locked());
    EXPECT_FALSE(plain.memory_was_locked());
    EXPECT_EQ(locked_kib(), 0);
    EXPECT_TRUE(warnings.empty());
    plain.stop_all();
  }
  ExecutionContextPool pool;
  pool.exclusive(ExecutionSettings{"fifo", Nanos{10'000'000}, SchedPolicy::fifo, 10, std::nullopt, Nanos{0}, std::nullopt});
  std::vector<std::string> warnings;
  pool.start_all(warnings);
  std::string said;
  for (const std::string& w : warnings) said += w + "\n";
  if (pool.memory_locked()) {
    EXPECT_GT(locked_kib(), 0);
    EXPECT_EQ(said.find("memory not locked"), std::string::npos) << said;
  } else {
    // Not root and a finite limit, or mlockall refused: said once, and nothing locked.
    EXPECT_NE(said.find("memory not locked"), std::string::npos) << said;
    EXPECT_EQ(locked_kib(), 0);
  }
  const bool locked = pool.memory_locked();
  pool.stop_all();
  EXPECT_FALSE(pool.memory_locked());
  EXPECT_EQ(pool.memory_was_locked(), locked) << "the run's final statistics still say it was locked";
  EXPECT_EQ(locked_kib(), 0) << "stop_all unlocks";
}

}  // namespace
}  // namespace polyport
