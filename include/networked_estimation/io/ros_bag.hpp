// Reading the message headers of a ROS bag (format 2.0) without ROS: the connections (topic, type,
// definition) and, per message of the topics asked for, the time the recorder received it and the
// `header.seq` and `header.stamp` at the start of its data. Nothing else of a message is read:
// the chunks are decompressed (none, bz2, lz4) and walked record by record, and of each message
// record only its header fields and the first 12 bytes of its data are looked at.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace networked_estimation
{

/// One connection record of a bag (a topic as one publisher gave it).
struct BagConnection
{
  std::uint32_t id = 0;
  std::string topic, type, md5sum, definition, callerid;
  /// The message definition's first field is a std_msgs/Header (so seq and stamp lead its data).
  bool has_header = false;
};

/// The messages of one topic, in the bag's record order: the receipt (record) time and, when the
/// type starts with a std_msgs/Header, its seq and stamp (s since the epoch).
struct BagTopicHeaders
{
  std::string topic, type;
  bool has_header = false;
  std::vector<double> receipt, stamp;
  std::vector<std::uint32_t> seq;
};

/// A bag file, its index read at construction (connections and chunks). Throws InputError naming
/// the file and the byte offset for a file that is not a bag of format 2.0, is truncated, or uses
/// an unknown compression.
class RosBag
{
public:
  explicit RosBag(const std::string& path);

  const std::string& path() const { return path_; }
  const std::vector<BagConnection>& connections() const { return connections_; }
  /// The topics of the bag, sorted, once each.
  std::vector<std::string> topics() const;
  /// "none", "bz2", "lz4" or "mixed" (of the chunks).
  const std::string& compression() const { return compression_; }
  std::size_t chunks() const { return chunks_.size(); }

  /// The headers of every message on `topics` (result i for topics[i]). Throws InputError when a
  /// topic is not in the bag (naming the topics it has) or a message is too short for a header.
  /// A topic whose type has no header gives has_header = false and no seq / stamp (the caller
  /// decides whether that is an error).
  std::vector<BagTopicHeaders> headers(const std::vector<std::string>& topics) const;

private:
  struct Chunk
  {
    std::uint64_t pos = 0;
    std::vector<std::uint32_t> connections;  ///< the connections with messages in the chunk
  };
  std::string path_;
  std::vector<BagConnection> connections_;
  std::vector<Chunk> chunks_;
  bool indexed_ = false;
  std::uint64_t data_end_ = 0;  ///< where the chunk section ends (the index position, or the file's end)
  std::string compression_;
};

/// True when a message definition's first field is a std_msgs/Header ("Header header").
bool definitionStartsWithHeader(const std::string& definition);

}  // namespace networked_estimation
