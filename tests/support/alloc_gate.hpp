// The DDS models' edges of polyport's part of the path, for malloc_counter.hpp: a
// CountingDomain wraps a vendor's Domain so that entering polyport's reader callback switches
// counting on and calling the SDK's write switches it off (and back on when the write
// returns). Include it in exactly one source file of a test binary.
#pragma once

#include <memory>

#include "dds_endpoint.hpp"
#include "dds_model.hpp"
#include "malloc_counter.hpp"

namespace polyport::test {

class CountingWriter final : public dds::Writer {
 public:
  explicit CountingWriter(std::unique_ptr<dds::Writer> inner) : inner_(std::move(inner)) {}
  Status write(const std::byte* cdr, std::uint32_t size) noexcept override {
    Scope sdk(false);
    return inner_->write(cdr, size);
  }
  std::int32_t matched_readers() const noexcept override { return inner_->matched_readers(); }
  dds::Guid guid() const noexcept override { return inner_->guid(); }

 private:
  std::unique_ptr<dds::Writer> inner_;
};

class CountingDomain final : public dds::Domain {
 public:
  explicit CountingDomain(std::unique_ptr<dds::Domain> inner) : inner_(std::move(inner)) {}
  std::string_view vendor() const noexcept override { return inner_->vendor(); }
  std::uint32_t id() const noexcept override { return inner_->id(); }
  Result<std::unique_ptr<dds::Writer>> create_writer(const dds::EndpointSpec& spec) override {
    auto writer = inner_->create_writer(spec);
    if (!writer) return writer.error();
    return std::unique_ptr<dds::Writer>(std::make_unique<CountingWriter>(std::move(writer).value()));
  }
  Result<std::unique_ptr<dds::Reader>> create_reader(const dds::EndpointSpec& spec,
                                                     dds::ReceiveCallback callback) override {
    return inner_->create_reader(spec, [callback = std::move(callback)](const std::byte* cdr, std::uint32_t size,
                                                                        MonoTime source) {
      Scope polyport(true);
      g_callbacks.fetch_add(1, std::memory_order_relaxed);
      callback(cdr, size, source);
    });
  }

 private:
  std::unique_ptr<dds::Domain> inner_;
};

// A DDS model whose domains (made by `make`) count polyport's allocations.
inline std::unique_ptr<dds::DdsModel> counting_model(std::string name, dds::DdsModel::DomainFactory make,
                                                     std::string default_config) {
  return std::make_unique<dds::DdsModel>(
      std::move(name),
      [make = std::move(make)](std::uint32_t domain, const std::string& config) -> Result<std::unique_ptr<dds::Domain>> {
        auto inner = make(domain, config);
        if (!inner) return inner.error();
        return std::unique_ptr<dds::Domain>(std::make_unique<CountingDomain>(std::move(inner).value()));
      },
      std::move(default_config));
}

}  // namespace polyport::test
