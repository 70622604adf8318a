#include "dds_interceptor.hpp"

#include <nlohmann/json.hpp>

#include "polyport/runtime/component_api.hpp"

namespace polyport::dds {

namespace {

// A service's request and reply topics, with the service's QoS. What the bridge's endpoints
// show in describe: the request writer its matched servers, the reply reader the servers'
// reply writers, the request reader its matched clients.
class ServiceTopics final : public RpcTransport {
 public:
  ServiceTopics(Domain& domain, const DdsAdaptor::Service& service) : domain_(domain), service_(service) {}

  Result<std::unique_ptr<RpcSender>> sender(const RpcLayout& layout) override {
    auto writer = domain_.create_writer(spec_of(layout));
    if (!writer) return make_error(writer.error().message);
    return std::unique_ptr<RpcSender>(std::make_unique<TopicSender>(std::move(writer).value(), layout.reply));
  }

  Result<std::unique_ptr<RpcReceiver>> receiver(const RpcLayout& layout, RpcReceive receive) override {
    auto reader = domain_.create_reader(
        spec_of(layout), [receive = std::move(receive)](const std::byte* cdr, std::uint32_t size, MonoTime) {
          receive(cdr, size);
        });
    if (!reader) return make_error(reader.error().message);
    return std::unique_ptr<RpcReceiver>(std::make_unique<TopicReceiver>(std::move(reader).value(), layout.reply));
  }

 private:
  class TopicSender final : public RpcSender {
   public:
    TopicSender(std::unique_ptr<Writer> writer, bool reply)
        : writer_(std::move(writer)), guid_(writer_->guid()), reply_(reply) {}
    Status send(const std::byte* wire, std::uint32_t size) noexcept override { return writer_->write(wire, size); }
    const std::uint8_t* caller() const noexcept override { return guid_.data(); }
    void describe(nlohmann::json& operation) const override {
      if (!reply_) operation["matched_servers"] = writer_->matched_readers();
    }

   private:
    std::unique_ptr<Writer> writer_;
    Guid guid_;
    bool reply_;
  };

  class TopicReceiver final : public RpcReceiver {
   public:
    TopicReceiver(std::unique_ptr<Reader> reader, bool reply) : reader_(std::move(reader)), reply_(reply) {}
    void describe(nlohmann::json& operation) const override {
      operation[reply_ ? "matched_reply_writers" : "matched_clients"] = reader_->matched_writers();
    }

   private:
    std::unique_ptr<Reader> reader_;
    bool reply_;
  };

  // Request and reply structs are bounded whenever the bridge accepts them (a service payload
  // has no unbounded member), so their endpoints may share memory too (EndpointSpec).
  EndpointSpec spec_of(const RpcLayout& layout) const {
    const bool bounded = layout.type != nullptr && DdsAdaptor::bounded(*layout.type, layout.max_size);
    return EndpointSpec{layout.address, layout.type_name, service_.qos, layout.max_size, bounded};
  }

