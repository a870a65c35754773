// Sharded Monte Carlo runs: running one shard, hashing its input files, finding and merging the
// shard files (montecarlo_shards.hpp; the file itself is shard_file.cpp; docs/formats.md, "Shard
// files").
#include "networked_estimation/experiments/montecarlo_shards.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/estimator_settings.hpp"

namespace networked_estimation
{

namespace
{

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

std::string joinNumbers(const std::vector<double>& v)
{
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i)
  {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", v[i]);
    out += (i ? ", " : "") + std::string(buf);
  }
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
      {"covariance_only", c.covariance_only ? "true" : "false"},
      {"thresholds", joinNumbers(c.thresholds)},
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
  if (!takesCustomInputs(config.experiment))
    return v;
  // an input given as text (a Python object) hashes its text, an algorithm name the text it stands for
  auto add = [&v, &config](const std::string& option, const std::string& path)
  {
    if (path.empty())
      return;
    const auto it = config.inline_inputs.find(path);
    if (it != config.inline_inputs.end())
      v.push_back({option, path, hex64(fnv1a(kFnvBasis, it->second.data(), it->second.size()))});
    else if (option == "--settings" && isAlgorithmName(path))
    {
      const std::string text = "algorithm: " + path + "\n";
      v.push_back({option, path, hex64(fnv1a(kFnvBasis, text.data(), text.size()))});
    }
    else
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
  shard.config = canonicalConfig(config);
  long runs = 0, steps = 0;
  experimentDefaults(shard.config.experiment, runs, steps);
  shard.config.runs = config.runs > 0 ? config.runs : runs;
  shard.config.steps = config.steps > 0 ? config.steps : steps;
  shard.shard = index;
  shard.shards = count;
  // hashed before the runs: a file edited while they run makes the merge refuse the shard
  shard.inputs = hashInputs(shard.config);
  shard.fingerprint = inputsFingerprint(shard.inputs);
  BlockSession session = BlockSession::shard(index, count);
  const ExperimentResult result = runExperiment(shard.config, progress, &session);
  shard.threads = result.threads;
  shard.wall_seconds = result.wall_seconds;
  shard.calls = session.takeCalls();
  return shard;
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
        throw InputError(shards[i].path + ": foreign shard: " + ids[i][f].first + " is " + ids[i][f].second + ", but " +
                         ids[major][f].second + " in " + shards[major].path +
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
          s.calls[i].raw != ref.calls[i].raw || s.calls[i].quantiles != ref.calls[i].quantiles ||
          s.calls[i].sketches.size() != ref.calls[i].sketches.size())
        throw InputError(s.path + ": foreign shard: call " + std::to_string(i) + " has " +
                         std::to_string(s.calls[i].runs) + " runs x " + std::to_string(s.calls[i].values) +
                         " values, " + ref.path + " has " + std::to_string(ref.calls[i].runs) + " x " +
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
    std::set<std::string> dirs;  // the folders of the shard files (none for shards held in memory)
    for (const ShardFile& s : shards)
    {
      const std::string dir = std::filesystem::path(s.path).parent_path().string();
      if (!dir.empty())
        dirs.insert(dir);
    }
    std::vector<std::string> dir_list(dirs.begin(), dirs.end());
    throw InputError("missing shard" + std::string(missing.size() > 1 ? "s " : " ") + joinInts(missing, 20) + " of " +
                     std::to_string(n) + " of " + ref.config.experiment + " (found " + joinInts(present, 20) +
                     (dir_list.empty() ? std::string() : " in " + joinStrings(dir_list)) + ")");
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
    throw InputError(ref.path + ": 'inputs' lists " + std::to_string(ref.inputs.size()) +
                     " files, its arguments name " + std::to_string(now.size()));

  // 4. all blocks of every call, in block order
  std::vector<CallBlocks> merged(ref.calls.size());
  int threads = 1;
  double wall = 0.0;
  for (std::size_t i = 0; i < merged.size(); ++i)
  {
    merged[i].runs = ref.calls[i].runs;
    merged[i].values = ref.calls[i].values;
    merged[i].raw = ref.calls[i].raw;
    merged[i].quantiles = ref.calls[i].quantiles;
    merged[i].sketches.resize(ref.calls[i].sketches.size());
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
    // the sketches' counts add exactly: the same sketches as the unsharded run's, in any order
    for (std::size_t i = 0; i < s.calls.size(); ++i)
      for (std::size_t v = 0; v < s.calls[i].sketches.size(); ++v)
        merged[i].sketches[v].merge(s.calls[i].sketches[v]);
    s.calls.clear();
  }

  // 5. the experiment once more, runMonteCarlo returning the merged moments
  BlockSession session = BlockSession::replay(std::move(merged));
  ExperimentResult result;
  try
  {
    MonteCarloConfig replay = config;
    replay.threads = 1;
    result = runExperiment(replay, nullptr, &session);
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
