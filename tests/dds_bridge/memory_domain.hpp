// An in-memory DDS domain for tests of the DDS interceptor's logic (service bridges,
// counters) without an SDK: a write is delivered at once, on the writer's thread, to every
// reader of the same topic and type. It complements the tests against Cyclone DDS and Fast
// DDS (tests/cyclonedds, tests/fastdds, tests/dds); it replaces none of them.
//
// Not real-time: delivery copies the reader list under a mutex (allocates). Readers may be
// created and deleted from the test thread only while no write is under way.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "dds_endpoint.hpp"

namespace polyport::test {

class MemoryDomain final : public dds::Domain {
 public:
  struct Subscription {
    std::string topic;
    std::string type_name;
    dds::ReceiveCallback callback;
    std::atomic<bool> alive{true};
    std::atomic<std::uint64_t> received{0};
  };

  std::string_view vendor() const noexcept override { return "memory"; }
  std::uint32_t id() const noexcept override { return 0; }

  Result<std::unique_ptr<dds::Writer>> create_writer(const dds::EndpointSpec& spec) override {
    remember(spec);
    return std::unique_ptr<dds::Writer>(std::make_unique<MemoryWriter>(*this, spec, next_guid()));
  }

  Result<std::unique_ptr<dds::Reader>> create_reader(const dds::EndpointSpec& spec,
                                                     dds::ReceiveCallback callback) override {
    remember(spec);
    auto subscription = std::make_shared<Subscription>();
    subscription->topic = spec.topic;
    subscription->type_name = spec.type_name;
    subscription->callback = std::move(callback);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      subscriptions_.push_back(subscription);
    }
    return std::unique_ptr<dds::Reader>(std::make_unique<MemoryReader>(*this, std::move(subscription)));
  }

  std::uint64_t writes() const noexcept { return writes_.load(); }
  // Every endpoint asked for, in order.
  std::vector<dds::EndpointSpec> specs() {
    std::lock_guard<std::mutex> lock(mutex_);
    return specs_;
  }

 private:
  class MemoryWriter final : public dds::Writer {
   public:
    MemoryWriter(MemoryDomain& domain, dds::EndpointSpec spec, dds::Guid guid)
        : domain_(domain), spec_(std::move(spec)), guid_(guid) {}
    Status write(const std::byte* cdr, std::uint32_t size) noexcept override {
      if (size < 4 || size > spec_.max_size) return Status::bad_size;
      domain_.deliver(spec_, cdr, size);
      return Status::ok;
    }
    std::int32_t matched_readers() const noexcept override { return domain_.count(spec_); }
    dds::Guid guid() const noexcept override { return guid_; }

   private:
    MemoryDomain& domain_;
    dds::EndpointSpec spec_;
    dds::Guid guid_;
  };

  class MemoryReader final : public dds::Reader {
   public:
    MemoryReader(MemoryDomain& domain, std::shared_ptr<Subscription> subscription)
        : domain_(domain), subscription_(std::move(subscription)) {}
    ~MemoryReader() override { domain_.remove(subscription_); }
    std::int32_t matched_writers() const noexcept override { return -1; }
    std::uint64_t received() const noexcept override { return subscription_->received.load(); }
    std::uint64_t refused() const noexcept override { return 0; }
    std::uint64_t loop_dropped() const noexcept override { return 0; }

   private:
    MemoryDomain& domain_;
    std::shared_ptr<Subscription> subscription_;
  };

  dds::Guid next_guid() {
    dds::Guid guid{};
    guid[0] = 0x70;
    guid[15] = static_cast<std::uint8_t>(++guids_);
    return guid;
  }

  void deliver(const dds::EndpointSpec& spec, const std::byte* cdr, std::uint32_t size) {
    writes_.fetch_add(1);
    std::vector<std::shared_ptr<Subscription>> targets;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& s : subscriptions_) {
        if (s->alive && s->topic == spec.topic && s->type_name == spec.type_name) targets.push_back(s);
      }
    }
    for (const auto& s : targets) {
      s->callback(cdr, size, mono_now());
      s->received.fetch_add(1);
    }
  }

  std::int32_t count(const dds::EndpointSpec& spec) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::int32_t n = 0;
    for (const auto& s : subscriptions_) n += s->alive && s->topic == spec.topic ? 1 : 0;
    return n;
  }

  void remove(const std::shared_ptr<Subscription>& subscription) {
    std::lock_guard<std::mutex> lock(mutex_);
    subscription->alive = false;
    std::erase(subscriptions_, subscription);
  }

  std::mutex mutex_;
  std::vector<std::shared_ptr<Subscription>> subscriptions_;
  std::atomic<std::uint64_t> writes_{0};
  std::vector<dds::EndpointSpec> specs_;  // guarded by mutex_

  void remember(const dds::EndpointSpec& spec) {
    std::lock_guard<std::mutex> lock(mutex_);
    specs_.push_back(spec);
  }
  std::uint8_t guids_ = 0;
};

}  // namespace polyport::test
