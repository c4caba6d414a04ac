#include "protocol/setpoint_check.hpp"

#include <cmath>
#include <sstream>

#include "protocol/wire.hpp"

namespace lagrange {
namespace {

std::string Number(double x) {
  std::ostringstream os;
  os.precision(6);
  os << x;
  return os.str();
}

// The first non-finite or out-of-range entry of a field, as a reason ("" if none).
std::string CheckField(const char* field, const std::vector<double>& v) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) return std::string("non-finite value in ") + field + "[" + std::to_string(i) + "]";
    if (std::abs(v[i]) > kMaxSetpointMagnitude) {
      return std::string(field) + "[" + std::to_string(i) + "] = " + Number(v[i]) + " is out of range (|x| <= 1e6)";
    }
  }
  return "";
}

SetpointVerdict Reject(std::string why) { return {SetpointVerdict::Kind::kRejected, std::move(why)}; }

}  // namespace

SetpointVerdict CheckSetpoint(const void* data, std::size_t size, const SetpointRules& rules, setpoint_t& out) {
  if (const WireCheck w = CheckSetpointPacket(data, size); w != WireCheck::kOk) {
    return {SetpointVerdict::Kind::kUndecodable, ToString(w)};
  }
  if (out.decode(data, 0, static_cast<int>(size)) < 0) return {SetpointVerdict::Kind::kUndecodable, "decode failed"};
  if (out.num_dofs != rules.n) {
    return Reject("num_dofs is " + std::to_string(out.num_dofs) + ", expected " + std::to_string(rules.n));
  }
  for (const auto& [field, values] : {std::pair{"q", &out.q}, std::pair{"qd", &out.qd}, std::pair{"qdd", &out.qdd}}) {
    if (std::string why = CheckField(field, *values); !why.empty()) return Reject(why);
  }
  for (int j = 0; j < rules.n; ++j) {
    if (out.q[static_cast<std::size_t>(j)] < rules.lower[j] || out.q[static_cast<std::size_t>(j)] > rules.upper[j]) {
      return Reject("q[" + std::to_string(j) + "] = " + Number(out.q[static_cast<std::size_t>(j)]) +
                    " is outside the setpoint limits [" + Number(rules.lower[j]) + ", " + Number(rules.upper[j]) + "]");
    }
  }
  return {SetpointVerdict::Kind::kAccepted, ""};
}

}  // namespace lagrange
