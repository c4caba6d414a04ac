// lagrangectl simulate: run a scene offline and write one CSV row per step (a
// floating base's pose, twist, centre of mass and momentum after the joints'),
// and each instance's joint names beside its CSV (JointNamesPath); an
// instance under a controller that moves a frame (a task-space controller, or
// an mpc with a frame) also that frame, one row per CSV row (TaskCsvPath).
// A scene with an external plant or controller is refused: it needs the bus.
// An instance that fails lagranged's health check (sim/health.hpp) stops at
// its last healthy row, with one line saying why, and the exit status is 1.
// An mpc controller's failed solves are one line each instance (their count
// and statuses); the run goes on, as lagranged's does.

#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>

#include "protocol/format.hpp"
#include "protocol/log_records.hpp"
#include "sim/health.hpp"
#include "sim/instance_model.hpp"
#include "sim/offline.hpp"
#include "sim/scene.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/log_csv.hpp"

namespace lagrange::cli {
namespace {

// FILE for a one-instance scene; FILE with ".NAME" before its extension otherwise.
std::string CsvPathFor(const std::string& path, const std::string& name, bool several) {
  if (!several || path == "-") return path;
  const std::size_t slash = path.find_last_of('/');
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return path + "." + name;
  return path.substr(0, dot) + "." + name + path.substr(dot);
}

// The columns log2csv gives the same quantities in a state CSV (JointColumns), and a floating base's in a base CSV.
void WriteHeader(std::ostream& out, const Instance& inst) {
  out << 't';
  for (const char* field : {"q", "qd", "q_des", "tau"}) out << JointColumns(field, inst.num_dofs());
  out << ',' << kKineticEnergyColumn << ',' << kPotentialEnergyColumn;
  if (inst.floating_base()) {
    for (const BaseStateArray& a : kBaseStateArrays) out << JointColumns(a.name, a.width);  // log2csv's names
  }
  out << '\n';
}

void WriteRow(std::ostream& out, Instance& inst) {
  out << FormatDouble(inst.t());
  const auto put = [&out](const auto& v) {
    for (Eigen::Index i = 0; i < v.size(); ++i) out << ',' << FormatDouble(v[i]);
  };
  for (const VectorXd* v : {&inst.q(), &inst.qd(), &inst.q_des(), &inst.tau()}) put(*v);
  out << ',' << FormatDouble(inst.KineticEnergy()) << ',' << FormatDouble(inst.PotentialEnergy());
  if (inst.floating_base()) {
    for (const double x : BaseRowOf(inst)) out << ',' << FormatDouble(x);  // base_state_t's arrays, in order
  }
  out << '\n';
}

// The task CSV's columns: log2csv's names for these fields of task_state_t (TaskStateWriter).
void WriteTaskHeader(std::ostream& out) {
  out << "t,frame" << JointColumns("position", 3) << JointColumns("position_des", 3) << JointColumns("error", 6)
      << '\n';
}

// The row's task space (TaskRowOf, sim/offline.hpp: nan at t = 0).
void WriteTaskRow(std::ostream& out, Instance& inst, bool computed) {
  const OfflineTaskRow row = TaskRowOf(inst, computed);
  out << FormatDouble(inst.t()) << ',' << CsvText(TaskFrameOf(inst));
  for (int i = 0; i < 3; ++i) out << ',' << FormatDouble(row.position[i]);
  for (int i = 0; i < 3; ++i) out << ',' << FormatDouble(row.position_des[i]);
  for (int i = 0; i < 6; ++i) out << ',' << FormatDouble(row.error[i]);
  out << '\n';
}

// One line for a fault: which instance, when, why, and where its CSV stops.
std::string FaultLine(Instance& inst, const OfflineFault& f) {
  return "lagrangectl simulate: " + OfflineFaultText(inst, f) + "; its CSV ends at t = " + FormatDouble(inst.t()) +
         " s, the last healthy step";
}

class SimulateCommand final : public Command {
 public:
  explicit SimulateCommand(CLI::App& parent)
      : Command(parent.add_subcommand("simulate", "Run a scene offline, as fast as possible, into CSV")) {
    app_->add_option("scene", scene_, "Scene file (YAML)")->required();
    app_->add_option("--duration", duration_, "Simulated time, s")->required()->check(PositiveNumber());
    app_->add_option("--csv", csv_,
                     "Output CSV ('-' for stdout), with its joint names in FILE.joints.csv beside it and, under a "
                     "controller that moves a frame (task-space, or mpc with a frame), its frame's position, target "
                     "and error (log2csv's task columns) in "
                     "FILE.task.csv; a scene with several instances writes FILE.NAME.csv (and FILE.NAME.joints.csv, "
                     "FILE.NAME.task.csv) for each")
        ->required();
  }

  int Run(std::ostream& out, std::ostream& err) override {
    const Scene scene = LoadScene(scene_);
    OfflineScene offline = PrepareOfflineScene(scene, scene_);
    std::vector<Instance>& instances = offline.instances;

    const bool several = instances.size() > 1;
    std::vector<std::unique_ptr<std::ofstream>> files;
    std::vector<std::ostream*> streams;
    std::vector<std::ostream*> task_streams(instances.size(), nullptr);  // null: no task CSV
    const auto open = [&files](const std::string& path) {
      files.push_back(std::make_unique<std::ofstream>(path));
      if (!*files.back()) throw std::runtime_error("cannot write " + path);
      return files.back().get();
    };
    for (std::size_t i = 0; i < instances.size(); ++i) {
      Instance& inst = instances[i];
      const std::string path = CsvPathFor(csv_, inst.name(), several);
      if (path == "-") {
        streams.push_back(&out);
        continue;
      }
      streams.push_back(open(path));
      WriteJointNames(path, inst.instance_model().joint_names);
      if (!TaskFrameOf(inst).empty()) {
        task_streams[i] = open(TaskCsvPath(path));
        WriteTaskHeader(*task_streams[i]);
      }
      if (several) err << "lagrangectl simulate: " << inst.name() << " -> " << path << "\n";
    }
    for (std::size_t i = 0; i < instances.size(); ++i) WriteHeader(*streams[i], instances[i]);

    const auto steps = static_cast<std::int64_t>(std::llround(duration_ / scene.period));
    std::vector<bool> stepped(instances.size(), false);  // observed once already: past t = 0
    const std::vector<OfflineFault> faults =
        RunOfflineChecked(instances, scene.period, steps, [&](std::size_t i, Instance& inst) {
          WriteRow(*streams[i], inst);
          if (task_streams[i] != nullptr && !TaskFrameOf(inst).empty())
            WriteTaskRow(*task_streams[i], inst, stepped[i]);
          stepped[i] = true;
        });
    for (auto& f : files) {
      f->flush();
      if (!*f) throw std::runtime_error("writing the CSV failed");
    }
    for (const OfflineFault& f : faults) err << FaultLine(instances[f.index], f) << "\n";
    for (const Instance& inst : instances) {
      if (const std::optional<std::string> failures = OfflineMpcFailureText(inst)) {
        err << "lagrangectl simulate: " << *failures << "\n";
      }
    }
    return faults.empty() ? 0 : 1;
  }

 private:
  std::string scene_;
  double duration_ = 0.0;
  std::string csv_;
};

}  // namespace

std::unique_ptr<Command> MakeSimulateCommand(CLI::App& parent) { return std::make_unique<SimulateCommand>(parent); }

}  // namespace lagrange::cli
