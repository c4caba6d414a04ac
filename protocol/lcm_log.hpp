#pragma once
// Reading lcm-logger files (LCM's event log), event by event, as warily as
// the bus: only a regular file is opened (a FIFO would block, a device never
// end: base/bounded_file.hpp), every length is checked before anything is
// read or allocated, a payload larger than the reader's bound is passed over
// unread, and a log cut short (a logger stopped or still writing) ends at its
// last whole event, the reader saying where (EndReason).
//
// The format, big-endian, event after event from the file's first byte:
//   sync word 0xEDA1DA01 (u32), event number (i64), timestamp (i64, µs since
//   the epoch, when the logger received it), channel length (i32, 1-999),
//   payload length (i32, >= 0), the channel (no NUL), the payload.
// As LCM's own reader does, a missing sync word between events is searched
// for byte by byte; a length out of range ends the log.
//
// What the payloads are is protocol/wire.hpp's to say (TypeOf, Check*Packet):
// a recorded packet is as untrusted as a live one.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/bus.hpp"

namespace lagrange {

struct LcmLogError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A log that ends inside an event (LcmLogReader::End::kTruncated): cut short
// by a logger that stopped, or one still writing; what came before is whole.
struct LcmLogCutShortError : LcmLogError {
  using LcmLogError::LcmLogError;
};

// The sync word every event starts with.
inline constexpr std::uint32_t kLcmLogSyncWord = 0xEDA1DA01;

struct LcmLogEvent {
  std::int64_t number = 0;  // the logger's event number
  std::int64_t utime = 0;   // when the logger received it, µs since the epoch
  std::string_view channel;
  const std::uint8_t* data = nullptr;  // the payload (null when oversized)
  std::size_t size = 0;                // its bytes (0 when oversized)
  bool oversized = false;              // over the reader's bound: passed over unread
};

class LcmLogReader {
 public:
  // Opens `path` and checks that it starts with the sync word. Throws
  // LcmLogError, one line: "cannot read PATH: cannot be opened (No such file
  // or directory)", "cannot read PATH: not a regular file (a FIFO)", ..., or
  // "PATH is not an LCM log (no LCM sync word at its start)". Payloads over
  // `max_payload` bytes (by default the largest message lagrange sends or
  // accepts) are passed over.
  explicit LcmLogReader(const std::string& path, std::size_t max_payload = kMaxMessageSize);

  // The next event, valid until the next call; null at the end of the log.
  const LcmLogEvent* Next();

  // How the log ended, once Next has returned null.
  enum class End : std::uint8_t {
    kNotYet,     // Next has not returned null
    kClean,      // after a whole event
    kTruncated,  // inside an event: the logger stopped (or is still writing)
    kCorrupt,    // a channel or payload length out of range
  };
  End end() const { return end_; }
  // Once the log ended: where, in bytes from the file's start. kTruncated and
  // kCorrupt: the event it ended in (its sync word; for trailing bytes that
  // hold no sync word, the first of them); kClean: the file's end.
  std::int64_t end_offset() const { return end_offset_; }
  // Why a log ended kTruncated or kCorrupt, one line naming the byte offset:
  // "cut short inside the event at byte 1234: it declares a 2147483647-byte
  // payload, of which the file holds 8", "the event at byte 24 declares a
  // 5000-byte channel name (an LCM log's are 1 to 999 bytes)". Empty
  // otherwise. (Made here, not in Next, which allocates nothing.)
  std::string EndReason() const;
  std::int64_t events_oversized() const { return oversized_; }
  std::int64_t bytes_skipped() const { return skipped_; }  // searching for a sync word

 private:
  // What of an event the log ended in (EndReason's wording).
  enum class Part : std::uint8_t { kHeader, kChannel, kPayload, kTrailing, kChannelLength, kPayloadLength };
  bool Read(void* out, std::size_t size);
  bool FindSyncWord();
  // Ends the log as `end` in `part` of the current event; returns null for Next.
  const LcmLogEvent* EndAt(End end, Part part);

  struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, FileCloser> file_;
  std::size_t max_payload_;
  std::int64_t file_size_ = 0;     // bytes, when opened
  std::int64_t offset_ = 0;        // bytes read (or passed over) so far
  std::int64_t event_offset_ = 0;  // the current event's sync word
  bool first_ = true;
  End end_ = End::kNotYet;
  Part end_part_ = Part::kHeader;
  std::int64_t end_offset_ = 0;
  std::int64_t declared_ = 0;  // the length the event declared, of its channel or payload
  std::int64_t held_ = 0;      // bytes of its payload the file holds
  std::int64_t oversized_ = 0;
  std::int64_t skipped_ = 0;
  std::string channel_;
  std::vector<std::uint8_t> payload_;
  LcmLogEvent event_;
};

}  // namespace lagrange
