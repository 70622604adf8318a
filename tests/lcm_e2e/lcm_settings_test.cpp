// The LCM model's service settings (adaptors/lcm): what a profile's <lcm>, <channel> and
// operation attributes give, the default request / reply channels, and every problem with the
// exact diagnostic at its place — those the loader reports while reading the profile, and
// those the adaptor reports when it checks the request / reply structs against
// config/types/polyport_rpc.lcm. No network: nothing is opened.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "lcm_adaptor.hpp"
#include "lcm_model.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/types/types.hpp"

namespace polyport::lcm {
namespace {

namespace fs = std::filesystem;

fs::path data_dir() { return fs::weakly_canonical(fs::path(POLYPORT_TEST_DATA) / "lcm_services"); }

class LcmServiceSettings : public ::testing::Test {
 protected:
  LcmServiceSettings() {
    models_.add(std::make_unique<LcmModel>());
    options_.models = &models_;
  }

  std::optional<ApplicationProfile> load(const std::string& app) {
    return load_application_profile(data_dir() / app, types_, options_, diagnostics_);
  }

  // Every diagnostic as the user reads it, with the data folder cut out of file names.
  std::vector<std::string> messages() const {
    const std::string prefix = data_dir().string() + "/";
    std::vector<std::string> out;
    for (const Diagnostic& item : diagnostics_.all()) {
      std::string text = item.to_string();
      for (auto at = text.find(prefix); at != std::string::npos; at = text.find(prefix, at)) {
        text.erase(at, prefix.size());
      }
      out.push_back(std::move(text));
    }
    return out;
  }

