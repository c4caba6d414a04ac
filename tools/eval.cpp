// lagrangectl eval: M, C, G, qdd, T and V of a plant at one state, as JSON.

#include <algorithm>
#include <nlohmann/json.hpp>

#include "plant/plant_spec.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

// "a,b,c" => {"a", "b", "c"}
std::vector<std::string> SplitCommas(const std::string& text) {
  std::vector<std::string> items;
  std::size_t start = 0;
  for (std::size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1) {
    items.push_back(text.substr(start, comma - start));
  }
  items.push_back(text.substr(start));
  return items;
}

// --param NAME=VALUE; for a chain, VALUE may be a comma-separated list with one value per link.
void SetParam(PlantSpec& spec, const std::string& name, const std::string& value) {
  if (spec.type() != PlantType::kChain || value.find(',') == std::string::npos) {
    if (auto e = SetPlantParam(spec, name, value)) throw UsageError("--param " + e->key + ": " + e->message);
    return;
  }
  if (name == "links" || name == "g" || name == "base_angle") {
    throw UsageError("--param " + name + ": expected a single value, got '" + value + "'");
  }
  const std::vector<std::string> items = SplitCommas(value);
  const int links = spec.num_dofs();
  if (static_cast<int>(items.size()) != links) {
    throw UsageError("--param " + name + ": expected " + std::to_string(links) + " values (one per link), got " +
                     std::to_string(items.size()));
  }
  for (int i = 0; i < links; ++i) {
    if (auto e = SetPlantParam(spec, name, items[static_cast<std::size_t>(i)], i)) {
      throw UsageError("--param " + e->key + "[" + std::to_string(i) + "]: " + e->message);
    }
  }
}

// A vector as a list of numbers.
std::vector<double> JsonList(const VectorXd& v) { return {v.begin(), v.end()}; }

// A matrix as a list of rows.
std::vector<std::vector<double>> JsonRows(const MatrixXd& m) {
  std::vector<std::vector<double>> rows;
  for (int i = 0; i < m.rows(); ++i) rows.push_back(JsonList(m.row(i).transpose()));
  return rows;
}

class EvalCommand final : public Command {
 public:
  explicit EvalCommand(CLI::App& parent)
      : Command(parent.add_subcommand("eval", "Evaluate M, C, G, qdd, T and V at one state (JSON)")) {
    app_->add_option("--plant", plant_, "Plant type: " + PlantTypeNames())->required();
    app_->add_option("--links", links_, "Number of links (chain)");
    app_->add_option("--param", params_,
                     "NAME=VALUE, repeatable (m1, m2, L1, L2, mc, mp, l, I, m, L, g, ...); a chain's m, L, com, I "
                     "and joints (revolute|prismatic) take one value for every link or a list: m=1,0.8,0.5");
    AddNumberList(*app_, "--q", q_, "Positions a,b,.. (rad or m)")->required();
    AddNumberList(*app_, "--qd", qd_, "Velocities c,d,.. (rad/s or m/s)")->required();
    AddNumberList(*app_, "--tau", tau_, "Generalized forces e,f,.. (N·m or N); default zeros");
    app_->add_option("--method", method_, "closed-form|lagrangian|recursive; default the fastest exact path");
  }

  int Run(std::ostream& out, std::ostream&) override {
    const std::optional<PlantType> type = ParsePlantType(plant_);
    if (!type) throw UsageError("--plant: expected one of " + PlantTypeNames() + ", got '" + plant_ + "'");
    PlantSpec spec = DefaultPlantSpec(*type);
    if (links_) {
      if (*type != PlantType::kChain) throw UsageError("--links: only a chain has links");
      if (auto e = SetChainLinks(spec, *links_)) throw UsageError("--links: " + e->message);
    }
    // The chain's link count first, so per-link lists are checked against it (as a scene does).
    std::vector<std::string> params = params_;
    std::stable_partition(params.begin(), params.end(), [](const std::string& p) { return p.starts_with("links="); });
    for (const std::string& p : params) {
      const std::size_t eq = p.find('=');
      if (eq == std::string::npos) throw UsageError("--param: expected NAME=VALUE, got '" + p + "'");
      SetParam(spec, p.substr(0, eq), p.substr(eq + 1));
    }
    if (auto e = ValidatePlantSpec(spec)) throw UsageError("--param " + e->key + ": " + e->message);

    Method method = FastestMethod(*type);
    if (method_) {
      const std::optional<Method> m = ParseMethod(*method_);
      if (!m) throw UsageError("--method: expected closed-form, lagrangian or recursive, got '" + *method_ + "'");
      if (!HasMethod(*type, *m)) {
        throw UsageError("--method: " + plant_ + " has no " + *method_ + " path (use lagrangian or recursive)");
      }
      method = *m;
    }

    const int n = spec.num_dofs();
    const VectorXd q = JointValues("--q", q_, n);
    const VectorXd qd = JointValues("--qd", qd_, n);
    const VectorXd tau = tau_.empty() ? VectorXd::Zero(n) : JointValues("--tau", tau_, n);

    auto dynamics = MakeDynamics(spec, method);
    MatrixXd M(n, n), C(n, n);
    VectorXd G(n), qdd(n);
    dynamics->ComputeMassMatrix(q, M);
    dynamics->ComputeCoriolisMatrix(q, qd, C);
    dynamics->ComputeGravityForce(q, G);
    dynamics->ComputeForwardDynamics(q, qd, tau, DynamicsTerms{}, qdd);
    const double T = dynamics->ComputeKineticEnergy(q, qd);
    const double V = dynamics->ComputePotentialEnergy(q);
    // Every value printed is finite (JSON has no inf or nan).
    if (!M.allFinite() || !C.allFinite() || !G.allFinite() || !qdd.allFinite() || !std::isfinite(T) ||
        !std::isfinite(V)) {
      throw std::runtime_error("the dynamics are not finite at this state");
    }

    // ordered_json keeps the keys in the order written; dump() prints the shortest text that reads back to each double.
    const nlohmann::ordered_json json = {{"plant", ToString(*type)},
                                         {"method", ToString(method)},
                                         {"num_dofs", n},
                                         {"M", JsonRows(M)},
                                         {"C", JsonRows(C)},
                                         {"G", JsonList(G)},
                                         {"qdd", JsonList(qdd)},
                                         {"T", T},
                                         {"V", V}};
    out << json.dump() << "\n";
    return 0;
  }

 private:
  std::string plant_;
  std::optional<int> links_;
  std::vector<std::string> params_;
  std::vector<double> q_, qd_, tau_;
  std::optional<std::string> method_;
};

}  // namespace

std::unique_ptr<Command> MakeEvalCommand(CLI::App& parent) { return std::make_unique<EvalCommand>(parent); }

}  // namespace lagrange::cli
