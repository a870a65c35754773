// Shard files of the montecarlo tool: running one shard, writing and reading the file, merging
// (montecarlo_shards.hpp; docs/formats.md, "Shard files").
#include "networked_estimation/experiments/montecarlo_shards.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/json_writer.hpp"

namespace networked_estimation
{

namespace
{

const char* const kFormat = "networked_estimation montecarlo shard";
const long kVersion = 1;
const int kMaxShards = 1000000;

// ---------------------------------------------------------------------------------------------
// Hashes

std::uint64_t fnv1a(std::uint64_t h, const char* data, std::size_t n)
{
  for (std::size_t i = 0; i < n; ++i)
  {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ULL;
  }
  return h;
}

const std::uint64_t kFnvBasis = 0xcbf29ce484222325ULL;

std::string hex64(std::uint64_t h)
{
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string hashFile(const std::string& option, const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(option + " " + path + ": cannot read the file");
  std::uint64_t h = kFnvBasis;
  char buf[65536];
  while (in)
  {
    in.read(buf, sizeof buf);
    h = fnv1a(h, buf, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad())
    throw InputError(option + " " + path + ": cannot read the file");
  return hex64(h);
}

// ---------------------------------------------------------------------------------------------
// Writing

/// A double that strtod reads back to the same bits: %.17g, or for the values JSON has no number
/// for, the strings "nan", "-nan", "inf", "-inf".
void appendNumber(std::string& out, double v)
{
  if (std::isnan(v))
    out += std::signbit(v) ? "\"-nan\"" : "\"nan\"";
  else if (std::isinf(v))
    out += v < 0 ? "\"-inf\"" : "\"inf\"";
  else
  {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    out += buf;
  }
}

void appendNumbers(std::string& out, const std::vector<double>& v)
{
  out += '[';
  for (std::size_t i = 0; i < v.size(); ++i)
  {
    if (i)
      out += ", ";
    appendNumber(out, v[i]);
  }
  out += ']';
}

std::string jsonStringList(const std::vector<std::string>& v)
{
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i)
    out += (i ? ", " : "") + jsonString(v[i]);
  return out + "]";
}

// ---------------------------------------------------------------------------------------------
// Reading: a strict reader of the shard file's JSON (the tool writes it; anything else is refused
// with the line and column)

class Reader
{
public:
  Reader(const std::string& text, const std::string& path) : text_(text), path_(path) {}

  [[noreturn]] void fail(const std::string& what) const
  {
    long line = 1, column = 1;
    for (std::size_t i = 0; i < pos_ && i < text_.size(); ++i)
    {
      if (text_[i] == '\n')
      {
        ++line;
        column = 1;
      }
      else
        ++column;
    }
    throw InputError(path_ + ": line " + std::to_string(line) + ", column " + std::to_string(column) + ": " + what);
  }

  std::string found() const
  {
    if (pos_ >= text_.size())
      return "the end of the file (truncated?)";
    const char c = text_[pos_];
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f)
      return "byte " + std::to_string(static_cast<unsigned char>(c));
    return std::string("'") + c + "'";
  }

  void skipSpace()
  {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n' || text_[pos_] == '\r' || text_[pos_] == '\t'))
      ++pos_;
  }

  char peek()
  {
    skipSpace();
    return pos_ < text_.size() ? text_[pos_] : '\0';
  }

  void expect(char c)
  {
    if (peek() != c || pos_ >= text_.size())
      fail(std::string("expected '") + c + "', found " + found());
    ++pos_;
  }

  /// Object members: call with first = true before the first; false at the closing brace.
  bool nextMember(bool& first, std::string& key)
  {
    if (peek() == '}')
    {
      ++pos_;
      return false;
    }
    if (!first)
    {
      if (peek() != ',')
        fail("expected ',' or '}', found " + found());
      ++pos_;
    }
    first = false;
    key = string();
    expect(':');
    return true;
  }

  /// Array elements, as nextMember.
  bool nextElement(bool& first)
  {
    if (peek() == ']')
    {
      ++pos_;
      return false;
    }
    if (!first)
    {
      if (peek() != ',')
        fail("expected ',' or ']', found " + found());
      ++pos_;
    }
    first = false;
    return true;
  }

  std::string string()
  {
    if (peek() != '"')
      fail("expected a string, found " + found());
    ++pos_;
    std::string out;
    while (true)
    {
      if (pos_ >= text_.size())
        fail("unterminated string (truncated file?)");
      const char c = text_[pos_++];
      if (c == '"')
        return out;
      if (static_cast<unsigned char>(c) < 0x20)
      {
        --pos_;
        fail("control character in a string");
      }
      if (c != '\\')
      {
        out += c;
        continue;
      }
      if (pos_ >= text_.size())
        fail("unterminated string (truncated file?)");
      const char e = text_[pos_++];
      switch (e)
      {
        case '"':
        case '\\':
        case '/':
          out += e;
          break;
        case 'n':
          out += '\n';
          break;
        case 'r':
          out += '\r';
          break;
        case 't':
          out += '\t';
          break;
        case 'b':
          out += '\b';
          break;
        case 'f':
          out += '\f';
          break;
        case 'u':
        {
          // jsonString writes \u00XX for control characters only
          unsigned v = 0;
          for (int i = 0; i < 4; ++i)
          {
            if (pos_ >= text_.size() || !std::isxdigit(static_cast<unsigned char>(text_[pos_])))
              fail("expected 4 hex digits after \\u");
            const char h = text_[pos_++];
            v = 16 * v + static_cast<unsigned>(std::isdigit(static_cast<unsigned char>(h)) ? h - '0' : (h | 0x20) - 'a' + 10);
          }
          if (v >= 0x80)
            fail("\\u escape beyond ASCII (not written by montecarlo)");
          out += static_cast<char>(v);
          break;
        }
        default:
          --pos_;
          fail(std::string("unknown escape '\\") + e + "'");
      }
    }
  }

  /// The text of a number token ([-+.0-9eE]+) at the current position; `what` names what was
  /// expected in the message when there is none.
  std::string token(const std::string& what)
  {
    skipSpace();
    const std::size_t begin = pos_;
    while (pos_ < text_.size() && std::string("-+.0123456789eE").find(text_[pos_]) != std::string::npos)
      ++pos_;
    if (pos_ == begin)
      fail(what + ", found " + found());
    return text_.substr(begin, pos_ - begin);
  }

  /// A double: a JSON number, or one of the strings "nan", "-nan", "inf", "-inf".
  double number()
  {
    if (peek() == '"')
    {
      const std::size_t at = pos_;
      const std::string s = string();
      if (s == "nan" || s == "-nan" || s == "inf" || s == "-inf")
        return std::strtod(s.c_str(), nullptr);  // keeps the sign of a NaN, which %g prints
      pos_ = at;
      fail("expected a number or \"nan\", \"-nan\", \"inf\", \"-inf\", found \"" + s + "\"");
    }
    const std::size_t at = (skipSpace(), pos_);
    const std::string t = token("expected a number");
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (end != t.c_str() + t.size() || (errno == ERANGE && std::isinf(v)))
    {
      pos_ = at;
      fail("'" + t + "' is not a number in range");
    }
    return v;
  }

  long integer(const std::string& key, long min, long max)
  {
    const std::size_t at = (skipSpace(), pos_);
    const std::string t = token("'" + key + "': expected an integer");
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(t.c_str(), &end, 10);
    if (end != t.c_str() + t.size() || errno == ERANGE || v < min || v > max)
    {
      pos_ = at;
      fail("'" + key + "': expected an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "], found '" +
           t + "'");
    }
    return static_cast<long>(v);
  }

