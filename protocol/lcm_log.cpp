#include "protocol/lcm_log.hpp"

#include "protocol/big_endian.hpp"

namespace lagrange {
namespace {

// LCM's own reader refuses channel lengths outside 1..999 (lcm_eventlog.c).
constexpr std::int32_t kMaxChannelLength = 999;
// Event number, timestamp, channel length, payload length.
constexpr std::size_t kHeaderSize = 8 + 8 + 4 + 4;

}  // namespace

LcmLogReader::LcmLogReader(const std::string& path, std::size_t max_payload)
    : file_(std::fopen(path.c_str(), "rb")), max_payload_(max_payload) {
  if (!file_) throw LcmLogError("cannot read " + path);
  std::uint8_t sync[4];
  if (!Read(sync, sizeof sync) || ReadBigEndian32(sync) != kLcmLogSyncWord) {
    throw LcmLogError(path + " is not an LCM log (no LCM sync word at its start)");
  }
  channel_.reserve(64);
}

bool LcmLogReader::Read(void* out, std::size_t size) { return std::fread(out, 1, size, file_.get()) == size; }

// Reads up to and including the next sync word, counting the bytes before
// it. At the end of the file: kClean right after an event, else kTruncated.
bool LcmLogReader::FindSyncWord() {
  std::uint32_t window = 0;
  for (int bytes = 0;; ++bytes) {
    const int c = std::fgetc(file_.get());
    if (c == EOF) {
      end_ = bytes == 0 ? End::kClean : End::kTruncated;
      return false;
    }
    window = (window << 8) | static_cast<std::uint32_t>(c);
    if (bytes >= 3 && window == kLcmLogSyncWord) {
      skipped_ += bytes - 3;
      return true;
    }
  }
}

const LcmLogEvent* LcmLogReader::Next() {
  if (end_ != End::kNotYet) return nullptr;
  // The constructor read the first event's sync word.
  if (!first_ && !FindSyncWord()) return nullptr;
  first_ = false;
  std::uint8_t header[kHeaderSize];
  if (!Read(header, sizeof header)) {
    end_ = End::kTruncated;
    return nullptr;
  }
  const auto channel_length = static_cast<std::int32_t>(ReadBigEndian32(header + 16));
  const auto payload_length = static_cast<std::int32_t>(ReadBigEndian32(header + 20));
  if (channel_length < 1 || channel_length > kMaxChannelLength || payload_length < 0) {
    end_ = End::kCorrupt;
    return nullptr;
  }
  channel_.resize(static_cast<std::size_t>(channel_length));
  if (!Read(channel_.data(), channel_.size())) {
    end_ = End::kTruncated;
    return nullptr;
  }
  const auto size = static_cast<std::size_t>(payload_length);
  event_.number = static_cast<std::int64_t>(ReadBigEndian64(header));
  event_.utime = static_cast<std::int64_t>(ReadBigEndian64(header + 8));
  event_.channel = channel_;
  event_.oversized = size > max_payload_;
  if (event_.oversized) {
    ++oversized_;
    // Passed over unread; a log that ends inside it is truncated.
    if (std::fseek(file_.get(), static_cast<long>(size) - 1, SEEK_CUR) != 0 || std::fgetc(file_.get()) == EOF) {
      end_ = End::kTruncated;
      return nullptr;
    }
    event_.data = nullptr;
    event_.size = 0;
    return &event_;
  }
  payload_.resize(size);
  if (!Read(payload_.data(), size)) {
    end_ = End::kTruncated;
    return nullptr;
  }
  event_.data = payload_.data();
  event_.size = size;
  return &event_;
}

}  // namespace lagrange
