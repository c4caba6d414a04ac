#include "tools/log_csv.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include "base/escape.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/log_records.hpp"
#include "protocol/wire.hpp"
#include "tools/cli_support.hpp"

namespace lagrange::cli {
namespace {

// Text already escaped, as one CSV field: quotes doubled.
std::string QuoteEscaped(const std::string& escaped) {
  std::string q = "\"";
  for (char c : escaped) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// One value as a CSV field: numbers as FormatDouble writes them, ids as RunIdText, text quoted.
void WriteValue(std::ostream& out, LogFieldKind kind, const LogValue& v) {
  switch (kind) {
    case LogFieldKind::kInt: out << std::get<std::int64_t>(v); break;
    case LogFieldKind::kId: out << RunIdText(std::get<std::int64_t>(v)); break;
    case LogFieldKind::kReal: out << FormatDouble(std::get<double>(v)); break;
    case LogFieldKind::kText: out << QuoteEscaped(std::get<std::string>(v)); break;
  }
}

void WriteHeader(std::ostream& out, const std::vector<LogField>& fields) {
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const LogField& f = fields[k];
    if (f.width == 0) out << (k ? "," : "") << f.name;
    for (int i = 0; i < f.width; ++i) out << (k || i ? "," : "") << LogColumnName(f, i);
  }
  out << '\n';
}

void WriteRow(std::ostream& out, const std::vector<LogField>& fields, const LogRow& row) {
  std::size_t v = 0;
  for (const LogField& f : fields) {
    for (int i = 0; i < std::max(f.width, 1); ++i, ++v) {
      if (v) out << ',';
      WriteValue(out, f.kind, row.values[v]);
    }
  }
  out << '\n';
}

std::string SafeFileName(const std::string& channel) {
  std::string s = channel;
  for (char& c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') c = '_';
  }
  return s;
}

// FILE.WHAT.csv for FILE.csv; PATH.WHAT.csv for any other PATH.
std::string BesidePath(const std::string& csv_path, const char* what) {
  constexpr std::string_view csv = ".csv";
  const bool has_csv = csv_path.size() > csv.size() && csv_path.ends_with(csv);
  return (has_csv ? csv_path.substr(0, csv_path.size() - csv.size()) : csv_path) + "." + what + ".csv";
}

}  // namespace

std::string CsvText(const std::string& text) { return QuoteEscaped(Escape(text)); }

std::string JointNamesPath(const std::string& csv_path) { return BesidePath(csv_path, "joints"); }

std::string TaskCsvPath(const std::string& csv_path) { return BesidePath(csv_path, "task"); }

std::string WriteJointNames(const std::string& csv_path, const std::vector<std::string>& names) {
  const std::string path = JointNamesPath(csv_path);
  std::ofstream out(path);
  out << "joint,name\n";
  for (std::size_t i = 0; i < names.size(); ++i) out << i << ',' << CsvText(names[i]) << '\n';
  out.flush();
  if (!out) throw std::runtime_error("cannot write " + path);
  return path;
}

std::string JointColumns(const char* field, int n, const char* separator) {
  std::string columns;
  for (int i = 0; i < n; ++i) columns += std::string(",") + field + separator + std::to_string(i);
  return columns;
}

LogToCsvResult LogToCsv(const std::string& log_path, const std::string& dir, const std::string& channel_regex) {
  struct Output {
    std::ofstream file;
    bool header = false;
  };
  std::map<std::string, Output, std::less<>> outputs;
  LogToCsvResult result;
  bool created = false;
  ReadLogRecords(log_path, channel_regex, [&](const LogRecord& r) {
    if (!created) {  // after the log opened: a log that cannot be read leaves no directory behind
      std::filesystem::create_directories(dir);
      created = true;
    }
    const std::string channel(r.channel);
    if (r.fields == nullptr) {
      ++result.unknown[channel];
      return;
    }
    auto it = outputs.find(channel);
    if (it == outputs.end()) {
      const std::string path = (std::filesystem::path(dir) / (SafeFileName(channel) + ".csv")).string();
      Output o{std::ofstream(path)};
      if (!o.file) throw std::runtime_error("cannot write " + path);
      result.written[channel] = {ToString(r.type), path, 0, 0};
      it = outputs.emplace(channel, std::move(o)).first;
    }
    ChannelCsv& c = result.written[channel];
    if (r.row == nullptr) {
      ++c.skipped;
      return;
    }
    if (!it->second.header) WriteHeader(it->second.file, *r.fields);
    it->second.header = true;
    WriteRow(it->second.file, *r.fields, *r.row);
    ++c.rows;
  });
  if (!created) std::filesystem::create_directories(dir);  // a readable log without events: as with events
  for (auto& [channel, o] : outputs) {
    o.file.flush();
    if (!o.file) throw std::runtime_error("writing " + result.written[channel].path + " failed");
  }
  return result;
}

}  // namespace lagrange::cli