  std::uint64_t uint64(const std::string& key)
  {
    const std::size_t at = (skipSpace(), pos_);
    const std::string t = token("'" + key + "': expected a non-negative integer");
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(t.c_str(), &end, 10);
    if (t[0] == '-' || t[0] == '+' || end != t.c_str() + t.size() || errno == ERANGE)
    {
      pos_ = at;
      fail("'" + key + "': expected a non-negative integer, found '" + t + "'");
    }
    return static_cast<std::uint64_t>(v);
  }

  bool boolean(const std::string& key)
  {
    skipSpace();
    if (text_.compare(pos_, 4, "true") == 0)
    {
      pos_ += 4;
      return true;
    }
    if (text_.compare(pos_, 5, "false") == 0)
    {
      pos_ += 5;
      return false;
    }
    fail("'" + key + "': expected true or false, found " + found());
  }

  std::vector<double> numbers()
  {
    std::vector<double> v;
    expect('[');
    bool first = true;
    while (nextElement(first))
      v.push_back(number());
    return v;
  }

  std::vector<std::string> strings()
  {
    std::vector<std::string> v;
    expect('[');
    bool first = true;
    while (nextElement(first))
      v.push_back(string());
    return v;
  }

  void end()
  {
    if (peek() != '\0' || pos_ < text_.size())
      fail("unexpected text after the shard's object: " + found());
  }

