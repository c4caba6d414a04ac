#include "protocol/lcm_log.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>

#include "base/bounded_file.hpp"
#include "protocol/big_endian.hpp"

namespace lagrange {
namespace {

// LCM's own reader refuses channel lengths outside 1..999 (lcm_eventlog.c).
constexpr std::int32_t kMaxChannelLength = 999;
// Event number, timestamp, channel length, payload length.
constexpr std::size_t kHeaderSize = 8 + 8 + 4 + 4;
constexpr std::int64_t kSyncSize = 4;

}  // namespace

LcmLogReader::LcmLogReader(const std::string& path, std::size_t max_payload) : max_payload_(max_payload) {
  int fd = -1;
  try {
    fd = OpenRegularFile(path);  // a FIFO or a device is refused here, before any read could block
  } catch (const FileReadError& e) {
    throw LcmLogError("cannot read " + path + ": " + e.what());
  }
  struct stat status {};
  if (::fstat(fd, &status) == 0) file_size_ = static_cast<std::int64_t>(status.st_size);
  file_.reset(::fdopen(fd, "rb"));
  if (!file_) {
    ::close(fd);
    throw LcmLogError("cannot read " + path + ": cannot be opened (out of memory)");
  }
  std::uint8_t sync[4];
  if (!Read(sync, sizeof sync) || ReadBigEndian32(sync) != kLcmLogSyncWord) {
    throw LcmLogError(path + " is not an LCM log (no LCM sync word at its start)");
  }
  channel_.reserve(64);
}

bool LcmLogReader::Read(void* out, std::size_t size) {
  const std::size_t got = std::fread(out, 1, size, file_.get());
  offset_ += static_cast<std::int64_t>(got);
  return got == size;
}

const LcmLogEvent* LcmLogReader::EndAt(End end, Part part) {
  end_ = end;
  end_part_ = part;
  end_offset_ = event_offset_;
  return nullptr;
}

// Reads up to and including the next sync word, counting the bytes before
// it. At the end of the file: kClean right after an event, else kTruncated.
bool LcmLogReader::FindSyncWord() {
  std::uint32_t window = 0;
  for (int bytes = 0;; ++bytes) {
    const int c = std::fgetc(file_.get());
    if (c == EOF) {
      event_offset_ = offset_ - bytes;  // the first byte after the last whole event
      if (bytes == 0) {
        end_ = End::kClean;
        end_offset_ = offset_;
      } else {
        EndAt(End::kTruncated, Part::kTrailing);
      }
      return false;
    }
    ++offset_;
    window = (window << 8) | static_cast<std::uint32_t>(c);
    if (bytes >= 3 && window == kLcmLogSyncWord) {
      skipped_ += bytes - 3;
      event_offset_ = offset_ - kSyncSize;
      return true;
    }
  }
}

const LcmLogEvent* LcmLogReader::Next() {
  if (end_ != End::kNotYet) return nullptr;
  // The constructor read the first event's sync word (at byte 0).
  if (!first_ && !FindSyncWord()) return nullptr;
  first_ = false;
  std::uint8_t header[kHeaderSize];
  if (!Read(header, sizeof header)) return EndAt(End::kTruncated, Part::kHeader);
  const auto channel_length = static_cast<std::int32_t>(ReadBigEndian32(header + 16));
  const auto payload_length = static_cast<std::int32_t>(ReadBigEndian32(header + 20));
  if (channel_length < 1 || channel_length > kMaxChannelLength) {
    declared_ = channel_length;
    return EndAt(End::kCorrupt, Part::kChannelLength);
  }
  if (payload_length < 0) {
    declared_ = payload_length;
    return EndAt(End::kCorrupt, Part::kPayloadLength);
  }
  channel_.resize(static_cast<std::size_t>(channel_length));
  if (!Read(channel_.data(), channel_.size())) {
    declared_ = channel_length;
    return EndAt(End::kTruncated, Part::kChannel);
  }
  const auto size = static_cast<std::size_t>(payload_length);
  declared_ = payload_length;
  event_.number = static_cast<std::int64_t>(ReadBigEndian64(header));
  event_.utime = static_cast<std::int64_t>(ReadBigEndian64(header + 8));
  event_.channel = channel_;
  event_.oversized = size > max_payload_;
  if (event_.oversized) {
    ++oversized_;
    // Passed over unread; a log that ends inside it is truncated.
    if (std::fseek(file_.get(), static_cast<long>(size) - 1, SEEK_CUR) != 0 || std::fgetc(file_.get()) == EOF) {
      held_ = std::clamp<std::int64_t>(file_size_ - offset_, 0, static_cast<std::int64_t>(size) - 1);
      return EndAt(End::kTruncated, Part::kPayload);
    }
    offset_ += static_cast<std::int64_t>(size);
    event_.data = nullptr;
    event_.size = 0;
    return &event_;
  }
  payload_.resize(size);
  const std::int64_t before = offset_;
  if (!Read(payload_.data(), size)) {
    held_ = offset_ - before;
    return EndAt(End::kTruncated, Part::kPayload);
  }
  event_.data = payload_.data();
  event_.size = size;
  return &event_;
}

std::string LcmLogReader::EndReason() const {
  if (end_ != End::kTruncated && end_ != End::kCorrupt) return "";
  const std::string at = std::to_string(end_offset_);
  switch (end_part_) {
    case Part::kHeader: return "cut short inside the event at byte " + at + " (in its header)";
    case Part::kChannel:
      return "cut short inside the event at byte " + at + " (in its " + std::to_string(declared_) +
             "-byte channel name)";
    case Part::kPayload:
      return "cut short inside the event at byte " + at + ": it declares a " + std::to_string(declared_) +
             "-byte payload, of which the file holds " + std::to_string(held_);
    case Part::kTrailing:
      return "cut short: the " + std::to_string(offset_ - end_offset_) + " bytes from byte " + at +
             " to the end hold no whole event";
    case Part::kChannelLength:
      return "the event at byte " + at + " declares a " + std::to_string(declared_) +
             "-byte channel name (an LCM log's are 1 to " + std::to_string(kMaxChannelLength) + " bytes)";
    case Part::kPayloadLength:
      return "the event at byte " + at + " declares a payload of " + std::to_string(declared_) + " bytes";
  }
  return "";
}

}  // namespace lagrange