  Domain& domain_;
  const DdsAdaptor::Service& service_;
};

}  // namespace

Status DdsInterceptor::TopicSink::on_sample(const std::byte* data, const SampleMeta& meta) noexcept {
  Writer* w = writer.load(std::memory_order_acquire);
  if (w == nullptr) return Status::not_active;
  return w->write(data, meta.size);
}

DdsInterceptor::DdsInterceptor(DdsAdaptor& adaptor, std::shared_ptr<Domain> domain, std::string config)
    : adaptor_(adaptor), domain_(std::move(domain)), config_(std::move(config)), closed_(adaptor.topics().size()) {
  for (const DdsAdaptor::Topic& topic : adaptor_.topics()) {
    if (topic.in != nullptr) {
      sinks_.push_back(std::make_unique<TopicSink>());
      topic.in->set_sink(sinks_.back().get());  // before wiring: the connection is push mode
    } else {
      sinks_.push_back(nullptr);
    }
  }
  for (const DdsAdaptor::Service& service : adaptor_.services()) {
    service_topics_.push_back(std::make_unique<ServiceTopics>(*domain_, service));
    if (service.provided != nullptr) {
      servers_.push_back(std::make_unique<ServiceServer>(service, adaptor_.max_calls_in_flight(),
                                                         adaptor_.call_timeout_ns(), "topic"));
    } else {
      clients_.push_back(std::make_unique<ServiceClient>(service, adaptor_.max_calls_in_flight(), "topic"));
    }
  }
}

DdsInterceptor::~DdsInterceptor() {
  stop();
  retired_.clear();
}

Result<void> DdsInterceptor::start() {
  if (active_) return {};
  const auto& topics = adaptor_.topics();
  readers_.resize(topics.size());
  writers_.resize(topics.size());
  auto fail = [this](const std::string& port, const std::string& message) {
    stop();
    return make_error(adaptor_.name() + "." + port + ": " + message);
  };
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const DdsAdaptor::Topic& topic = topics[i];
    const EndpointSpec spec{topic.topic, topic.type_name, topic.qos, topic.max_size, topic.bounded};
    if (topic.out != nullptr) {
      DataOutPort* port = topic.out;
      auto reader = domain_->create_reader(spec, [port](const std::byte* cdr, std::uint32_t size, MonoTime source) {
        (void)port->write(cdr, size, source);
      });
      if (!reader) return fail(port->name(), reader.error().message);
      readers_[i] = std::move(reader).value();
    } else {
      auto writer = domain_->create_writer(spec);
      if (!writer) return fail(topic.in->name(), writer.error().message);
      writers_[i] = std::move(writer).value();
      sinks_[i]->writer.store(writers_[i].get(), std::memory_order_release);
    }
  }
  std::size_t server = 0;
  std::size_t client = 0;
  for (std::size_t i = 0; i < adaptor_.services().size(); ++i) {
    RpcTransport& service_topics = *service_topics_[i];
    auto started = adaptor_.services()[i].provided != nullptr ? servers_[server++]->start(service_topics)
                                                              : clients_[client++]->start(service_topics);
    if (!started) return fail("service", started.error().message);
  }
  active_ = true;
  return {};
}

void DdsInterceptor::stop() noexcept {
  for (auto& client : clients_) client->stop();
  for (auto& server : servers_) server->stop();
  for (std::size_t i = 0; i < readers_.size(); ++i) {
    if (!readers_[i]) continue;
    closed_[i].received += readers_[i]->received();
    closed_[i].refused += readers_[i]->refused();
    closed_[i].loop_dropped += readers_[i]->loop_dropped();
    readers_[i].reset();
  }
  for (std::size_t i = 0; i < writers_.size(); ++i) {
    if (sinks_[i]) sinks_[i]->writer.store(nullptr, std::memory_order_release);
    if (writers_[i]) retired_.push_back(std::move(writers_[i]));
  }
  readers_.clear();
  writers_.clear();
  active_ = false;
}

ReturnCode DdsInterceptor::command(LifecycleCommand command) { return start_stop_command(*this, command); }

InterceptorStatus DdsInterceptor::status() const {
  // Samples the SDK refused are counted by the connections (dropped_sink_error).
  return InterceptorStatus{active_ ? "active" : "inactive", 0, 0};
}

void DdsInterceptor::describe(nlohmann::json& out) const {
  nlohmann::json topics = nlohmann::json::array();
  const auto& list = adaptor_.topics();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const DdsAdaptor::Topic& topic = list[i];
    nlohmann::json t{{"port", topic.out ? topic.out->name() : topic.in->name()},
                     {"topic", topic.topic},
                     {"type", topic.type_name},
                     {"polyport", topic.out ? "reads" : "writes"}};
    if (topic.out != nullptr) {
      const bool open = i < readers_.size() && readers_[i];
      // Matched writers only while the reader exists; the counts over every reader so far.
      if (open) t["matched_writers"] = readers_[i]->matched_writers();
      t["received"] = closed_[i].received + (open ? readers_[i]->received() : 0);
      t["refused"] = closed_[i].refused + (open ? readers_[i]->refused() : 0);
      // Written by polyport itself (another of its ports on this topic) and not forwarded.
      t["loop_dropped"] = closed_[i].loop_dropped + (open ? readers_[i]->loop_dropped() : 0);
    }
    if (i < writers_.size() && writers_[i]) t["matched_readers"] = writers_[i]->matched_readers();
    topics.push_back(std::move(t));
  }
  nlohmann::json services = nlohmann::json::array();
  for (const auto& server : servers_) {
    nlohmann::json s;
    server->describe(s);
    services.push_back(std::move(s));
  }
  for (const auto& client : clients_) {
    nlohmann::json s;
    client->describe(s);
    services.push_back(std::move(s));
  }
  out["dds"] = {{"vendor", domain_->vendor()},
                {"domain", domain_->id()},
                {"config", config_},
                {"topics", std::move(topics)},
                {"services", std::move(services)}};
}

}  // namespace polyport::dds