  /// Marks a key of the current object as seen; fails on a repeated key.
  void seen(std::set<std::string>& keys, const std::string& key)
  {
    if (!keys.insert(key).second)
      fail("key '" + key + "' given twice");
  }

  const std::string& path() const { return path_; }

private:
  const std::string& text_;
  std::string path_;
  std::size_t pos_ = 0;
};

/// Fails naming the keys of `required` that are not in `keys`.
void requireKeys(const Reader& in, const std::set<std::string>& keys, const std::vector<std::string>& required,
                 const std::string& where)
{
  for (const std::string& k : required)
    if (!keys.count(k))
      throw InputError(in.path() + ": " + where + "missing key '" + k + "'");
}

BlockMoments readBlock(Reader& in, std::size_t values, bool raw, const std::string& where)
{
  BlockMoments b;
  std::set<std::string> keys;
  in.expect('{');
  bool first = true;
  std::string key;
  while (in.nextMember(first, key))
  {
    in.seen(keys, key);
    if (key == "index")
      b.index = in.integer(key, 0, 1L << 50);
    else if (key == "count")
      b.count = in.integer(key, 1, kBlockRuns);
    else if (key == "mean")
      b.mean = in.numbers();
    else if (key == "m2")
      b.m2 = in.numbers();
    else if (key == "raw" && raw)
      b.raw = in.numbers();
    else
      in.fail(where + "unknown key '" + key + "'");
  }
  std::vector<std::string> required = {"index", "count", "mean", "m2"};
  if (raw)
    required.push_back("raw");
  requireKeys(in, keys, required, where + "a block: ");
  const std::string block = where + "block " + std::to_string(b.index) + ": ";
  if (b.mean.size() != values || b.m2.size() != values)
    throw InputError(in.path() + ": " + block + "expected " + std::to_string(values) + " numbers in 'mean' and 'm2', found " +
                     std::to_string(b.mean.size()) + " and " + std::to_string(b.m2.size()));
  if (raw && b.raw.size() != static_cast<std::size_t>(b.count) * values)
    throw InputError(in.path() + ": " + block + "expected " + std::to_string(b.count) + " x " + std::to_string(values) +
                     " numbers in 'raw', found " + std::to_string(b.raw.size()));
  return b;
}

CallBlocks readCall(Reader& in, std::size_t index)
{
  CallBlocks c;
  const std::string where = "call " + std::to_string(index) + ": ";
  std::set<std::string> keys;
  in.expect('{');
  bool first = true;
  std::string key;
  while (in.nextMember(first, key))
  {
    in.seen(keys, key);
    if (key == "runs")
      c.runs = in.integer(key, 1, 100000000);
    else if (key == "values")
      c.values = static_cast<std::size_t>(in.integer(key, 0, 1L << 40));
    else if (key == "raw")
      c.raw = in.boolean(key);
    else if (key == "blocks")
    {
      // the blocks come last (the writer's order), so their sizes can be checked as they are read
      requireKeys(in, keys, {"runs", "values", "raw"}, where + "before 'blocks': ");
      in.expect('[');
      bool first_block = true;
      while (in.nextElement(first_block))
        c.blocks.push_back(readBlock(in, c.values, c.raw, where));
    }
    else
      in.fail(where + "unknown key '" + key + "'");
  }
  requireKeys(in, keys, {"runs", "values", "raw", "blocks"}, where);
  return c;
}

std::vector<ShardInput> readInputs(Reader& in)
{
  std::vector<ShardInput> v;
  in.expect('[');
  bool first = true;
  while (in.nextElement(first))
  {
    ShardInput f;
    std::set<std::string> keys;
    in.expect('{');
    bool first_key = true;
    std::string key;
    while (in.nextMember(first_key, key))
    {
      in.seen(keys, key);
      if (key == "option")
        f.option = in.string();
      else if (key == "path")
        f.path = in.string();
      else if (key == "fnv1a64")
        f.hash = in.string();
      else
        in.fail("inputs: unknown key '" + key + "'");
    }
    requireKeys(in, keys, {"option", "path", "fnv1a64"}, "inputs: ");
    v.push_back(f);
  }
  return v;
}

std::string joinInts(const std::vector<int>& v, std::size_t limit)
{
  std::string out;
  for (std::size_t i = 0; i < v.size() && i < limit; ++i)
    out += (i ? ", " : "") + std::to_string(v[i]);
  if (v.size() > limit)
    out += ", ... (" + std::to_string(v.size()) + " in all)";
  return out;
}

std::string joinStrings(const std::vector<std::string>& v)
{
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i)
    out += (i ? ", " : "") + v[i];
  return out + "]";
}

