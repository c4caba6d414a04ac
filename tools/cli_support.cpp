#include "tools/cli_support.hpp"

#include <charconv>
#include <vector>

#include "plant/plant_spec.hpp"

namespace lagrange::cli {

VectorXd ParseNumberList(std::string_view option, std::string_view text, int expected) {
  std::vector<double> values;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string_view item = text.substr(start, comma == std::string_view::npos ? text.npos : comma - start);
    const std::optional<double> v = ParseFiniteNumber(item);
    if (!v) {
      throw UsageError(std::string(option) + ": expected comma-separated finite numbers, got '" + std::string(item) +
                       "' in '" + std::string(text) + "'");
    }
    values.push_back(*v);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (expected > 0 && static_cast<int>(values.size()) != expected) {
    throw UsageError(std::string(option) + ": expected " + std::to_string(expected) + " values (one per joint), got " +
                     std::to_string(values.size()));
  }
  return Eigen::Map<const VectorXd>(values.data(), static_cast<int>(values.size()));
}

std::string FormatDouble(double x) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, end) : std::string("nan");
}

void WriteJsonVector(std::ostream& out, const VectorXd& v) {
  out << '[';
  for (int i = 0; i < v.size(); ++i) out << (i ? ", " : "") << FormatDouble(v[i]);
  out << ']';
}

void WriteJsonMatrix(std::ostream& out, const MatrixXd& m) {
  out << '[';
  for (int i = 0; i < m.rows(); ++i) {
    out << (i ? ", " : "");
    WriteJsonVector(out, m.row(i).transpose());
  }
  out << ']';
}

}  // namespace lagrange::cli
