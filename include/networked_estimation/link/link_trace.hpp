// A recorded link: the messages one topic sent over it (their header stamps, header.seq when the
// publisher sets it, and the times the recorder received them), and the expected messages found in
// them (the slots): which arrived, their delays, the duplicates and the reordering. The input of
// the link fits (link_fit.hpp), of fit_link and analyze --bag, and of the trace-driven LossyChannel
// (`model: trace`). ROS-free: bags are read by io/ros_bag.hpp.
//
// Finding the expected messages. The slots run from the first message received to the last (what
// was lost before or after them cannot be seen). With header.seq, slot = seq - the first seq,
// when the sequence numbers increase with the stamps in 99 % of the steps, run from the first
// stamp's number to the last's, and count the stamps' periods (one number per typical stamp step,
// within 1 %; how far single steps go is not asked: a sender late by a few periods that catches up
// still numbers its messages one by one); else they are not used and the summary says why (a
// restart, several publishers, or a relay: every roscpp publisher writes its own count into
// header.seq, which then hides the losses before it). Otherwise from the stamps against the period:
// the period is learnt from the stamps (the steps between consecutive distinct stamps are whole
// multiples of it; --rate gives it instead, and a rate the stamps contradict is refused), and each
// message lies round(step / period) slots after the one before it, so stamp jitter of up to a fifth
// of a period (a step then errs by less than 0.4 periods) and a slow drift of the sender's clock
// are tolerated; more than 5 % of steps further than 0.4 periods from a whole number of periods
// are refused as not periodic. A copy of a slot received before
// (same seq, or the same stamp) is a duplicate; a message received after one of a later slot is
// reordered. The delay of a slot is its first copy's receipt time minus its stamp, less the clock
// offset (below).
//
// Clocks. receipt - stamp is the delay only when the sender's and the recorder's clocks agree.
// When they differ by an unknown constant, only the delay relative to the smallest one is
// identifiable: the offset is then taken as the smallest receipt - stamp and the delays reported
// relative to it. ClockMode::AUTO decides by the sign: a negative receipt - stamp means the clocks
// differ.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace networked_estimation
{

/// The messages of one link as recorded, in the order received.
struct LinkRecord
{
  std::string source;              ///< e.g. "run.bag, topic /gps" or "trace.csv"
  std::vector<double> stamp;       ///< header.stamp (s)
  std::vector<double> receipt;     ///< when the recorder received it (s)
  std::vector<std::uint32_t> seq;  ///< header.seq (empty: not known)
};

/// Reads a trace CSV: a header line naming the columns stamp and receipt (and optionally seq), in
/// any order, then one message per line (seconds; seq a non-negative integer). Throws InputError
/// naming the file, the line and the column.
LinkRecord readLinkCsv(const std::string& path);
/// Writes a record as a trace CSV (stamp,receipt,seq; seq only when known), numbers exact.
void writeLinkCsv(const LinkRecord& record, const std::string& path);

/// The records of several topics of a ROS bag, one bag reading for all. Throws InputError naming
/// the bag and the topic: no such topic (listing the bag's topics), or a type without a header.
std::vector<LinkRecord> readBagLinks(const std::string& path, const std::vector<std::string>& topics);

enum class ClockMode
{
  AUTO,      ///< same clock unless some receipt precedes its stamp
  SAME,      ///< the delays are receipt - stamp (negative ones refused)
  DIFFERENT  ///< unknown offset: delays relative to the smallest
};

/// "auto" / "same" / "different" -> ClockMode; throws InputError naming `what` otherwise.
ClockMode clockModeOf(const std::string& text, const std::string& what);

struct TraceOptions
{
  double rate = 0.0;  ///< expected messages per second; 0: learnt from the stamps
  ClockMode clock = ClockMode::AUTO;
  bool use_seq = true;            ///< use header.seq when it agrees with the stamps
  std::size_t min_messages = 50;  ///< fewer received messages are refused
};

/// The expected messages of a link (its slots) and what happened to each.
struct SlotTrace
{
  std::string source;
  double period = 0.0;       ///< s between expected messages
  double first_stamp = 0.0;  ///< the stamp of slot 0
  std::string slots_from;  ///< "header.seq", "the stamps (rate learnt)", "the stamps (--rate)", "the channel's events"
  std::string note;        ///< why header.seq was not used, or ""
  std::size_t messages = 0;           ///< records read (copies included)
  std::size_t duplicates = 0;         ///< copies of a slot already received
  std::size_t reordered = 0;          ///< first copies received after a later slot's
  std::vector<std::uint8_t> arrived;  ///< per slot: 1 received, 0 lost
  std::vector<double> delay;  ///< per slot: the first copy's delay (s, relative to the clock offset); 0 when lost
  std::vector<std::uint8_t> copies;  ///< per slot: copies received (0 lost, capped at 255)
  /// The slots of the first copies in the order they were received (RFC 3550's jitter follows it).
  std::vector<std::size_t> receipt_order;
  double clock_offset = 0.0;    ///< subtracted from receipt - stamp
  bool relative_delay = false;  ///< the clocks differ: delays relative to the smallest
  std::string clock_note;       ///< what was decided about the clocks and why

  std::size_t slots() const { return arrived.size(); }
  std::size_t received() const;
};

/// The slots of a record. Throws InputError naming the source: fewer than min_messages messages,
/// stamps that are zero, not finite or not periodic, a rate the stamps contradict, negative delays
/// with ClockMode::SAME.
SlotTrace analyseLink(const LinkRecord& record, const TraceOptions& options);

/// The slots of a LossyChannel's ~events recorded with `rostopic echo -p` (networked_estimation/
/// ChannelEvent): one slot per offered message (its field.seq), received when field.outcome is 0,
/// its delay field.delay, a copy when field.duplicated. Throws InputError naming file, line and
/// column (missing columns, a gap in field.seq, bad values).
SlotTrace readEventSlots(const std::string& path, std::size_t min_messages = 50);

/// True when the CSV file's header names ChannelEvent's columns (field.outcome): a ~events record.
bool isEventsCsv(const std::string& path);

}  // namespace networked_estimation