/// The fields two shards of one merge must agree on, as (name, text) pairs, in the order checked.
std::vector<std::pair<std::string, std::string>> identity(const ShardFile& s)
{
  const MonteCarloConfig& c = s.config;
  return {
      {"experiment", c.experiment},
      {"shards (N)", std::to_string(s.shards)},
      {"runs", std::to_string(c.runs)},
      {"steps", std::to_string(c.steps)},
      {"seed", std::to_string(c.seed)},
      {"block_runs", std::to_string(s.block_runs)},
      {"model", "'" + c.model_path + "'"},
      {"channel", joinStrings(c.channel_args)},
      {"actuator_channel", "'" + c.actuator_channel_path + "'"},
      {"settings", joinStrings(c.settings_paths)},
      {"axes", joinStrings(c.axis_args)},
      {"fingerprint (of the input files)", s.fingerprint},
  };
}

}  // namespace

// ---------------------------------------------------------------------------------------------

bool parseShardSpec(const std::string& text, int& index, int& count)
{
  const std::string::size_type slash = text.find('/');
  if (slash == std::string::npos)
    return false;
  const std::string a = text.substr(0, slash), b = text.substr(slash + 1);
  auto digits = [](const std::string& s) {
    return !s.empty() && s.size() <= 7 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!digits(a) || !digits(b))
    return false;
  const long k = std::strtol(a.c_str(), nullptr, 10), n = std::strtol(b.c_str(), nullptr, 10);
  if (n < 1 || n > kMaxShards || k < 1 || k > n)
    return false;
  index = static_cast<int>(k);
  count = static_cast<int>(n);
  return true;
}

std::vector<ShardInput> hashInputs(const MonteCarloConfig& config)
{
  std::vector<ShardInput> v;
  if (config.experiment != "custom" && config.experiment != "sweep")
    return v;
  auto add = [&v](const std::string& option, const std::string& path) {
    if (!path.empty())
      v.push_back({option, path, hashFile(option, path)});
  };
  add("--model", config.model_path);
  for (const std::string& arg : config.channel_args)
  {
    // FILE or NAME=FILE, split as resolveSensorLinks does
    const std::string::size_type eq = arg.find('=');
    add("--channel", eq == std::string::npos ? arg : arg.substr(eq + 1));
  }
  add("--actuator-channel", config.actuator_channel_path);
  for (const std::string& p : config.settings_paths)
    add("--settings", p);
  return v;
}

std::string inputsFingerprint(const std::vector<ShardInput>& inputs)
{
  std::uint64_t h = kFnvBasis;
  for (const ShardInput& f : inputs)
    for (const std::string* s : {&f.option, &f.path, &f.hash})
      h = fnv1a(h, s->c_str(), s->size() + 1);  // with the terminating NUL as a separator
  return hex64(h);
}

ShardFile runShard(const MonteCarloConfig& config, int index, int count, ProgressCounter* progress)
{
  if (count < 1 || count > kMaxShards || index < 1 || index > count)
    throw ConfigError("shard " + std::to_string(index) + " of " + std::to_string(count) +
                      ": expected 1 <= K <= N <= " + std::to_string(kMaxShards));
  ShardFile shard;
  shard.config = config;
  long runs = 0, steps = 0;
  experimentDefaults(config.experiment, runs, steps);
  shard.config.runs = config.runs > 0 ? config.runs : runs;
  shard.config.steps = config.steps > 0 ? config.steps : steps;
  shard.shard = index;
  shard.shards = count;
  // hashed before the runs: a file edited while they run makes the merge refuse the shard
  shard.inputs = hashInputs(shard.config);
  shard.fingerprint = inputsFingerprint(shard.inputs);
  BlockSession session = BlockSession::shard(index, count);
  ExperimentResult result;
  {
    BlockSessionScope scope(session);
    result = runExperiment(shard.config, progress);
  }
  shard.threads = result.threads;
  shard.wall_seconds = result.wall_seconds;
  shard.calls = session.takeCalls();
  return shard;
}

std::string shardFileName(const std::string& experiment, int index, int count)
{
  return experiment + ".shard-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json";
}

