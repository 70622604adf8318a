// A DDS model (cyclonedds, fastdds): a component profile with <model>NAME</model> is a DDS
// application whose data ports are topics and whose service ports are request/reply topic
// pairs. One Domain (participant) per domain id is shared by every proxy of the model (the
// interceptors hold it; it goes when the last of them does). The vendor supplies only the
// factory that makes a Domain from a domain id and its configuration file.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "dds_endpoint.hpp"
#include "dds_settings.hpp"
#include "polyport/runtime/model.hpp"

namespace polyport::dds {

class DdsModel final : public Model {
 public:
  // config: the vendor's configuration file, or "" for the SDK's own defaults.
  using DomainFactory =
      std::function<Result<std::unique_ptr<Domain>>(std::uint32_t domain_id, const std::string& config)>;

  // `default_config`: used when a profile names none (the shipped loopback configuration).
  DdsModel(std::string name, DomainFactory factory, std::string default_config)
      : name_(std::move(name)), factory_(std::move(factory)), default_config_(std::move(default_config)) {}

  std::string_view name() const noexcept override { return name_; }
  const ModelSection* profile_section() const noexcept override { return &section_; }
  std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                    Diagnostics& diagnostics) override;
  const std::string& default_config() const noexcept { return default_config_; }
  // How the vendor's configuration says the scheduling of its receive and delivery threads
  // (<dds><receive_thread>): the configuration as the factory takes it, with that added. None:
  // the vendor cannot (the reader warned already).
  using ThreadConfig = std::function<std::string(const std::string& config, const ThreadScheduling& scheduling)>;
  void set_thread_config(ThreadConfig thread_config) { thread_config_ = std::move(thread_config); }

 private:
  struct DomainEntry {
    std::weak_ptr<Domain> domain;
    std::string config;
  };
  std::string name_;
  DomainFactory factory_;
  std::string default_config_;
  ThreadConfig thread_config_;
  DdsSection section_;
  std::map<std::uint32_t, DomainEntry> domains_;
};

}  // namespace polyport::dds
