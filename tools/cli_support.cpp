#include "tools/cli_support.hpp"

#include "plant/plant_factory.hpp"
#include "protocol/format.hpp"

namespace lagrange::cli {

namespace {

CLI::Validator NumberCheck(std::string description, bool (*ok)(double, double), double max, std::string expected) {
  return CLI::Validator(
      [ok, max, expected](std::string& text) -> std::string {
        const std::optional<double> v = ParseFiniteNumber(text);
        if (!v || !ok(*v, max)) return "expected " + expected + ", got '" + text + "'";
        return "";
      },
      std::move(description));
}

}  // namespace

CLI::Validator FiniteNumber() {
  return NumberCheck(
      "NUMBER", [](double, double) { return true; }, 0.0, "comma-separated finite numbers");
}

CLI::Validator NonNegativeNumber() {
  return NumberCheck(
      "NUMBER >= 0", [](double v, double) { return v >= 0.0; }, 0.0, "finite numbers >= 0");
}

CLI::Validator PositiveNumber(double max) {
  return NumberCheck(
      "NUMBER > 0", [](double v, double m) { return v > 0.0 && v <= m; }, max,
      max < 1e300 ? "a number in (0, " + FormatDouble(max) + "]" : std::string("a positive number"));
}

CLI::Option* AddNumberList(CLI::App& app, const std::string& name, std::vector<double>& values,
                           const std::string& help) {
  return app.add_option(name, values, help)->delimiter(',')->allow_extra_args(false)->check(FiniteNumber());
}

VectorXd JointValues(std::string_view option, const std::vector<double>& values, int n, bool scalar_ok,
                     bool task_axes) {
  if (scalar_ok && values.size() == 1) return VectorXd::Constant(n, values[0]);
  if (static_cast<int>(values.size()) != n) {
    const std::string each = task_axes ? " (one for every task axis, or one per task axis: x, y, z, rx, ry, rz)"
                             : scalar_ok && n > 1 ? " (one for every joint, or one per joint)"
                                                  : " (one per joint)";
    throw UsageError(std::string(option) + ": expected " + std::to_string(n) + (n == 1 ? " value" : " values") +
                     each + ", got " + std::to_string(values.size()));
  }
  return Eigen::Map<const VectorXd>(values.data(), n);
}

}  // namespace lagrange::cli
