// Shared by the config tests (test_model_config.cpp, test_estimator_settings.cpp,
// test_channel_settings.cpp, test_sensor_links.cpp): a model file with keys replaced, the error of
// a parse, the checks of a message's shape, a scratch folder.
#pragma once

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/sensor_links.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace ne = networked_estimation;

namespace config_test
{

inline const char* const kZhou = R"(name: zhou_example
period: 0.01
A:  [[0.9802, 0.0196], [0.0, 0.9802]]
B:  [[1, 0], [0, 1]]
Q:  [[1.9608, 0.0195], [0.0195, 1.9605]]
C:  [[1, -1]]
R:  [[1]]
x0: [1, 0]
P0: [[1, 0], [0, 1]]
uncertainty:
  - dA: [[0, 0.099], [0, 0]]
    range: 1.0
)";

inline const char* const kRemove = "<remove>";

/// A valid two-state model, one key per line (line numbers: name 1, period 2, A 3, B 4, Q 5,
/// C 6, R 7, x0 8, P0 9), with keys replaced, removed (value kRemove) or appended.
inline std::string modelYaml(const std::vector<std::pair<std::string, std::string>>& changes = {})
{
  std::vector<std::pair<std::string, std::string>> keys = {
      {"name", "m"},
      {"period", "0.01"},
      {"A", "[[1, 0.1], [0, 1]]"},
      {"B", "[[1, 0], [0, 1]]"},
      {"Q", "[[1, 0], [0, 1]]"},
      {"C", "[[1, 0]]"},
      {"R", "[[1]]"},
      {"x0", "[0, 0]"},
      {"P0", "[[1, 0], [0, 1]]"},
  };
  for (const auto& change : changes)
  {
    bool found = false;
    for (auto& kv : keys)
    {
      if (kv.first == change.first)
      {
        kv.second = change.second;
        found = true;
      }
    }
    if (!found)
    {
      keys.push_back(change);
    }
  }
  std::string out;
  for (const auto& kv : keys)
  {
    if (kv.second != kRemove)
    {
      out += kv.first + ": " + kv.second + "\n";
    }
  }
  return out;
}

/// The ConfigError message thrown by `f`, or "" (with a test failure) when nothing is thrown.
inline std::string errorOf(const std::function<void()>& f)
{
  try
  {
    f();
  }
  catch (const ne::ConfigError& e)
  {
    return e.what();
  }
  catch (const std::exception& e)
  {
    ADD_FAILURE() << "expected ConfigError, got another exception: " << e.what();
    return "";
  }
  ADD_FAILURE() << "expected ConfigError, nothing was thrown";
  return "";
}

inline std::string modelError(const std::string& yaml)
{
  return errorOf([&] { ne::parseModel(YAML::Load(yaml), "m.yaml"); });
}

inline std::string estimatorError(const std::string& yaml)
{
  return errorOf([&] { ne::parseEstimatorSettings(YAML::Load(yaml), "est.yaml"); });
}

inline std::string channelError(const std::string& yaml)
{
  return errorOf([&] { ne::parseChannelSettings(YAML::Load(yaml), "chan.yaml"); });
}

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << "message: " << (text)

/// Checks the message names the source, the key and the problem.
inline void expectMessage(const std::string& msg, const std::string& source, const std::string& key,
                          const std::string& problem)
{
  EXPECT_EQ(msg.rfind(source + ":", 0), 0u) << "message: " << msg;
  EXPECT_CONTAINS(msg, key + ": ");
  EXPECT_CONTAINS(msg, problem);
}

inline void expectModelError(const std::vector<std::pair<std::string, std::string>>& changes, const std::string& key,
                             const std::string& problem)
{
  expectMessage(modelError(modelYaml(changes)), "m.yaml", key, problem);
}

/// A scratch folder under the system temp directory, removed on destruction.
class TempDir
{
public:
  TempDir()
  {
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    path_ =
        std::filesystem::temp_directory_path() / ("test_config_" + std::to_string(stamp) + "_" +
                                                  std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir()
  {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string write(const std::string& name, const std::string& text) const
  {
    const std::filesystem::path file = path_ / name;
    std::ofstream out(file);
    out << text;
    return file.string();
  }
  const std::filesystem::path& path() const { return path_; }

private:
  std::filesystem::path path_;
};

}  // namespace config_test

using namespace config_test;  // NOLINT: the tests' own helpers
