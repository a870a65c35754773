// The shard file of the montecarlo tool: its JSON text, written and read through nlohmann/json
// (JsonWriter, JsonDocument), and the checks of what it holds (montecarlo_shards.hpp;
// docs/formats.md, "Shard files").
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "io/json_document.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/experiments/montecarlo_shards.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/json_writer.hpp"

namespace networked_estimation
{

namespace
{

const char* const kFormat = "networked_estimation montecarlo shard";
// Version 2: the accumulators of the heavy-tail statistics in every block, the calls' quantile
// sketches, and the covariance_only and thresholds options.
const long kVersion = 2;

/// A double that reads back to the same bits: a JSON number (the library writes the shortest text
/// that does), or for the values JSON has no number for, the strings "nan", "-nan", "inf", "-inf".
void writeNumber(JsonWriter& w, double v)
{
  if (std::isnan(v))
    w.value(std::signbit(v) ? "-nan" : "nan");
  else if (std::isinf(v))
    w.value(v < 0 ? "-inf" : "inf");
  else
    w.value(v);
}

void writeNumbers(JsonWriter& w, const std::vector<double>& v)
{
  w.beginArray();
  for (double x : v)
    writeNumber(w, x);
  w.endArray();
}

void writeCall(JsonWriter& w, const CallBlocks& call)
{
  w.beginObject().member("runs", call.runs).member("values", call.values).member("raw", call.raw).key("blocks");
  w.beginArray();
  for (const BlockMoments& b : call.blocks)
  {
    w.br(6).beginObject().member("index", b.index).member("count", b.count);
    w.br(7).key("mean");
    writeNumbers(w, b.mean);
    w.br(7).key("m2");
    writeNumbers(w, b.m2);
    if (call.raw)
    {
      w.br(7).key("raw");
      writeNumbers(w, b.raw);
    }
    w.endObject();
  }
  if (!call.blocks.empty())
    w.br(4);
  w.endArray();
  if (call.quantiles)
  {
    w.member("quantiles", true);
    w.br(4).key("sketches").beginArray();
    for (const QuantileSketch& q : call.sketches)
    {
      w.br(6).beginArray();
      for (std::int64_t c : q.encode())
        w.value(static_cast<long>(c));
      w.endArray();
    }
    if (!call.sketches.empty())
      w.br(4);
    w.endArray();
  }
  w.endObject();
}

BlockMoments readBlock(const JsonField& f, std::size_t values, bool raw)
{
  BlockMoments b;
  if (raw)
    f.keys({"index", "count", "mean", "m2", "raw"});
  else
    f.keys({"index", "count", "mean", "m2"});
  b.index = f["index"].integer(0, 1L << 50);
  b.count = f["count"].integer(1, kBlockRuns);
  b.mean = f["mean"].numbers();
  b.m2 = f["m2"].numbers();
  if (b.mean.size() != values || b.m2.size() != values)
    f.fail("block " + std::to_string(b.index) + ": expected " + std::to_string(values) +
           " numbers in 'mean' and 'm2', found " + std::to_string(b.mean.size()) + " and " +
           std::to_string(b.m2.size()));
  if (raw)
  {
    b.raw = f["raw"].numbers();
    if (b.raw.size() != static_cast<std::size_t>(b.count) * values)
      f["raw"].fail("block " + std::to_string(b.index) + ": expected " + std::to_string(b.count) + " x " +
                    std::to_string(values) + " numbers, found " + std::to_string(b.raw.size()));
  }
  return b;
}

CallBlocks readCall(const JsonField& f)
{
  CallBlocks c;
  f.keys({"runs", "values", "raw", "blocks"}, {"quantiles", "sketches"});
  c.runs = f["runs"].integer(1, 100000000);
  c.values = static_cast<std::size_t>(f["values"].integer(0, 1L << 40));
  c.raw = f["raw"].boolean();
  for (const JsonField& b : f["blocks"].elements())
    c.blocks.push_back(readBlock(b, c.values, c.raw));
  c.quantiles = f.json().count("quantiles") && f["quantiles"].boolean();
  if (c.quantiles != (f.json().count("sketches") > 0))
    f.fail("'quantiles' and 'sketches' go together");
  if (c.quantiles)
  {
    const std::vector<JsonField> sketches = f["sketches"].elements();
    if (sketches.size() > c.values)
      f["sketches"].fail("expected at most " + std::to_string(c.values) + " sketches (one per value), found " +
                         std::to_string(sketches.size()));
    for (const JsonField& q : sketches)
    {
      std::vector<std::int64_t> v;
      if (!q.json().is_array())
        q.fail("expected an array of integers");
      for (const nlohmann::json& x : q.json())
      {
        if (!x.is_number_integer())
          q.fail("expected an array of integers, found " + x.dump());
        v.push_back(x.get<std::int64_t>());
      }
      try
      {
        c.sketches.push_back(QuantileSketch::decode(v, "quantile sketch"));
      }
      catch (const InputError& e)
      {
        q.fail(e.what());
      }
    }
  }
  return c;
}

std::vector<ShardInput> readInputs(const JsonField& f)
{
  std::vector<ShardInput> v;
  for (const JsonField& e : f.elements())
  {
    e.keys({"option", "path", "fnv1a64"});
    v.push_back({e["option"].string(), e["path"].string(), e["fnv1a64"].string()});
  }
  return v;
}

/// Every call holds exactly the blocks of its shard, each of its size.
void checkBlocks(const ShardFile& s)
{
  const std::string part = "shard " + std::to_string(s.shard) + " of " + std::to_string(s.shards);
  for (std::size_t i = 0; i < s.calls.size(); ++i)
  {
    const CallBlocks& call = s.calls[i];
    const std::string where = s.path + ": call " + std::to_string(i) + ": ";
    std::size_t j = 0;
    for (long b = s.shard - 1; b < blockCount(call.runs); b += s.shards, ++j)
    {
      if (j >= call.blocks.size())
        throw InputError(where + "block " + std::to_string(b) + " of " + part + " is missing");
      const BlockMoments& blk = call.blocks[j];
      if (blk.index != b)
        throw InputError(where + "expected block " + std::to_string(b) + ", found block " + std::to_string(blk.index) +
                         " (" + part + " holds the blocks b with b % " + std::to_string(s.shards) + " = " +
                         std::to_string(s.shard - 1) + ")");
      if (blk.count != blockRuns(call.runs, b))
        throw InputError(where + "block " + std::to_string(b) + ": 'count' is " + std::to_string(blk.count) +
                         ", expected " + std::to_string(blockRuns(call.runs, b)));
    }
    if (j != call.blocks.size())
      throw InputError(where + std::to_string(call.blocks.size() - j) + " blocks more than " + part + " holds");
  }
}

}  // namespace

std::string shardFileName(const std::string& experiment, int index, int count)
{
  return experiment + ".shard-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json";
}

std::string shardJson(const ShardFile& s)
{
  const MonteCarloConfig& c = s.config;
  JsonWriter w;
  w.beginObject();
  w.br(2).member("format", kFormat);
  w.br(2).member("version", kVersion);
  w.br(2).member("experiment", c.experiment);
  w.br(2).member("runs", c.runs);
  w.br(2).member("steps", c.steps);
  w.br(2).member("seed", c.seed);
  w.br(2).member("shard", s.shard);
  w.br(2).member("shards", s.shards);
  w.br(2).member("block_runs", s.block_runs);
  w.br(2).member("model", c.model_path);
  w.br(2).member("channel", c.channel_args);
  w.br(2).member("actuator_channel", c.actuator_channel_path);
  w.br(2).member("settings", c.settings_paths);
  if (!c.axis_args.empty())
    w.br(2).member("axes", c.axis_args);
  if (c.covariance_only)
    w.br(2).member("covariance_only", true);
  if (!c.inline_inputs.empty())
  {
    w.br(2).key("inline_inputs").beginObject();
    for (const auto& kv : c.inline_inputs)
      w.br(4).member(kv.first, kv.second);
    w.br(2).endObject();
  }
  if (!c.thresholds.empty())
  {
    w.br(2).key("thresholds").beginArray();
    for (double t : c.thresholds)
      writeNumber(w, t);
    w.endArray();
  }
  w.br(2).key("inputs").beginArray();
  for (const ShardInput& f : s.inputs)
    w.br(4).beginObject().member("option", f.option).member("path", f.path).member("fnv1a64", f.hash).endObject();
  if (!s.inputs.empty())
    w.br(2);
  w.endArray();
  w.br(2).member("fingerprint", s.fingerprint);
  w.br(2).member("threads", s.threads);
  w.br(2).key("wall_seconds");
  writeNumber(w, std::isfinite(s.wall_seconds) ? s.wall_seconds : 0.0);
  w.br(2).key("calls").beginArray();
  for (const CallBlocks& call : s.calls)
  {
    w.br(4);
    writeCall(w, call);
  }
  if (!s.calls.empty())
    w.br(2);
  w.endArray();
  w.br(0).endObject();
  return w.text() + "\n";
}

ShardFile parseShard(const std::string& text, const std::string& path)
{
  const JsonDocument doc(text, path);
  const JsonField top(doc, doc.root(), "");
  ShardFile s;
  s.path = path;
  MonteCarloConfig& c = s.config;
  // what the file is first, so that another JSON file is named as such rather than by its keys
  if (top.json().count("format") && top["format"].string() != kFormat)
    throw InputError(path + ": not a montecarlo shard file ('format' is '" + top["format"].string() + "', expected '" +
                     kFormat + "')");
  if (top.json().count("version") && top["version"].integer(0, 1000000) != kVersion)
    throw InputError(path + ": shard format version " + std::to_string(top["version"].integer(0, 1000000)) +
                     ", this montecarlo reads version " + std::to_string(kVersion));
  top.keys({"format", "version", "experiment", "runs", "steps", "seed", "shard", "shards", "block_runs", "model",
            "channel", "actuator_channel", "settings", "inputs", "fingerprint", "threads", "wall_seconds", "calls"},
           {"axes", "covariance_only", "thresholds", "inline_inputs"});
  c.experiment = top["experiment"].string();
  c.runs = top["runs"].integer(1, 100000000);
  c.steps = top["steps"].integer(1, 100000000);
  c.seed = top["seed"].uint64();
  s.shard = static_cast<int>(top["shard"].integer(1, kMaxShards));
  s.shards = static_cast<int>(top["shards"].integer(1, kMaxShards));
  s.block_runs = top["block_runs"].integer(1, 1L << 40);
  c.model_path = top["model"].string();
  c.channel_args = top["channel"].strings();
  c.actuator_channel_path = top["actuator_channel"].string();
  c.settings_paths = top["settings"].strings();
  if (top.json().count("axes"))
    c.axis_args = top["axes"].strings();  // sweep only
  if (top.json().count("covariance_only"))
    c.covariance_only = top["covariance_only"].boolean();
  if (top.json().count("thresholds"))
    c.thresholds = top["thresholds"].numbers();
  if (top.json().count("inline_inputs"))
  {
    const JsonField f = top["inline_inputs"];
    if (!f.json().is_object())
      f.fail("expected an object of texts");
    for (auto it = f.json().begin(); it != f.json().end(); ++it)
      c.inline_inputs[it.key()] = f[it.key()].string();
  }
  s.inputs = readInputs(top["inputs"]);
  s.fingerprint = top["fingerprint"].string();
  s.threads = static_cast<int>(top["threads"].integer(1, 1000000));
  s.wall_seconds = top["wall_seconds"].number();
  for (const JsonField& call : top["calls"].elements())
    s.calls.push_back(readCall(call));

  // the meaning of the fields
  try
  {
    checkExperimentName(c.experiment);
  }
  catch (const ConfigError& e)
  {
    top["experiment"].fail(e.what());
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
  checkBlocks(s);
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

}  // namespace networked_estimation
