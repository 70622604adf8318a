// An Engine built from a test profile with the models a test names; problems() lists
// every diagnostic for assertion messages.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "polyport/runtime/engine.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/types/types.hpp"

namespace polyport::test {

class EngineFixture : public ::testing::Test {
 protected:
  EngineFixture(std::string data_dir, LoadOptions options) : data_dir_(std::move(data_dir)), options_(std::move(options)) {}

  bool build(const std::string& file) {
    options_.models = &models;
    auto profile = load_application_profile(data_dir_ + "/" + file, types, options_, diagnostics);
    return profile && engine.build(*profile, diagnostics);
  }
  std::string problems() const {
    std::string out;
    for (const auto& d : diagnostics.all()) out += d.to_string() + "\n";
    return out;
  }

  TypeRegistry types;
  ModelRegistry models;
  Diagnostics diagnostics;
  Engine engine{models, types};

 private:
  std::string data_dir_;
  LoadOptions options_;
};

}  // namespace polyport::test
