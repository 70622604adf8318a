// The DDS service bridges (core's polyport/runtime/service_bridge.hpp over the DDS
// interceptor's topics) on an in-memory domain: the correlation header, replies kept apart by
// writer GUID and sequence number, the call timeout, the cap on calls in flight, errors
// carried back, malformed samples counted.
// A "DDS application" here is a reader and a writer on the request/reply topics, encoding
// with polyport's CDR codec; tests/dds runs the same against idlc / fastddsgen programs.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "../support/eventually.hpp"
#include "dds_adaptor.hpp"
#include "dds_interceptor.hpp"
#include "memory_domain.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/runtime/service.hpp"

namespace polyport {
namespace {

std::string text_of(const Diagnostics& diagnostics) {
  std::string out;
  for (const Diagnostic& d : diagnostics.all()) out += d.to_string() + "\n";
  return out;
}

using namespace std::chrono_literals;

// The flat layouts of calc.idl's structs (types.hpp's layout rules are C's).
struct Identity {
  std::uint8_t guid[16];
  std::uint64_t sequence;
};
struct AddArgs {
  double a, b;
};
struct AddResult {
  double sum;
};
struct AddRequest {
  Identity id;
  AddArgs request;
};
struct AddReply {
  Identity id;
  std::int32_t status;
  AddResult reply;
};

constexpr Nanos kLongWait{5'000'000'000};

class ServiceBridge : public ::testing::Test {
 public:  // the simulated DDS applications use the codecs and endpoints too
  void SetUp() override {
    ASSERT_TRUE(types.add_idl_file(POLYPORT_SOURCE_DIR "/config/types/polyport_rpc.idl", diagnostics));
    ASSERT_TRUE(types.add_idl_file(POLYPORT_TEST_DATA "/dds_bridge/calc.idl", diagnostics));
    request_codec = make_cdr_codec(*types.find("calc::Add_Request"), WireFormat::xcdr1).value();
    reply_codec = make_cdr_codec(*types.find("calc::Add_Reply"), WireFormat::xcdr1).value();
    ASSERT_EQ(types.find("calc::Add_Request")->size, sizeof(AddRequest));
    ASSERT_EQ(types.find("calc::Add_Reply")->size, sizeof(AddReply));
  }

  // A DDS component with one service port `calc` (operation add) in `direction`.
  void build(PortDirection direction, std::uint32_t max_in_flight = 16, std::int64_t timeout_ns = 1'000'000'000) {
    Subcomponent sub;
    sub.name = "app";
    sub.profile.model = "cyclonedds";
    auto settings = std::make_shared<dds::DdsSettings>();
    settings->max_calls_in_flight = max_in_flight;
    settings->call_timeout_ns = timeout_ns;
    PortSpec port;
    port.name = "calc";
    port.kind = PortKind::service;
    port.direction = direction;
    port.service_type = "calc::Calc";
    OperationSpec add;
    add.name = "add";
    add.request_type = "calc::AddArgs";
    add.reply_type = "calc::AddResult";
    settings->ports["calc"].operations["add"] = {"calc::Add_Request", "calc::Add_Reply"};
    sub.profile.model_settings = settings;
    port.operations.push_back(add);
    sub.profile.ports.push_back(port);
    adaptor = dds::DdsAdaptor::create(sub, types, diagnostics);
    ASSERT_TRUE(adaptor) << text_of(diagnostics);
    interceptor = std::make_unique<dds::DdsInterceptor>(*adaptor, domain, "memory");
  }

  dds::EndpointSpec endpoint(const char* topic, const char* type) const {
    return dds::EndpointSpec{topic, type, DdsQos{}, 1024};
  }

  std::vector<std::byte> encode_request(const AddRequest& request) const {
    std::vector<std::byte> wire(256);
    const CodecResult r = request_codec->encode(reinterpret_cast<const std::byte*>(&request), sizeof request,
                                                wire.data(), static_cast<std::uint32_t>(wire.size()));
    EXPECT_TRUE(r.ok());
    wire.resize(r.size);
    return wire;
  }

  std::vector<std::byte> encode_reply(const AddReply& reply) const {
    std::vector<std::byte> wire(256);
    const CodecResult r = reply_codec->encode(reinterpret_cast<const std::byte*>(&reply), sizeof reply, wire.data(),
                                              static_cast<std::uint32_t>(wire.size()));
    EXPECT_TRUE(r.ok());
    wire.resize(r.size);
    return wire;
  }

  nlohmann::json counters() const {
    nlohmann::json out;
    interceptor->describe(out);
    return out["dds"]["services"][0]["counters"];
  }

  Diagnostics diagnostics;
  TypeRegistry types;
  std::unique_ptr<Codec> request_codec;
  std::unique_ptr<Codec> reply_codec;
  std::shared_ptr<test::MemoryDomain> domain = std::make_shared<test::MemoryDomain>();
  std::unique_ptr<dds::DdsAdaptor> adaptor;
  std::unique_ptr<dds::DdsInterceptor> interceptor;
};

// ---- polyport calls a DDS server ----------------------------------------------------------

// A DDS application serving calc/add: answers each request with `status` and a + b, unless
// told to stay silent; `foreign_first` sends a reply for another client before each answer.
class DdsServer {
 public:
  DdsServer(ServiceBridge& test, dds::Domain& domain) : test_(test) {
    reply_writer_ = domain.create_writer(test.endpoint("calc/add/reply", "calc::Add_Reply")).value();
    request_reader_ = domain
                          .create_reader(test.endpoint("calc/add/request", "calc::Add_Request"),
                                         [this](const std::byte* cdr, std::uint32_t size, MonoTime) {
                                           on_request(cdr, size);
                                         })
                          .value();
  }
  std::atomic<bool> silent{false};
  std::atomic<bool> foreign_first{false};
  std::atomic<bool> malformed_first{false};
  std::atomic<std::int32_t> status{0};
  std::atomic<int> requests{0};
  Identity last{};

 private:
  void on_request(const std::byte* cdr, std::uint32_t size) {
    AddRequest request{};
    ASSERT_TRUE(test_.request_codec
                    ->decode(cdr, size, reinterpret_cast<std::byte*>(&request), sizeof request)
                    .ok());
    ++requests;
    last = request.id;
    if (silent) return;
    if (malformed_first) {
      const std::byte junk[4] = {std::byte{0}, std::byte{1}, std::byte{0}, std::byte{0}};  // header only
      ASSERT_EQ(reply_writer_->write(junk, sizeof junk), Status::ok);
    }
    AddReply reply{};
    reply.id = request.id;
    if (foreign_first) {
      AddReply other = reply;
      other.id.guid[0] ^= 0xff;  // another client's request, same sequence number
      other.reply.sum = -1.0;
      const auto wire = test_.encode_reply(other);
      ASSERT_EQ(reply_writer_->write(wire.data(), static_cast<std::uint32_t>(wire.size())), Status::ok);
    }
    reply.status = status;
    reply.reply.sum = request.request.a + request.request.b;
    const auto wire = test_.encode_reply(reply);
    ASSERT_EQ(reply_writer_->write(wire.data(), static_cast<std::uint32_t>(wire.size())), Status::ok);
  }

  ServiceBridge& test_;
  std::unique_ptr<dds::Writer> reply_writer_;
  std::unique_ptr<dds::Reader> request_reader_;
};

// The in-process caller.
class Caller : public Component {
 public:
  explicit Caller(ProvidedServicePort& provider)
      : Component("caller", "inproc"),
        port(add_port<RequiredServicePort>("calc", "calc::Calc", provider.operations(), 8)) {
    EXPECT_TRUE(port.connect(provider));
  }
  RequiredServicePort& port;
};

// A service's request and reply structs are bounded (the bridge refuses unbounded payloads),
// so their endpoints are marked bounded: Fast DDS may share their samples in memory.
TEST_F(ServiceBridge, RequestAndReplyEndpointsAreBounded) {
  build(PortDirection::provided);
  ASSERT_TRUE(interceptor->start());
  const std::vector<dds::EndpointSpec> specs = domain->specs();
  ASSERT_EQ(specs.size(), 2u);  // the request reader, the reply writer
  for (const dds::EndpointSpec& spec : specs) {
    EXPECT_TRUE(spec.bounded) << spec.topic;
    EXPECT_GT(spec.max_size, 4u) << spec.topic;
  }
}

TEST_F(ServiceBridge, InProcessCallerGetsTheDdsServersReply) {
  build(PortDirection::provided);
  DdsServer server(*this, *domain);
  ASSERT_TRUE(interceptor->start());
  Caller caller(*adaptor->services()[0].provided);

  for (int i = 0; i < 3; ++i) {
    const AddArgs args{1.5 * i, 2.25};
    AddResult result{};
    std::uint32_t size = 0;
    ASSERT_EQ(caller.port.query("add", &args, sizeof args, &result, sizeof result, kLongWait, &size), Status::ok);
    EXPECT_EQ(size, sizeof result);
    EXPECT_DOUBLE_EQ(result.sum, 1.5 * i + 2.25);
  }
  // The request carried the GUID of polyport's request writer and distinct sequence numbers.
  EXPECT_EQ(server.requests.load(), 3);
  EXPECT_EQ(server.last.guid[0], 0x70);
  EXPECT_EQ(counters()["replies"], 3);
  EXPECT_EQ(counters()["errors"], 0);
}

TEST_F(ServiceBridge, RepliesToOtherClientsAndMalformedRepliesAreSetAside) {
  build(PortDirection::provided);
  DdsServer server(*this, *domain);
  server.foreign_first = true;
  server.malformed_first = true;
  ASSERT_TRUE(interceptor->start());
  Caller caller(*adaptor->services()[0].provided);

  const AddArgs args{2.0, 3.0};
  AddResult result{};
  ASSERT_EQ(caller.port.query("add", &args, sizeof args, &result, sizeof result, kLongWait), Status::ok);
  EXPECT_DOUBLE_EQ(result.sum, 5.0);  // not the foreign reply's -1
  EXPECT_EQ(counters()["unmatched"], 1);
  EXPECT_EQ(counters()["malformed"], 1);
}

TEST_F(ServiceBridge, ServersErrorStatusReachesTheCaller) {
  build(PortDirection::provided);
  DdsServer server(*this, *domain);
  server.status = static_cast<std::int32_t>(Status::error);
  ASSERT_TRUE(interceptor->start());
  Caller caller(*adaptor->services()[0].provided);
  const AddArgs args{1.0, 1.0};
  AddResult result{};
  EXPECT_EQ(caller.port.query("add", &args, sizeof args, &result, sizeof result, kLongWait), Status::error);
  server.status = 4242;  // not a status polyport knows: an error too
  EXPECT_EQ(caller.port.query("add", &args, sizeof args, &result, sizeof result, kLongWait), Status::error);
}

TEST_F(ServiceBridge, SilentServerTimesOutAndTheNextCallWorks) {
  build(PortDirection::provided, 16, 50'000'000);  // 50 ms call timeout
  DdsServer server(*this, *domain);
  server.silent = true;
  ASSERT_TRUE(interceptor->start());
  Caller caller(*adaptor->services()[0].provided);

  const AddArgs args{1.0, 2.0};
  AddResult result{};
  // The caller would wait 5 s; the bridge's call timeout ends the call first.
  EXPECT_EQ(caller.port.query("add", &args, sizeof args, &result, sizeof result, kLongWait), Status::timeout);
  EXPECT_EQ(counters()["timeouts"], 1);
  server.silent = false;
  EXPECT_EQ(caller.port.query("add", &args, sizeof args, &result, sizeof result, kLongWait), Status::ok);
  EXPECT_DOUBLE_EQ(result.sum, 3.0);
}

TEST_F(ServiceBridge, CallsBeyondTheCapAreRefusedWithTooManyCalls) {
  build(PortDirection::provided, 2, 10'000'000'000);
  DdsServer server(*this, *domain);
  server.silent = true;
  ASSERT_TRUE(interceptor->start());
  Caller caller(*adaptor->services()[0].provided);

  const AddArgs args{1.0, 2.0};
  CallHandle first = caller.port.request("add", &args, sizeof args);
  CallHandle second = caller.port.request("add", &args, sizeof args);
  ASSERT_TRUE(first);
  ASSERT_TRUE(second);
  CallHandle third = caller.port.request("add", &args, sizeof args);
  AddResult result{};
  EXPECT_EQ(caller.port.receive(third, &result, sizeof result, kLongWait), Status::too_many_calls);
  EXPECT_EQ(counters()["refused"], 1);
  // Stopping completes the calls in flight with not_active.
  interceptor->stop();
  EXPECT_EQ(caller.port.receive(first, &result, sizeof result, kLongWait), Status::not_active);
  EXPECT_EQ(caller.port.receive(second, &result, sizeof result, kLongWait), Status::not_active);
}

// ---- a DDS client calls an in-process provider --------------------------------------------

// A DDS application calling calc/add: writes requests, keeps every reply it sees.
class DdsClient {
 public:
  DdsClient(ServiceBridge& test, dds::Domain& domain) : test_(test) {
    request_writer_ = domain.create_writer(test.endpoint("calc/add/request", "calc::Add_Request")).value();
    reply_reader_ = domain
                        .create_reader(test.endpoint("calc/add/reply", "calc::Add_Reply"),
                                       [this](const std::byte* cdr, std::uint32_t size, MonoTime) {
                                         AddReply reply{};
                                         ASSERT_TRUE(test_.reply_codec
                                                         ->decode(cdr, size, reinterpret_cast<std::byte*>(&reply),
                                                                  sizeof reply)
                                                         .ok());
                                         std::lock_guard<std::mutex> lock(mutex_);
                                         replies_.push_back(reply);
                                       })
                        .value();
  }

  void call(std::uint64_t sequence, double a, double b) {
    AddRequest request{};
    std::memset(request.id.guid, 0xc1, sizeof request.id.guid);
    request.id.sequence = sequence;
    request.request = {a, b};
    const auto wire = test_.encode_request(request);
    ASSERT_EQ(request_writer_->write(wire.data(), static_cast<std::uint32_t>(wire.size())), Status::ok);
  }
  void write_raw(const std::byte* bytes, std::uint32_t size) { ASSERT_EQ(request_writer_->write(bytes, size), Status::ok); }

  std::vector<AddReply> replies() {
    std::lock_guard<std::mutex> lock(mutex_);
    return replies_;
  }

 private:
  ServiceBridge& test_;
  std::unique_ptr<dds::Writer> request_writer_;
  std::unique_ptr<dds::Reader> reply_reader_;
  std::mutex mutex_;
  std::vector<AddReply> replies_;
};

// The in-process provider of calc/add.
class Provider : public Component {
 public:
  Provider(const std::vector<OperationInfo>& operations, ProvidedServicePort::Dispatch dispatch)
      : Component("provider", "inproc"), port(add_port<ProvidedServicePort>("calc", "calc::Calc", operations)) {
    port.set_handler(
        0,
        [](const std::byte* request, std::uint32_t, std::byte* reply, std::uint32_t& reply_size) {
          AddArgs args{};
          std::memcpy(&args, request, sizeof args);
          const AddResult result{args.a + args.b};
          std::memcpy(reply, &result, sizeof result);
          reply_size = sizeof result;
          return Status::ok;
        },
        dispatch);
    port.set_accepting(true);
  }
  ProvidedServicePort& port;
};

// The DDS application calls; polyport forwards to an in-process provider with `dispatch`.
class ServiceBridgeClient : public ServiceBridge {
 protected:
  void start(ProvidedServicePort::Dispatch dispatch) {
    build(PortDirection::required);
    RequiredServicePort& required = *adaptor->services()[0].required;
    provider = std::make_unique<Provider>(required.operations(), dispatch);
    ASSERT_TRUE(required.connect(provider->port));
    ASSERT_TRUE(interceptor->start());
    dds_client = std::make_unique<DdsClient>(*this, *domain);
  }
  std::unique_ptr<Provider> provider;
  std::unique_ptr<DdsClient> dds_client;
};

TEST_F(ServiceBridgeClient, DdsClientGetsTheInProcessProvidersReplyWithItsIdentity) {
  start(ProvidedServicePort::Dispatch::caller_thread);
  DdsClient& client = *dds_client;

  client.call(7, 1.25, 2.5);
  client.call(8, -4.0, 1.0);
  ASSERT_TRUE(test::eventually([&] { return client.replies().size() == 2; }));
  const auto replies = client.replies();
  EXPECT_EQ(replies[0].id.sequence, 7u);
  EXPECT_EQ(replies[0].id.guid[0], 0xc1);
  EXPECT_EQ(replies[0].status, 0);
  EXPECT_DOUBLE_EQ(replies[0].reply.sum, 3.75);
  EXPECT_EQ(replies[1].id.sequence, 8u);
  EXPECT_DOUBLE_EQ(replies[1].reply.sum, -3.0);
}

TEST_F(ServiceBridgeClient, ProviderOnItsOwnThreadRepliesLater) {
  start(ProvidedServicePort::Dispatch::own_thread);
  DdsClient& client = *dds_client;
  RequiredServicePort& required = *adaptor->services()[0].required;

  client.call(1, 10.0, 5.0);
  EXPECT_TRUE(client.replies().empty());  // queued until the provider's thread serves it
  std::thread serving([&] { provider->port.serve_queued(); });
  serving.join();
  ASSERT_TRUE(test::eventually([&] { return client.replies().size() == 1; }));
  EXPECT_DOUBLE_EQ(client.replies()[0].reply.sum, 15.0);
  EXPECT_EQ(required.counters().ok.load(), 1u);
}

TEST_F(ServiceBridge, DdsClientHearsWhyACallFailed) {
  build(PortDirection::required, 2);
  RequiredServicePort& required = *adaptor->services()[0].required;
  ASSERT_TRUE(interceptor->start());
  DdsClient client(*this, *domain);

  client.call(1, 1.0, 1.0);  // nothing connected yet
  ASSERT_TRUE(test::eventually([&] { return client.replies().size() == 1; }));
  EXPECT_EQ(client.replies()[0].status, static_cast<std::int32_t>(Status::not_connected));

  // A provider that queues and never serves: two calls fill the cap, the third is refused.
  Provider provider(required.operations(), ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required.connect(provider.port));
  client.call(2, 1.0, 1.0);
  client.call(3, 1.0, 1.0);
  client.call(4, 1.0, 1.0);
  ASSERT_TRUE(test::eventually([&] { return client.replies().size() == 2; }));
  EXPECT_EQ(client.replies()[1].id.sequence, 4u);
  EXPECT_EQ(client.replies()[1].status, static_cast<std::int32_t>(Status::too_many_calls));
  // The provider stops: the queued calls end with not_active, and the client hears it.
  provider.port.set_accepting(false);
  provider.port.cancel_queued(Status::not_active);
  ASSERT_TRUE(test::eventually([&] { return client.replies().size() == 4; }));
  EXPECT_EQ(client.replies()[2].status, static_cast<std::int32_t>(Status::not_active));
  EXPECT_EQ(client.replies()[3].status, static_cast<std::int32_t>(Status::not_active));
}

TEST_F(ServiceBridgeClient, MalformedRequestIsCountedAndDropped) {
  start(ProvidedServicePort::Dispatch::caller_thread);
  DdsClient& client = *dds_client;

  const std::byte truncated[8] = {std::byte{0}, std::byte{1}, std::byte{0}, std::byte{0}, std::byte{1}};
  client.write_raw(truncated, sizeof truncated);
  client.call(9, 2.0, 2.0);
  ASSERT_TRUE(test::eventually([&] { return client.replies().size() == 1; }));
  EXPECT_EQ(client.replies()[0].id.sequence, 9u);
  EXPECT_EQ(counters()["malformed"], 1);
  EXPECT_EQ(counters()["calls"], 1);
}

// ---- the adaptor checks the request / reply structs ---------------------------------------

TEST_F(ServiceBridge, WrongRequestStructIsReportedAtTheOperation) {
  Subcomponent sub;
  sub.name = "app";
  sub.profile.model = "fastdds";
  PortSpec port;
  port.name = "calc";
  port.kind = PortKind::service;
  port.direction = PortDirection::provided;
  OperationSpec add;
  add.name = "add";
  add.request_type = "calc::AddArgs";
  add.reply_type = "calc::AddResult";
  auto settings = std::make_shared<dds::DdsSettings>();
  settings->ports["calc"].operations["add"] = {"calc::AddArgs",       // no header
                                               "calc::Add_Request"};  // a request header, not a reply header
  sub.profile.model_settings = settings;
  add.where = SourceLocation{"app.xml", 12, 7};
  port.operations.push_back(add);
  sub.profile.ports.push_back(port);
  EXPECT_FALSE(dds::DdsAdaptor::create(sub, types, diagnostics));
  const std::string text = text_of(diagnostics);
  EXPECT_NE(text.find("app.xml:12:7"), std::string::npos) << text;
  EXPECT_NE(text.find("operation 'add' of port 'calc': dds_request 'calc::AddArgs' must start with a "
                      "polyport::rpc::RequestHeader"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("dds_reply 'calc::Add_Request' must start with a polyport::rpc::ReplyHeader"),
            std::string::npos)
      << text;
}

// Data ports: a type without unbounded members is marked bounded (its largest encoding is
// the topic's max_size, which lets Fast DDS share its samples in memory, raw_type.hpp); one
// with an unbounded string is not.
TEST_F(ServiceBridge, DataTopicsOfBoundedTypesAreMarkedBounded) {
  Subcomponent sub;
  sub.name = "app";
  sub.profile.model = "fastdds";
  sub.profile.model_settings = std::make_shared<dds::DdsSettings>();
  for (const char* type : {"calc::Pose", "calc::Note"}) {
    PortSpec port;
    port.name = type + 6;  // "Pose", "Note"
    port.kind = PortKind::data;
    port.direction = PortDirection::output;
    port.data_type = type;
    sub.profile.ports.push_back(port);
  }
  auto made = dds::DdsAdaptor::create(sub, types, diagnostics);
  ASSERT_TRUE(made) << text_of(diagnostics);
  ASSERT_EQ(made->topics().size(), 2u);
  EXPECT_TRUE(made->topics()[0].bounded);
  // id, x, string<16> frame: 4 + 4 (align) + 8 + 4 + 17, after the 4-byte header.
  EXPECT_GE(made->topics()[0].max_size, 41u);
  EXPECT_LT(made->topics()[0].max_size, 64u);
  EXPECT_FALSE(made->topics()[1].bounded);
}

}  // namespace
}  // namespace polyport
