// Reading the message headers of a ROS bag, format 2.0 (ros_bag.hpp). The format: after the line
// "#ROSBAG V2.0\n", records of [uint32 header length][header][uint32 data length][data], the header
// a list of [uint32 length]["name=value"] fields, integers little-endian. Record types (field op):
// 0x03 the bag header (index_pos: where the index section starts), 0x05 a chunk (compression,
// size; its data: message data and connection records, compressed), 0x04 a chunk's index, 0x07 a
// connection (conn, topic; its data: the connection header with type, md5sum, message_definition),
// 0x06 chunk information (chunk_pos, and per connection its message count in the chunk), 0x02
// message data (conn, time: the record time as uint32 seconds + uint32 nanoseconds).
#include "networked_estimation/io/ros_bag.hpp"

#include <bzlib.h>
#include <lz4frame.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <unordered_map>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace ros_bag_detail
{

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicLength = 13;
constexpr std::uint8_t kOpMessage = 0x02, kOpBagHeader = 0x03, kOpChunk = 0x05, kOpChunkInfo = 0x06,
                       kOpConnection = 0x07;

std::uint32_t u32(const char* p)
{
  std::uint32_t v;
  std::memcpy(&v, p, 4);  // the bag is little-endian, as every machine this builds on
  return v;
}

std::uint64_t u64(const char* p)
{
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

double timeOf(const char* p)
{
  return static_cast<double>(u32(p)) + 1e-9 * static_cast<double>(u32(p + 4));
}

/// The fields of a record header (or of a connection header): name -> value bytes.
struct Fields
{
  std::vector<std::pair<std::string, std::string>> items;
  const std::string* find(const char* name) const
  {
    for (const auto& f : items)
      if (f.first == name)
        return &f.second;
    return nullptr;
  }
};

class Failure
{
public:
  Failure(const std::string& path) : path_(path) {}
  [[noreturn]] void operator()(std::uint64_t offset, const std::string& problem) const
  {
    throw InputError(path_ + ": byte " + std::to_string(offset) + ": " + problem);
  }
  [[noreturn]] void operator()(const std::string& problem) const { throw InputError(path_ + ": " + problem); }

private:
  std::string path_;
};

Fields parseFields(const char* p, std::size_t n, std::uint64_t offset, const Failure& fail)
{
  Fields out;
  std::size_t i = 0;
  while (i < n)
  {
    if (n - i < 4)
      fail(offset + i, "record header ends inside a field length");
    const std::uint32_t len = u32(p + i);
    i += 4;
    if (len > n - i)
      fail(offset + i, "record header field of " + std::to_string(len) + " bytes runs past the header's end");
    const char* f = p + i;
    const char* eq = static_cast<const char*>(std::memchr(f, '=', len));
    if (!eq)
      fail(offset + i, "record header field without '='");
    out.items.emplace_back(std::string(f, eq), std::string(eq + 1, f + len));
    i += len;
  }
  return out;
}

std::uint32_t fieldU32(const Fields& f, const char* name, std::uint64_t offset, const Failure& fail)
{
  const std::string* v = f.find(name);
  if (!v || v->size() != 4)
    fail(offset, std::string("record without a 4-byte field '") + name + "'");
  return u32(v->data());
}

std::uint64_t fieldU64(const Fields& f, const char* name, std::uint64_t offset, const Failure& fail)
{
  const std::string* v = f.find(name);
  if (!v || v->size() != 8)
    fail(offset, std::string("record without an 8-byte field '") + name + "'");
  return u64(v->data());
}

std::uint8_t opOf(const Fields& f, std::uint64_t offset, const Failure& fail)
{
  const std::string* v = f.find("op");
  if (!v || v->size() != 1)
    fail(offset, "record without its type (field 'op')");
  return static_cast<std::uint8_t>((*v)[0]);
}

/// The file read in pieces, with the byte offsets of what was read kept for the messages.
class BagFile
{
public:
  BagFile(const std::string& path, const Failure& fail) : in_(path, std::ios::binary), fail_(fail)
  {
    if (!in_)
      fail_("cannot open file");
    in_.seekg(0, std::ios::end);
    size_ = static_cast<std::uint64_t>(in_.tellg());
    in_.seekg(0);
  }
  std::uint64_t size() const { return size_; }

  void read(std::uint64_t offset, std::size_t n, std::vector<char>& out, const char* what)
  {
    if (offset > size_ || n > size_ - offset)
      fail_(offset, std::string("file ends inside ") + what + " (a truncated bag: `rosbag reindex` may recover it)");
    out.resize(n);
    in_.seekg(static_cast<std::streamoff>(offset));
    in_.read(out.data(), static_cast<std::streamsize>(n));
    if (!in_)
      fail_(offset, std::string("cannot read ") + what);
  }

  /// The record at `offset`: its header fields, where its data starts and its data length.
  struct Record
  {
    Fields fields;
    std::uint8_t op = 0;
    std::uint64_t data_offset = 0;
    std::uint32_t data_length = 0;
  };
  Record record(std::uint64_t offset)
  {
    Record r;
    read(offset, 4, buffer_, "a record's header length");
    const std::uint32_t hl = u32(buffer_.data());
    read(offset + 4, static_cast<std::size_t>(hl) + 4, buffer_, "a record's header");
    r.fields = parseFields(buffer_.data(), hl, offset + 4, fail_);
    r.op = opOf(r.fields, offset, fail_);
    r.data_length = u32(buffer_.data() + hl);
    r.data_offset = offset + 8 + hl;
    if (r.data_offset + r.data_length > size_)
      fail_(offset, "record's data runs past the end of the file (a truncated bag: `rosbag reindex` may recover it)");
    return r;
  }

private:
  std::ifstream in_;
  const Failure& fail_;
  std::uint64_t size_ = 0;
  std::vector<char> buffer_;
};

BagConnection connectionOf(const Fields& record_fields, const char* data, std::uint32_t length, std::uint64_t offset,
                           const Failure& fail)
{
  BagConnection c;
  c.id = fieldU32(record_fields, "conn", offset, fail);
  const std::string* topic = record_fields.find("topic");
  if (!topic)
    fail(offset, "connection record without a topic");
  c.topic = *topic;
  const Fields h = parseFields(data, length, offset, fail);
  for (const auto& f : h.items)
  {
    if (f.first == "type")
      c.type = f.second;
    else if (f.first == "md5sum")
      c.md5sum = f.second;
    else if (f.first == "message_definition")
      c.definition = f.second;
    else if (f.first == "callerid")
      c.callerid = f.second;
  }
  c.has_header = definitionStartsWithHeader(c.definition);
  return c;
}

void decompress(const std::string& compression, const std::vector<char>& in, std::uint32_t size, std::vector<char>& out,
                std::uint64_t offset, const Failure& fail)
{
  out.resize(size);
  if (compression == "bz2")
  {
    unsigned int n = size;
    const int rc = BZ2_bzBuffToBuffDecompress(out.data(), &n, const_cast<char*>(in.data()),
                                              static_cast<unsigned int>(in.size()), 0, 0);
    if (rc != BZ_OK || n != size)
      fail(offset, "bz2 chunk does not decompress to its " + std::to_string(size) + " bytes (bzip2 error " +
                       std::to_string(rc) + ")");
    return;
  }
  // lz4: rosbag's roslz4 writes the LZ4 frame format.
  LZ4F_dctx* ctx = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)))
    fail(offset, "cannot start an lz4 decompression");
  std::size_t done_in = 0, done_out = 0;
  std::size_t rc = 1;
  while (rc != 0 && done_in < in.size() && done_out <= size)
  {
    std::size_t n_out = size - done_out, n_in = in.size() - done_in;
    rc = LZ4F_decompress(ctx, out.data() + done_out, &n_out, in.data() + done_in, &n_in, nullptr);
    if (LZ4F_isError(rc))
    {
      const std::string name = LZ4F_getErrorName(rc);
      LZ4F_freeDecompressionContext(ctx);
      fail(offset, "lz4 chunk does not decompress: " + name);
    }
    if (n_in == 0 && n_out == 0)
      break;
    done_in += n_in;
    done_out += n_out;
  }
  LZ4F_freeDecompressionContext(ctx);
  if (done_out != size)
    fail(offset,
         "lz4 chunk decompresses to " + std::to_string(done_out) + " bytes, its header says " + std::to_string(size));
}

}  // namespace ros_bag_detail