std::string shardJson(const ShardFile& s)
{
  const MonteCarloConfig& c = s.config;
  std::string out;
  out += "{\n";
  out += "  \"format\": " + jsonString(kFormat) + ",\n";
  out += "  \"version\": " + std::to_string(kVersion) + ",\n";
  out += "  \"experiment\": " + jsonString(c.experiment) + ",\n";
  out += "  \"runs\": " + std::to_string(c.runs) + ",\n";
  out += "  \"steps\": " + std::to_string(c.steps) + ",\n";
  out += "  \"seed\": " + std::to_string(c.seed) + ",\n";
  out += "  \"shard\": " + std::to_string(s.shard) + ",\n";
  out += "  \"shards\": " + std::to_string(s.shards) + ",\n";
  out += "  \"block_runs\": " + std::to_string(s.block_runs) + ",\n";
  out += "  \"model\": " + jsonString(c.model_path) + ",\n";
  out += "  \"channel\": " + jsonStringList(c.channel_args) + ",\n";
  out += "  \"actuator_channel\": " + jsonString(c.actuator_channel_path) + ",\n";
  out += "  \"settings\": " + jsonStringList(c.settings_paths) + ",\n";
  if (!c.axis_args.empty())
    out += "  \"axes\": " + jsonStringList(c.axis_args) + ",\n";
  out += "  \"inputs\": [";
  for (std::size_t i = 0; i < s.inputs.size(); ++i)
    out += std::string(i ? "," : "") + "\n    {\"option\": " + jsonString(s.inputs[i].option) +
           ", \"path\": " + jsonString(s.inputs[i].path) + ", \"fnv1a64\": " + jsonString(s.inputs[i].hash) + "}";
  out += s.inputs.empty() ? "],\n" : "\n  ],\n";
  out += "  \"fingerprint\": " + jsonString(s.fingerprint) + ",\n";
  out += "  \"threads\": " + std::to_string(s.threads) + ",\n";
  out += "  \"wall_seconds\": ";
  appendNumber(out, std::isfinite(s.wall_seconds) ? s.wall_seconds : 0.0);
  out += ",\n";
  out += "  \"calls\": [";
  for (std::size_t i = 0; i < s.calls.size(); ++i)
  {
    const CallBlocks& call = s.calls[i];
    out += std::string(i ? "," : "") + "\n    {\"runs\": " + std::to_string(call.runs) +
           ", \"values\": " + std::to_string(call.values) + ", \"raw\": " + (call.raw ? "true" : "false") +
           ", \"blocks\": [";
    for (std::size_t j = 0; j < call.blocks.size(); ++j)
    {
      const BlockMoments& b = call.blocks[j];
      out += std::string(j ? "," : "") + "\n      {\"index\": " + std::to_string(b.index) +
             ", \"count\": " + std::to_string(b.count) + ",\n       \"mean\": ";
      appendNumbers(out, b.mean);
      out += ",\n       \"m2\": ";
      appendNumbers(out, b.m2);
      if (call.raw)
      {
        out += ",\n       \"raw\": ";
        appendNumbers(out, b.raw);
      }
      out += "}";
    }
    out += call.blocks.empty() ? "]}" : "\n    ]}";
  }
  out += s.calls.empty() ? "]\n" : "\n  ]\n";
  out += "}\n";
  return out;
}