  TypeRegistry types_;
  Diagnostics diagnostics_;
  ModelRegistry models_;
  LoadOptions options_;
};

TEST_F(LcmServiceSettings, ReadsTheLimitsAndDerivesTheChannels) {
  const auto app = load("good_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  const std::shared_ptr<const LcmSettings> settings = lcm_settings(app->components[0].profile);
  EXPECT_EQ(settings->max_calls_in_flight, 3u);
  EXPECT_EQ(settings->call_timeout_ns, 40'000'000);

  const auto adaptor = LcmAdaptor::create(app->components[0], types_, diagnostics_);
  ASSERT_NE(adaptor, nullptr) << ::testing::PrintToString(messages());
  EXPECT_TRUE(messages().empty()) << ::testing::PrintToString(messages());
  ASSERT_EQ(adaptor->services().size(), 2u);
  const RpcService& provided = adaptor->services()[0];
  ASSERT_NE(provided.provided, nullptr);
  ASSERT_EQ(provided.operations.size(), 2u);
  const RpcOperation& add = provided.operations[0];
  EXPECT_EQ(add.request.address, "calc/add/request");  // <port name>/<operation>/request
  EXPECT_EQ(add.reply.address, "calc/add/reply");
  EXPECT_EQ(add.request.type_name, "svc.request_t");
  EXPECT_EQ(add.reply.type_name, "svc.reply_t");
  // The header's fields where the flat struct has them: client id, sequence, status.
  EXPECT_EQ(add.request.caller_offset, 0u);
  EXPECT_EQ(add.request.caller_size, 8u);
  EXPECT_EQ(add.request.sequence_offset, 8u);
  EXPECT_EQ(add.request.body_offset, 16u);
  EXPECT_EQ(add.request.body_size, 16u);
  EXPECT_EQ(add.reply.status_offset, 16u);
  EXPECT_EQ(add.reply.body_size, 8u);
  const RpcOperation& ping = provided.operations[1];
  EXPECT_TRUE(ping.oneway);
  EXPECT_EQ(ping.request.address, "PING");
  EXPECT_EQ(ping.request.body_size, 0u);
  EXPECT_EQ(ping.reply.type, nullptr);

  const RpcService& required = adaptor->services()[1];
  ASSERT_NE(required.required, nullptr);
  EXPECT_EQ(required.required->max_in_flight(), 3u);
  EXPECT_EQ(required.operations[0].request.address, "CALC/add/request");  // <channel>/<operation>/request
  EXPECT_EQ(required.operations[0].reply.address, "CALC_REPLY");
}

TEST_F(LcmServiceSettings, SettingErrorsAtTheirPlaces) {
  EXPECT_FALSE(load("bad_settings_app.xml").has_value());
  const std::vector<std::string> expected = {
      "BadSettings.xml:5:29: /component_profile/lcm/max_calls_in_flight: bad max_calls_in_flight '0': expected an "
      "integer from 1 to 4096",
      "BadSettings.xml:5:69: /component_profile/lcm/call_timeout_ms: call_timeout_ms must be greater than 0",
      "BadSettings.xml:8:7: /component_profile/ports/service_port/operation[1]: missing attribute 'lcm_request': the "
      "struct an LCM application publishes on the request channel (a polyport.rpc_request_header_t, then the request)",
      "BadSettings.xml:8:7: /component_profile/ports/service_port/operation[1]: missing attribute 'lcm_reply': the "
      "struct an LCM application publishes on the reply channel (a polyport.rpc_reply_header_t, then the reply)",
      "BadSettings.xml:9:106: /component_profile/ports/service_port/operation[2]/@lcm_reply: a oneway operation has "
      "no reply",
      "BadSettings.xml:9:139: /component_profile/ports/service_port/operation[2]/@lcm_reply_channel: a oneway "
      "operation has no reply",
      "BadSettings.xml:10:147: /component_profile/ports/service_port/operation[3]/@lcm_request_channel: channel 'A B' "
      "has a blank or control character",
  };
  EXPECT_EQ(messages(), expected);
}

TEST_F(LcmServiceSettings, StructErrorsWhenTheModelBuildsTheComponent) {
  const auto app = load("bad_shapes_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(LcmAdaptor::create(app->components[0], types_, diagnostics_), nullptr);
  const std::vector<std::string> expected = {
      "BadShapes.xml:7:7: operation 'headless' of port 'svc': lcm_request 'svc::headless_t' must start with a "
      "polyport::rpc_request_header_t (config/types/polyport_rpc.lcm); expected { polyport::rpc_request_header_t "
      "header; svc::args_t <member>; }",
      "BadShapes.xml:8:7: operation 'swapped' of port 'svc': lcm_reply 'svc::reply_with_request_header_t' must start "
      "with a polyport::rpc_reply_header_t (config/types/polyport_rpc.lcm); expected { "
      "polyport::rpc_reply_header_t header; svc::result_t <member>; }",
      "BadShapes.xml:9:7: operation 'text' of port 'svc': lcm_request 'svc::text_request_t' carries 'svc::text_t', "
      "which has an unbounded string or sequence; service payloads must be bounded",
      "BadShapes.xml:10:7: operation 'wrong_payload' of port 'svc': lcm_request 'svc::request_t' must be { "
      "polyport::rpc_request_header_t header; svc::result_t <member>; } (its second member is a 'svc::args_t')",
      "BadShapes.xml:11:7: operation 'an_operation_whose_name_makes_the_default_channel_too_long' of port 'svc': "
      "request channel 'svc/an_operation_whose_name_makes_the_default_channel_too_long/request' is longer than "
      "LCM's 63 characters (name it with lcm_request_channel)",
      "BadShapes.xml:11:7: operation 'an_operation_whose_name_makes_the_default_channel_too_long' of port 'svc': "
      "reply channel 'svc/an_operation_whose_name_makes_the_default_channel_too_long/reply' is longer than LCM's 63 "
      "characters (name it with lcm_reply_channel)",
  };
  EXPECT_EQ(messages(), expected);
}

TEST_F(LcmServiceSettings, ReadsTheReceiveThreadsScheduling) {
  const auto app = load("thread_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  const std::shared_ptr<const LcmSettings> settings = lcm_settings(app->components[0].profile);
  ASSERT_TRUE(settings->receive_thread);
  EXPECT_EQ(settings->receive_thread->policy, SchedPolicy::fifo);
  EXPECT_EQ(settings->receive_thread->priority, 40);
  EXPECT_EQ(settings->receive_thread->cpu, 0);
  EXPECT_EQ(to_string(*settings->receive_thread), "SCHED_FIFO 40 on CPU 0");
}

TEST_F(LcmServiceSettings, RefusesABadReceiveThreadAtItsPlace) {
  EXPECT_FALSE(load("bad_thread_app.xml").has_value());
  const std::vector<std::string> expected{
      "BadThread.xml:5:68: /component_profile/lcm/receive_thread/@nice: warning: unknown attribute 'nice'",
      "BadThread.xml:5:54: /component_profile/lcm/receive_thread/@priority: priority 0 is out of range for SCHED_FIFO (1 to 99)",
      "BadThread.xml:5:62: /component_profile/lcm/receive_thread/@cpu: bad cpu '4096': expected an integer from 0 to 1023",
      "NoPriority.xml:5:8: /component_profile/lcm/receive_thread: SCHED_RR needs a priority from 1 to 99",
  };
  EXPECT_EQ(messages(), expected);
}

TEST(ThreadScheduling, TheStrongerRequestWins) {
  const ThreadScheduling other{SchedPolicy::other, 0, 1};
  const ThreadScheduling fifo40{SchedPolicy::fifo, 40, std::nullopt};
  const ThreadScheduling rr60{SchedPolicy::rr, 60, 0};
  EXPECT_EQ(stronger(other, fifo40), (ThreadScheduling{SchedPolicy::fifo, 40, 1})) << "real time wins, the CPU is kept";
  EXPECT_EQ(stronger(fifo40, other), (ThreadScheduling{SchedPolicy::fifo, 40, 1}));
  EXPECT_EQ(stronger(fifo40, rr60), rr60);
  EXPECT_EQ(stronger(rr60, fifo40), rr60);
  EXPECT_EQ(to_string(other), "SCHED_OTHER on CPU 1");
}

}  // namespace
}  // namespace polyport::lcm
