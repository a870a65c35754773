// Sharding a Monte Carlo experiment across processes or machines (ROS-free):
//   montecarlo ... --shard K/N --out DIR   computes shard K of N and writes DIR/NAME.shard-K-of-N.json
//   montecarlo merge DIR... [--out DIR]    checks the shards, merges them, writes DIR/NAME.csv, .json
// Shard K of N computes, in every runMonteCarlo call of the experiment, the blocks b (of kBlockRuns
// runs) with b % N == K - 1 and records their Welford accumulators (and per-run values) exactly.
// The merge re-runs the experiment with runMonteCarlo replaying the merged blocks (a BlockSession
// passed to runExperiment),
// so its outputs are those of the unsharded run, bit for bit; only `threads` and `wall_seconds` of
// the JSON differ. docs/formats.md, "Shard files", has the format and the rules.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/experiments/montecarlo.hpp"

namespace networked_estimation
{

/// One input file of an experiment (custom: the model, channel, actuator channel and settings
/// files) and the hash of its contents.
struct ShardInput
{
  std::string option;  ///< where it came from: "--model", "--channel", "--actuator-channel", "--settings"
  std::string path;
  std::string hash;  ///< FNV-1a 64 of the file's bytes, 16 hex digits
};

/// The contents of a shard file.
struct ShardFile
{
  std::string path;         ///< the file it was read from (for messages); empty for a new shard
  MonteCarloConfig config;  ///< experiment, runs and steps (resolved), seed, custom arguments
  int shard = 1, shards = 1;
  long block_runs = kBlockRuns;
  std::vector<ShardInput> inputs;
  std::string fingerprint;  ///< FNV-1a 64 over the inputs (options, paths and hashes)
  int threads = 1;
  double wall_seconds = 0.0;
  std::vector<CallBlocks> calls;  ///< per runMonteCarlo call of the experiment, in call order
};

/// The most shards an experiment may be split into.
constexpr int kMaxShards = 1000000;

/// Parses "K/N" (decimal, 1 <= K <= N <= kMaxShards). False when the text is not of that form.
bool parseShardSpec(const std::string& text, int& index, int& count);

/// The input files of an experiment with the hashes of their contents (none but for custom).
/// Throws InputError naming a file that cannot be read.
std::vector<ShardInput> hashInputs(const MonteCarloConfig& config);
/// The fingerprint of a list of inputs.
std::string inputsFingerprint(const std::vector<ShardInput>& inputs);

/// Runs shard `index` of `count` of an experiment (errors as runExperiment).
ShardFile runShard(const MonteCarloConfig& config, int index, int count, ProgressCounter* progress = nullptr);

/// "NAME.shard-K-of-N.json".
std::string shardFileName(const std::string& experiment, int index, int count);
/// The shard file's text (JSON through nlohmann/json: each double as the shortest number that reads
/// back to the same bits, the non-finite ones as the strings "nan", "-nan", "inf", "-inf").
std::string shardJson(const ShardFile& shard);
/// Parses and checks a shard file's text. Throws InputError naming `path` and the problem (with
/// the line and column of a syntax error, the line and the field of a wrong value).
ShardFile parseShard(const std::string& text, const std::string& path);
/// Reads and parses a shard file. Throws InputError naming the file.
ShardFile readShard(const std::string& path);
/// Writes DIR/shardFileName(...) atomically (creating DIR) and returns its path.
std::string writeShard(const ShardFile& shard, const std::string& dir);

/// The shard files (NAME.shard-K-of-N.json; with `experiment`, only that NAME) in the directories,
/// sorted by path. Throws InputError for a directory that does not exist or holds no shard file.
std::vector<std::string> findShardFiles(const std::vector<std::string>& dirs, const std::string& experiment = "");

/// Checks that the shards belong together (one experiment, the same runs, steps, seed, N, custom
/// arguments and input fingerprint; every K from 1 to N exactly once; the input files unchanged)
/// and returns the experiment's result as the unsharded run computes it: `threads` is the largest
/// of the shards' and `wall_seconds` their sum. Throws InputError naming the file and the field.
ExperimentResult mergeShards(std::vector<ShardFile> shards);

}  // namespace networked_estimation
