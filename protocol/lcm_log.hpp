#pragma once
// Reading lcm-logger files (LCM's event log), event by event, as warily as
// the bus: every length is checked before anything is read or allocated, a
// payload larger than the reader's bound is passed over unread, and a log cut
// short (a logger stopped or still writing) ends at its last whole event.
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
  // LcmLogError, one line: "cannot read PATH", or "PATH is not an LCM log (no
  // LCM sync word at its start)". Payloads over `max_payload` bytes (by default
  // the largest message lagrange sends or accepts) are passed over.
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
  std::int64_t events_oversized() const { return oversized_; }
  std::int64_t bytes_skipped() const { return skipped_; }  // searching for a sync word

 private:
  bool Read(void* out, std::size_t size);
  bool FindSyncWord();

  struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, FileCloser> file_;
  std::size_t max_payload_;
  bool first_ = true;
  End end_ = End::kNotYet;
  std::int64_t oversized_ = 0;
  std::int64_t skipped_ = 0;
  std::string channel_;
  std::vector<std::uint8_t> payload_;
  LcmLogEvent event_;
};

}  // namespace lagrange
