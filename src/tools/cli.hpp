// Command-line handling shared by the tools: `--key value` (or `--key=value`) options, required
// and optional ones, repeatable ones, value-less switches, `--help`; unknown flags are rejected.
// runTool() maps the package's errors to exit codes:
//   0 success, 2 bad arguments or bad files (ConfigError, InputError), 3 divergence, 1 anything else.
// A tool with a --json switch, run with it, prints its errors as JSON too: {"error": "..."} on stderr.
#pragma once

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/json_writer.hpp"

namespace networked_estimation
{
namespace cli
{

/// Bad command line: printed with the usage, exit code 2.
class UsageError : public std::runtime_error
{
public:
  explicit UsageError(const std::string& what) : std::runtime_error(what) {}
};

struct Option
{
  std::string name;        ///< without the leading "--"
  std::string value_name;  ///< e.g. "FILE"; empty for a switch (no value)
  std::string help;
  bool required = false;
  bool repeatable = false;
};

class CommandLine
{
public:
  CommandLine(std::string program, std::string summary, std::vector<Option> options)
    : program_(std::move(program)), summary_(std::move(summary)), options_(std::move(options))
  {
  }

  /// Parses argv. Returns false when --help was given (the usage has been printed to stdout).
  /// Throws UsageError for unknown flags, missing values, repeated or missing required options.
  bool parse(int argc, char** argv)
  {
    for (int i = 1; i < argc; ++i)
    {
      std::string arg = argv[i];
      if (arg == "--help" || arg == "-h")
      {
        std::cout << usage();
        return false;
      }
      if (arg.size() < 3 || arg.compare(0, 2, "--") != 0)
        throw UsageError("unexpected argument '" + arg + "' (options are --key value)");
      std::string key = arg.substr(2), value;
      bool has_value = false;
      const std::string::size_type eq = key.find('=');
      if (eq != std::string::npos)
      {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
        has_value = true;
      }
      const Option* opt = find(key);
      if (!opt)
        throw UsageError("unknown option '--" + key + "'");
      if (opt->value_name.empty())
      {
        if (has_value)
          throw UsageError("option '--" + key + "' takes no value");
        value = "1";
      }
      else if (!has_value)
      {
        if (i + 1 >= argc)
          throw UsageError("option '--" + key + "' needs a value (" + opt->value_name + ")");
        value = argv[++i];
      }
      if (opt->value_name == "FILE" && value.empty())
        throw UsageError("option '--" + key + "': expected a file name, found ''");
      std::vector<std::string>& slot = values_[key];
      if (!slot.empty() && !opt->repeatable)
        throw UsageError("option '--" + key + "' given more than once");
      slot.push_back(value);
    }
    for (const Option& o : options_)
      if (o.required && !has(o.name))
        throw UsageError("missing required option '--" + o.name + "'");
    return true;
  }

  bool has(const std::string& name) const { return values_.count(name) > 0; }

  std::string get(const std::string& name, const std::string& fallback = "") const
  {
    const auto it = values_.find(name);
    return it == values_.end() ? fallback : it->second.front();
  }

  std::vector<std::string> getAll(const std::string& name) const
  {
    const auto it = values_.find(name);
    return it == values_.end() ? std::vector<std::string>{} : it->second;
  }

  /// An integer option value in [min, max].
  long getLong(const std::string& name, long fallback, long min, long max) const
  {
    if (!has(name))
      return fallback;
    const std::string text = get(name);
    errno = 0;
    char* end = nullptr;
    const long v = std::strtol(text.c_str(), &end, 10);
    if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v < min || v > max)
      throw UsageError("option '--" + name + "': expected an integer in [" + std::to_string(min) + ", " +
                       std::to_string(max) + "], found '" + text + "'");
    return v;
  }

  /// An unsigned 64-bit option value (seeds).
  std::uint64_t getUint64(const std::string& name, std::uint64_t fallback) const
  {
    if (!has(name))
      return fallback;
    const std::string text = get(name);
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
    if (text.empty() || text[0] == '-' || text[0] == '+' || end != text.c_str() + text.size() || errno == ERANGE)
      throw UsageError("option '--" + name + "': expected a non-negative integer, found '" + text + "'");
    return static_cast<std::uint64_t>(v);
  }

  std::string usage() const
  {
    std::string out = "usage: " + program_;
    for (const Option& o : options_)
    {
      std::string part = "--" + o.name + (o.value_name.empty() ? "" : " " + o.value_name);
      if (o.repeatable)
        part += " ...";
      out += o.required ? " " + part : " [" + part + "]";
    }
    out += "\n\n" + summary_ + "\n\noptions:\n";
    std::size_t width = 0;
    for (const Option& o : options_)
      width = std::max(width, o.name.size() + (o.value_name.empty() ? 0 : o.value_name.size() + 1));
    for (const Option& o : options_)
    {
      std::string left = "--" + o.name + (o.value_name.empty() ? "" : " " + o.value_name);
      out += "  " + left + std::string(width + 4 - left.size(), ' ') + o.help;
      out += o.required ? " (required)\n" : "\n";
    }
    const std::string help = "--help";
    out += "  " + help + std::string(std::max<std::size_t>(width + 4, help.size() + 2) - help.size(), ' ') +
           "this message\n";
    return out;
  }

  const std::string& program() const { return program_; }

  /// Whether the tool has a --json switch and argv gives it (looked up in argv itself, so that an
  /// error in the rest of the command line is reported as JSON too).
  bool jsonRequested(int argc, char** argv) const
  {
    if (!find("json"))
      return false;
    for (int i = 1; i < argc; ++i)
      if (std::string(argv[i]) == "--json")
        return true;
    return false;
  }

private:
  const Option* find(const std::string& name) const
  {
    for (const Option& o : options_)
      if (o.name == name)
        return &o;
    return nullptr;
  }

  std::string program_, summary_;
  std::vector<Option> options_;
  std::map<std::string, std::vector<std::string>> values_;
};

/// The text of an error on stderr: "error: MESSAGE" (with the usage after a usage error), or with
/// --json {"error": "MESSAGE"}.
inline std::string errorText(const CommandLine& cl, bool json, const std::string& message, bool usage)
{
  if (json)
    return JsonWriter().beginObject().member("error", message).endObject().text() + "\n";
  return "error: " + message + "\n" + (usage ? "\n" + cl.usage() : std::string());
}

/// Parses the command line and runs body() (which returns the exit code), mapping exceptions to
/// messages on stderr and exit codes. --help prints the usage and returns 0.
template <class F>
int runTool(CommandLine& cl, int argc, char** argv, F&& body)
{
  const bool json = cl.jsonRequested(argc, argv);
  try
  {
    if (!cl.parse(argc, argv))
      return 0;
    return body();
  }
  catch (const UsageError& e)
  {
    std::cerr << errorText(cl, json, e.what(), true);
    return 2;
  }
  catch (const ConfigError& e)
  {
    std::cerr << errorText(cl, json, e.what(), false);
    return 2;
  }
  catch (const InputError& e)
  {
    std::cerr << errorText(cl, json, e.what(), false);
    return 2;
  }
  catch (const DivergenceError& e)
  {
    std::cerr << errorText(cl, json, e.what(), false);
    return 3;
  }
  catch (const std::exception& e)
  {
    std::cerr << errorText(cl, json, cl.program() + ": " + e.what(), false);
    return 1;
  }
}

}  // namespace cli
}  // namespace networked_estimation