bool definitionStartsWithHeader(const std::string& definition)
{
  std::size_t at = 0;
  while (at < definition.size())
  {
    std::size_t end = definition.find('\n', at);
    if (end == std::string::npos)
      end = definition.size();
    std::string line = definition.substr(at, end - at);
    at = end + 1;
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos)
      line.erase(hash);
    const std::size_t b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos)
      continue;
    const std::size_t e = line.find_first_of(" \t", b);
    const std::string type = line.substr(b, e == std::string::npos ? std::string::npos : e - b);
    return type == "Header" || type == "std_msgs/Header";
  }
  return false;
}

RosBag::RosBag(const std::string& path) : path_(path)
{
  using namespace ros_bag_detail;
  const Failure fail(path);
  BagFile file(path, fail);
  std::vector<char> buf;
  if (file.size() < kMagicLength)
    fail("not a ROS bag: the file is " + std::to_string(file.size()) + " bytes long, shorter than its first line");
  file.read(0, kMagicLength, buf, "the first line");
  if (std::memcmp(buf.data(), kMagic, kMagicLength) != 0)
  {
    const std::string first(buf.begin(), std::find(buf.begin(), buf.end(), '\n'));
    if (first.rfind("#ROSBAG V", 0) == 0)
      fail("ROS bag of format " + first.substr(9) + ": only format 2.0 is read (`rosbag fix` converts older bags)");
    fail("not a ROS bag: expected the first line '#ROSBAG V2.0'");
  }
  const BagFile::Record header = file.record(kMagicLength);
  if (header.op != kOpBagHeader)
    fail(kMagicLength, "expected the bag header record (op 3), found op " + std::to_string(header.op));
  const std::uint64_t index_pos = fieldU64(header.fields, "index_pos", kMagicLength, fail);
  if (index_pos == 0 || index_pos > file.size())
    fail(
        "the bag has no index (a recording that did not end cleanly, e.g. a .bag.active file): run "
        "`rosbag reindex` on it first");
  indexed_ = true;
  data_end_ = index_pos;
  std::set<std::string> compressions;
  std::uint64_t at = index_pos;
  std::set<std::uint32_t> ids;
  while (at < file.size())
  {
    const BagFile::Record r = file.record(at);
    if (r.op == kOpConnection)
    {
      file.read(r.data_offset, r.data_length, buf, "a connection record");
      BagConnection c = connectionOf(r.fields, buf.data(), r.data_length, at, fail);
      if (ids.insert(c.id).second)
        connections_.push_back(std::move(c));
    }
    else if (r.op == kOpChunkInfo)
    {
      Chunk chunk;
      chunk.pos = fieldU64(r.fields, "chunk_pos", at, fail);
      const std::uint32_t count = fieldU32(r.fields, "count", at, fail);
      file.read(r.data_offset, r.data_length, buf, "a chunk information record");
      if (r.data_length < 8ull * count)
        fail(at, "chunk information record lists " + std::to_string(count) + " connections in " +
                     std::to_string(r.data_length) + " bytes");
      for (std::uint32_t i = 0; i < count; ++i)
        chunk.connections.push_back(u32(buf.data() + 8 * i));
      chunks_.push_back(std::move(chunk));
    }
    at = r.data_offset + r.data_length;
  }
  std::sort(chunks_.begin(), chunks_.end(), [](const Chunk& a, const Chunk& b) { return a.pos < b.pos; });
  for (const Chunk& c : chunks_)
  {
    const BagFile::Record r = file.record(c.pos);
    if (r.op != kOpChunk)
      fail(c.pos, "the index points at a record of op " + std::to_string(r.op) + ", not a chunk");
    const std::string* comp = r.fields.find("compression");
    compressions.insert(comp ? *comp : std::string("?"));
  }
  compression_ = compressions.empty() ? "none" : compressions.size() == 1 ? *compressions.begin() : "mixed";
}