ShardFile parseShard(const std::string& text, const std::string& path)
{
  Reader in(text, path);
  ShardFile s;
  s.path = path;
  MonteCarloConfig& c = s.config;
  std::set<std::string> keys;
  std::string format;
  long version = 0;
  in.expect('{');
  bool first = true;
  std::string key;
  while (in.nextMember(first, key))
  {
    in.seen(keys, key);
    if (key == "format")
    {
      format = in.string();
      if (format != kFormat)
        throw InputError(path + ": not a montecarlo shard file ('format' is '" + format + "', expected '" + kFormat + "')");
    }
    else if (key == "version")
    {
      version = in.integer(key, 0, 1000000);
      if (version != kVersion)
        throw InputError(path + ": shard format version " + std::to_string(version) + ", this montecarlo reads version " +
                         std::to_string(kVersion));
    }
    else if (key == "experiment")
      c.experiment = in.string();
    else if (key == "runs")
      c.runs = in.integer(key, 1, 100000000);
    else if (key == "steps")
      c.steps = in.integer(key, 1, 100000000);
    else if (key == "seed")
      c.seed = in.uint64(key);
    else if (key == "shard")
      s.shard = static_cast<int>(in.integer(key, 1, kMaxShards));
    else if (key == "shards")
      s.shards = static_cast<int>(in.integer(key, 1, kMaxShards));
    else if (key == "block_runs")
      s.block_runs = in.integer(key, 1, 1L << 40);
    else if (key == "model")
      c.model_path = in.string();
    else if (key == "channel")
      c.channel_args = in.strings();
    else if (key == "actuator_channel")
      c.actuator_channel_path = in.string();
    else if (key == "settings")
      c.settings_paths = in.strings();
    else if (key == "axes")
      c.axis_args = in.strings();  // sweep only (absent otherwise)
    else if (key == "inputs")
      s.inputs = readInputs(in);
    else if (key == "fingerprint")
      s.fingerprint = in.string();
    else if (key == "threads")
      s.threads = static_cast<int>(in.integer(key, 1, 1000000));
    else if (key == "wall_seconds")
      s.wall_seconds = in.number();
    else if (key == "calls")
    {
      in.expect('[');
      bool first_call = true;
      while (in.nextElement(first_call))
        s.calls.push_back(readCall(in, s.calls.size()));
    }
    else
      in.fail("unknown key '" + key + "'");
  }
  in.end();
  requireKeys(in, keys,
              {"format", "version", "experiment", "runs", "steps", "seed", "shard", "shards", "block_runs", "model",
               "channel", "actuator_channel", "settings", "inputs", "fingerprint", "threads", "wall_seconds", "calls"},
              "");

  // the meaning of the fields
  try
  {
    checkExperimentName(c.experiment);
  }
  catch (const ConfigError& e)
  {
    throw InputError(path + ": 'experiment': " + e.what());
  }
  if (s.shard > s.shards)
    throw InputError(path + ": 'shard' " + std::to_string(s.shard) + " is beyond 'shards' " + std::to_string(s.shards));
  if (s.block_runs != kBlockRuns)
    throw InputError(path + ": 'block_runs' is " + std::to_string(s.block_runs) + ", this montecarlo uses " +
                     std::to_string(kBlockRuns));
  if (s.fingerprint != inputsFingerprint(s.inputs))
    throw InputError(path + ": 'fingerprint' " + s.fingerprint + " does not match its 'inputs' (" +
                     inputsFingerprint(s.inputs) + "): the file was edited");
  const std::string base = std::filesystem::path(path).filename().string();
  std::smatch m;
  static const std::regex name_pattern(R"(^(.+)\.shard-([0-9]+)-of-([0-9]+)\.json$)");
  if (std::regex_match(base, m, name_pattern) &&
      (m[1].str() != c.experiment || m[2].str() != std::to_string(s.shard) || m[3].str() != std::to_string(s.shards)))
    throw InputError(path + ": the file name says " + m[1].str() + " shard " + m[2].str() + " of " + m[3].str() +
                     ", the file holds " + c.experiment + " shard " + std::to_string(s.shard) + " of " +
                     std::to_string(s.shards) + " (renamed?)");
  // every call holds exactly the blocks of this shard, each of its size
  for (std::size_t i = 0; i < s.calls.size(); ++i)
  {
    const CallBlocks& call = s.calls[i];
    std::size_t j = 0;
    for (long b = s.shard - 1; b < blockCount(call.runs); b += s.shards, ++j)
    {
      const std::string where = path + ": call " + std::to_string(i) + ": ";
      if (j >= call.blocks.size())
        throw InputError(where + "block " + std::to_string(b) + " of shard " + std::to_string(s.shard) + " of " +
                         std::to_string(s.shards) + " is missing");
      const BlockMoments& blk = call.blocks[j];
      if (blk.index != b)
        throw InputError(where + "expected block " + std::to_string(b) + ", found block " + std::to_string(blk.index) +
                         " (shard " + std::to_string(s.shard) + " of " + std::to_string(s.shards) + " holds the blocks b with b % " +
                         std::to_string(s.shards) + " = " + std::to_string(s.shard - 1) + ")");
      if (blk.count != blockRuns(call.runs, b))
        throw InputError(where + "block " + std::to_string(b) + ": 'count' is " + std::to_string(blk.count) + ", expected " +
                         std::to_string(blockRuns(call.runs, b)));
    }
    if (j != call.blocks.size())
      throw InputError(path + ": call " + std::to_string(i) + ": " + std::to_string(call.blocks.size() - j) +
                       " blocks more than shard " + std::to_string(s.shard) + " of " + std::to_string(s.shards) + " holds");
  }
  return s;
}