std::vector<std::string> RosBag::topics() const
{
  std::set<std::string> t;
  for (const BagConnection& c : connections_)
    t.insert(c.topic);
  return std::vector<std::string>(t.begin(), t.end());
}

std::vector<BagTopicHeaders> RosBag::headers(const std::vector<std::string>& topics) const
{
  using namespace ros_bag_detail;
  const Failure fail(path_);
  std::vector<BagTopicHeaders> out(topics.size());
  std::unordered_map<std::uint32_t, std::size_t> wanted;  // connection -> index into out
  for (std::size_t i = 0; i < topics.size(); ++i)
  {
    out[i].topic = topics[i];
    bool found = false;
    for (const BagConnection& c : connections_)
    {
      if (c.topic != topics[i])
        continue;
      if (found && (c.type != out[i].type))
        fail("topic " + topics[i] + " has two types in the bag (" + out[i].type + " and " + c.type + ")");
      found = true;
      out[i].type = c.type;
      out[i].has_header = c.has_header;
      wanted[c.id] = i;
    }
    if (!found)
    {
      std::string names;
      for (const std::string& t : this->topics())
        names += (names.empty() ? "" : ", ") + t;
      fail("no topic " + topics[i] + " in the bag (its topics: " + (names.empty() ? "none" : names) + ")");
    }
  }
  BagFile file(path_, fail);
  std::vector<char> raw, plain;
  for (const Chunk& chunk : chunks_)
  {
    if (std::none_of(chunk.connections.begin(), chunk.connections.end(),
                     [&](std::uint32_t c) { return wanted.count(c) > 0; }))
      continue;
    const BagFile::Record r = file.record(chunk.pos);
    const std::string* comp = r.fields.find("compression");
    const std::uint32_t size = fieldU32(r.fields, "size", chunk.pos, fail);
    const std::string compression = comp ? *comp : "none";
    if (compression != "none" && compression != "bz2" && compression != "lz4")
      fail(chunk.pos, "chunk compressed with '" + compression + "': expected none, bz2 or lz4");
    const std::vector<char>* data = &raw;
    file.read(r.data_offset, r.data_length, raw, "a chunk");
    if (compression != "none")
    {
      decompress(compression, raw, size, plain, chunk.pos, fail);
      data = &plain;
    }
    else if (r.data_length != size)
      fail(chunk.pos, "uncompressed chunk of " + std::to_string(r.data_length) + " bytes, its header says " +
                          std::to_string(size));
    // The chunk's records: message data and connections. Only a message's fields op, conn and time
    // and the first 12 bytes of its data are read.
    const char* p = data->data();
    const std::size_t n = data->size();
    std::size_t i = 0;
    while (i < n)
    {
      const std::uint64_t where = chunk.pos;  // offsets inside a decompressed chunk name the chunk
      if (n - i < 4)
        fail(where, "chunk ends inside a record's header length");
      const std::uint32_t hl = u32(p + i);
      if (hl > n - i - 4 || n - i - 4 - hl < 4)
        fail(where, "chunk ends inside a record's header");
      const char* h = p + i + 4;
      const std::uint32_t dl = u32(h + hl);
      const char* d = h + hl + 4;
      if (dl > n - (static_cast<std::size_t>(d - p)))
        fail(where, "a record's data runs past the chunk's end");
      int op = -1;
      std::uint32_t conn = 0;
      const char* time = nullptr;
      for (std::size_t j = 0; j < hl;)
      {
        if (hl - j < 4)
          fail(where, "a record header ends inside a field length");
        const std::uint32_t fl = u32(h + j);
        const char* f = h + j + 4;
        if (fl > hl - j - 4)
          fail(where, "a record header field runs past the header's end");
        if (fl == 4 && std::memcmp(f, "op=", 3) == 0)
          op = static_cast<std::uint8_t>(f[3]);
        else if (fl == 9 && std::memcmp(f, "conn=", 5) == 0)
          conn = u32(f + 5);
        else if (fl == 13 && std::memcmp(f, "time=", 5) == 0)
          time = f + 5;
        j += 4 + fl;
      }
      if (op == kOpMessage)
      {
        const auto w = wanted.find(conn);
        if (w != wanted.end())
        {
          if (!time)
            fail(where, "message record without its time");
          BagTopicHeaders& t = out[w->second];
          t.receipt.push_back(timeOf(time));
          if (t.has_header)
          {
            if (dl < 12)
              fail(where, "a message of " + t.topic + " (" + t.type + ") has " + std::to_string(dl) +
                              " bytes, too few for its header");
            t.seq.push_back(u32(d));
            t.stamp.push_back(timeOf(d + 4));
          }
        }
      }
      else if (op != kOpConnection)
        fail(where, "a record of op " + std::to_string(op) + " inside a chunk (expected messages and connections)");
      i = static_cast<std::size_t>(d - p) + dl;
    }
  }
  return out;
}

}  // namespace networked_estimation