ShardFile readShard(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(path + ": cannot read the shard file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad())
    throw InputError(path + ": cannot read the shard file");
  const std::string text = ss.str();
  if (text.empty())
    throw InputError(path + ": empty shard file");
  return parseShard(text, path);
}

std::string writeShard(const ShardFile& shard, const std::string& dir)
{
  makeOutputDirectory(dir);
  AtomicFile file((dir.empty() ? std::string(".") : dir) + "/" +
                  shardFileName(shard.config.experiment, shard.shard, shard.shards));
  file.stream() << shardJson(shard);
  file.commit();
  return file.path();
}

std::vector<std::string> findShardFiles(const std::vector<std::string>& dirs, const std::string& experiment)
{
  namespace fs = std::filesystem;
  static const std::regex name_pattern(R"(^.+\.shard-[0-9]+-of-[0-9]+\.json$)");
  const std::string prefix = experiment.empty() ? "" : experiment + ".shard-";
  std::vector<std::string> files;
  std::set<std::string> seen;  // canonical paths: a directory given twice (or as ./DIR and DIR) is read once
  for (const std::string& dir : dirs)
  {
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
      throw InputError(dir + ": " + (fs::exists(dir, ec) ? "not a directory" : "no such directory"));
    std::size_t found = 0;
    fs::directory_iterator it(dir, ec), end;
    if (ec)
      throw InputError(dir + ": cannot list the directory (" + ec.message() + ")");
    for (; it != end; it.increment(ec))
    {
      if (ec)
        throw InputError(dir + ": cannot list the directory (" + ec.message() + ")");
      const std::string name = it->path().filename().string();
      if (std::regex_match(name, name_pattern) && name.compare(0, prefix.size(), prefix) == 0 && !it->is_directory(ec))
      {
        const fs::path file = fs::path(dir) / name;
        const fs::path canonical = fs::weakly_canonical(file, ec);
        if (seen.insert(ec ? file.string() : canonical.string()).second)
          files.push_back(file.string());
        ++found;
      }
    }
    if (found == 0)
      throw InputError(dir + ": no shard files (" + (experiment.empty() ? std::string("NAME") : experiment) +
                       ".shard-K-of-N.json) in the directory");
  }
  std::sort(files.begin(), files.end());
  return files;
}

ExperimentResult mergeShards(std::vector<ShardFile> shards)
{
  if (shards.empty())
    throw InputError("merge: no shard files");
  // 1. every shard of the same experiment, configuration and inputs. A field's reference value is
  // the one most shards have (the first shard's on a tie), so the odd one out is named.
  std::vector<std::vector<std::pair<std::string, std::string>>> ids;
  for (const ShardFile& s : shards)
    ids.push_back(identity(s));
  for (std::size_t f = 0; f < ids[0].size(); ++f)
  {
    std::map<std::string, std::size_t> votes;
    std::size_t major = 0;
    for (std::size_t i = 0; i < shards.size(); ++i)
      if (++votes[ids[i][f].second] > votes[ids[major][f].second])
        major = i;
    for (std::size_t i = 0; i < shards.size(); ++i)
      if (ids[i][f].second != ids[major][f].second)
        throw InputError(shards[i].path + ": foreign shard: " + ids[i][f].first + " is " + ids[i][f].second +
                         ", but " + ids[major][f].second + " in " + shards[major].path +
                         (f == 0 ? " (merge one experiment at a time: --experiment NAME)" : ""));
  }
  const ShardFile& ref = shards.front();
  for (const ShardFile& s : shards)
  {
    if (s.calls.size() != ref.calls.size())
      throw InputError(s.path + ": foreign shard: it holds " + std::to_string(s.calls.size()) + " Monte Carlo calls, " +
                       ref.path + " holds " + std::to_string(ref.calls.size()));
    for (std::size_t i = 0; i < s.calls.size(); ++i)
      if (s.calls[i].runs != ref.calls[i].runs || s.calls[i].values != ref.calls[i].values ||
          s.calls[i].raw != ref.calls[i].raw)
        throw InputError(s.path + ": foreign shard: call " + std::to_string(i) + " has " +
                         std::to_string(s.calls[i].runs) + " runs x " + std::to_string(s.calls[i].values) + " values, " +
                         ref.path + " has " + std::to_string(ref.calls[i].runs) + " x " +
                         std::to_string(ref.calls[i].values));
  }
  // 2. every K of N exactly once
  const int n = ref.shards;
  std::map<int, std::string> by_index;
  for (const ShardFile& s : shards)
  {
    const auto it = by_index.find(s.shard);
    if (it != by_index.end())
      throw InputError("duplicate shard " + std::to_string(s.shard) + " of " + std::to_string(n) + ": " + it->second +
                       " and " + s.path);
    by_index[s.shard] = s.path;
  }
  std::vector<int> missing;
  for (int k = 1; k <= n; ++k)
    if (!by_index.count(k))
      missing.push_back(k);
  if (!missing.empty())
  {
    std::vector<int> present;
    for (const auto& e : by_index)
      present.push_back(e.first);
    std::set<std::string> dirs;
    for (const ShardFile& s : shards)
      dirs.insert(std::filesystem::path(s.path).parent_path().string());
    std::vector<std::string> dir_list(dirs.begin(), dirs.end());
    throw InputError("missing shard" + std::string(missing.size() > 1 ? "s " : " ") + joinInts(missing, 20) + " of " +
                     std::to_string(n) + " of " + ref.config.experiment + " (found " + joinInts(present, 20) + " in " +
                     joinStrings(dir_list) + ")");
  }
  // 3. the input files as they were when the shards ran (the merge re-reads them)
  std::vector<ShardInput> now;
  try
  {
    now = hashInputs(ref.config);
  }
  catch (const InputError& e)
  {
    throw InputError(std::string(e.what()) + " (the merge re-reads the input files of " + ref.path + ")");
  }
  for (std::size_t i = 0; i < now.size() && i < ref.inputs.size(); ++i)
    if (now[i].hash != ref.inputs[i].hash || now[i].path != ref.inputs[i].path)
      throw InputError(now[i].option + " " + now[i].path + " has changed since the shards were computed (fnv1a64 " +
                       ref.inputs[i].hash + " in " + ref.path + ", " + now[i].hash + " now)");
  if (now.size() != ref.inputs.size())
    throw InputError(ref.path + ": 'inputs' lists " + std::to_string(ref.inputs.size()) + " files, its arguments name " +
                     std::to_string(now.size()));

  // 4. all blocks of every call, in block order
  std::vector<CallBlocks> merged(ref.calls.size());
  int threads = 1;
  double wall = 0.0;
  for (std::size_t i = 0; i < merged.size(); ++i)
  {
    merged[i].runs = ref.calls[i].runs;
    merged[i].values = ref.calls[i].values;
    merged[i].raw = ref.calls[i].raw;
    merged[i].blocks.resize(static_cast<std::size_t>(blockCount(merged[i].runs)));
  }
  const MonteCarloConfig config = ref.config;
  const std::string ref_path = ref.path;
  for (ShardFile& s : shards)
  {
    threads = std::max(threads, s.threads);
    wall += s.wall_seconds;
    for (std::size_t i = 0; i < s.calls.size(); ++i)
      for (BlockMoments& b : s.calls[i].blocks)
      {
        // parseShard has checked that a shard holds exactly its blocks; a ShardFile made otherwise
        // may not, and combineBlocks refuses a gap
        if (b.index < 0 || b.index >= static_cast<long>(merged[i].blocks.size()) ||
            merged[i].blocks[static_cast<std::size_t>(b.index)].count != 0)
          throw InputError(s.path + ": call " + std::to_string(i) + ": block " + std::to_string(b.index) +
                           " is out of range or held by another shard too");
        merged[i].blocks[static_cast<std::size_t>(b.index)] = std::move(b);
      }
    s.calls.clear();
  }

  // 5. the experiment once more, runMonteCarlo returning the merged moments
  BlockSession session = BlockSession::replay(std::move(merged));
  ExperimentResult result;
  try
  {
    BlockSessionScope scope(session);
    MonteCarloConfig replay = config;
    replay.threads = 1;
    result = runExperiment(replay, nullptr);
  }
  catch (const InputError& e)
  {
    throw InputError("merging the shards of " + config.experiment + " (" + ref_path + ", ...): " + e.what());
  }
  if (session.replayed() != session.calls().size())
    throw InputError("merging the shards of " + config.experiment + " (" + ref_path + ", ...): they hold " +
                     std::to_string(session.calls().size()) + " Monte Carlo calls, the experiment makes " +
                     std::to_string(session.replayed()) + " (were they computed by another version of montecarlo?)");
  result.threads = threads;
  result.wall_seconds = wall;
  return result;
}

}  // namespace networked_estimation
