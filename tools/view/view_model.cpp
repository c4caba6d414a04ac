#include "tools/view/view_model.hpp"

#include <cmath>
#include <stdexcept>

#include "base/escape.hpp"

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

constexpr double kRodRadius = 0.02;    // m: the built-in plants' links
constexpr double kJointRadius = 0.035;  // m: a sphere at each joint
constexpr double kSkeletonRadius = 0.025;  // m: a URDF robot without <visual>

json Pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  json a = json::array();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.push_back(R(i, j));
  for (int i = 0; i < 3; ++i) a.push_back(p(i));
  return a;
}

json Rgba(double r, double g, double b, double a = 1.0) { return json::array({r, g, b, a}); }

json Rod(int from, int to, double radius, json color) {
  return {{"type", "rod"}, {"from", from}, {"to", to}, {"radius", radius}, {"rgba", std::move(color)}};
}
json Sphere(int frame, double radius, json color) {
  return {{"type", "sphere"}, {"frame", frame}, {"size", {radius}}, {"origin", Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero())},
          {"rgba", std::move(color)}};
}
json Box(int frame, Eigen::Vector3d size, Eigen::Vector3d at, json color) {
  return {{"type", "box"}, {"frame", frame}, {"size", {size.x(), size.y(), size.z()}},
          {"origin", Pose(Eigen::Matrix3d::Identity(), at)}, {"rgba", std::move(color)}};
}

// A number for JSON: null for ±inf or NaN (JSON has neither).
json Finite(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

}  // namespace

ViewModel::ViewModel(std::string name, const PlantSpec& spec, const ViewModelOptions& options)
    : name_(std::move(name)), floating_base_(options.floating_base) {
  const RigidTree tree = MakeRigidTree(spec);
  kinematics_ = std::make_unique<Kinematics>(tree);
  data_ = kinematics_->MakeData();
  const bool planar = spec.type() != PlantType::kUrdf;
  json joints = json::array();
  const std::vector<JointType> types = JointTypesOf(spec);
  const std::vector<std::string> names = JointNamesOf(spec);
  for (std::size_t k = 0; k < names.size(); ++k) {
    const bool prismatic = types[k] == JointType::kPrismatic;
    double lower = prismatic ? -1.0 : -M_PI, upper = prismatic ? 1.0 : M_PI;  // a slider's range without limits
    if (spec.type() == PlantType::kUrdf) {
      const UrdfJointProperties& p = std::get<UrdfParams>(spec.params).robot->properties[k];
      lower = p.lower.value_or(lower);
      upper = p.upper.value_or(upper);
    }
    joints.push_back({{"name", Escape(names[k])}, {"type", prismatic ? "prismatic" : "revolute"}, {"lower", lower}, {"upper", upper}});
  }
  json frames = json::array();
  for (const std::string& f : kinematics_->frame_names()) frames.push_back(Escape(f));
  json limits = json::array();
  for (Eigen::Index k = 0; k < options.torque_limits.size(); ++k) limits.push_back(Finite(options.torque_limits[k]));
  geometry_ = {{"name", Escape(name_)},
               {"plant", std::string(ToString(spec.type()))},
               {"planar", planar},
               {"floating_base", floating_base_},
               {"dofs", kinematics_->num_dofs()},
               {"joints", joints},
               {"frames", frames},
               {"shapes", json::array()},
               {"missing", json::array()},
               {"tau_limits", limits},
               {"meshes", json::array()}};
  if (planar)
    BuiltInShapes(spec);
  else
    UrdfShapes(*std::get<UrdfParams>(spec.params).robot, options.package_path);
}

int ViewModel::Frame(const std::string& name) const { return kinematics_->FrameIndex(name).value_or(-1); }

void ViewModel::BuiltInShapes(const PlantSpec& spec) {
  json& shapes = geometry_["shapes"];
  const json link = Rgba(0.85, 0.55, 0.2), joint = Rgba(0.3, 0.3, 0.35), body = Rgba(0.25, 0.5, 0.85);
  shapes.push_back(Box(-1, {0.08, 0.08, 0.08}, Eigen::Vector3d::Zero(), joint));  // the base (pivot, shoulder, rail's middle)
  switch (spec.type()) {
    case PlantType::kArm2:
    case PlantType::kChain: {
      // Joint to joint, then to the tip: frames link1 .. linkN, tip in order.
      const int n = kinematics_->num_frames();
      for (int k = 0; k + 1 < n; ++k) shapes.push_back(Rod(k, k + 1, kRodRadius, link));
      for (int k = 0; k + 1 < n; ++k) shapes.push_back(Sphere(k, kJointRadius, joint));
      shapes.push_back(Sphere(n - 1, 0.5 * kJointRadius, joint));
      break;
    }
    case PlantType::kPendulum: {
      const auto& p = std::get<PendulumParams>(spec.params);
      shapes.push_back(Rod(-1, Frame("bob"), kRodRadius * (p.body == PendulumBody::kRod ? 1.5 : 0.5), link));
      if (p.body == PendulumBody::kPointMass) shapes.push_back(Sphere(Frame("bob"), 0.06, body));
      break;
    }
    case PlantType::kCartPole: {
      shapes.push_back(Box(-1, {2.0, 0.02, 0.02}, {0.0, -0.09, 0.0}, joint));  // the rail
      shapes.push_back(Box(Frame("cart"), {0.3, 0.15, 0.15}, Eigen::Vector3d::Zero(), body));
      shapes.push_back(Rod(Frame("pole"), Frame("pole_tip"), kRodRadius, link));
      shapes.push_back(Sphere(Frame("pole"), kJointRadius, joint));
      break;
    }
    case PlantType::kUrdf:
      break;
  }
}

// Quoted and escaped, for a line on the page.
static std::string Quoted(const std::string& text) {
  std::string q(1, '\'');  // appended: g++ 12 warns falsely (-Wrestrict) on "'" + std::string
  q += Escape(text, 256);
  q += '\'';
  return q;
}

void ViewModel::UrdfShapes(const UrdfRobot& robot, const std::vector<std::string>& package_path) {
  json& shapes = geometry_["shapes"];
  json& missing = geometry_["missing"];
  for (const std::string& note : robot.looks.notes) missing.push_back(note + "; not drawn");
  const MeshRoots roots(robot.file, package_path);
  int drawn = 0;
  for (const UrdfVisual& v : robot.looks.visuals) {
    json shape = {{"frame", Frame(v.link)}, {"origin", Pose(v.R, v.p)}, {"rgba", {v.rgba[0], v.rgba[1], v.rgba[2], v.rgba[3]}}};
    switch (v.geometry) {
      case UrdfVisual::Geometry::kBox:
        shape["type"] = "box";
        shape["size"] = {v.size.x(), v.size.y(), v.size.z()};
        break;
      case UrdfVisual::Geometry::kCylinder:
        shape["type"] = "cylinder";
        shape["size"] = {v.size.x(), v.size.y()};
        break;
      case UrdfVisual::Geometry::kSphere:
        shape["type"] = "sphere";
        shape["size"] = {v.size.x()};
        break;
      case UrdfVisual::Geometry::kMesh:
        UrdfMesh(v, roots, shape);
        if (shape.is_null()) continue;
        break;
    }
    shapes.push_back(std::move(shape));
    ++drawn;
  }
  geometry_["skeleton"] = drawn == 0;
  if (drawn == 0) UrdfSkeleton(robot.looks);
}

// A mesh visual's shape, with the file to serve; null (and a line in "missing") when it is missing or refused.
void ViewModel::UrdfMesh(const UrdfVisual& v, const MeshRoots& roots, json& shape) {
  const auto found = roots.Find(v.mesh);
  if (const std::string* why = std::get_if<std::string>(&found)) {
    geometry_["missing"].push_back("link " + Quoted(v.link) + " <visual> " + std::to_string(v.index) + ": mesh " +
                                   Quoted(v.mesh) + " " + *why + "; its frame is drawn");
    shape = nullptr;
    return;
  }
  const MeshFile& file = std::get<MeshFile>(found);
  shape["type"] = "mesh";
  shape["format"] = file.format == MeshFormat::kStl ? "stl" : "dae";
  shape["scale"] = {v.scale.x(), v.scale.y(), v.scale.z()};
  shape["mesh"] = static_cast<int>(mesh_files_.size());
  mesh_files_.push_back(file);
}

// No <visual> at all: a rod from each link's frame to each child link's, a sphere at each. A parent that is no
// frame is the world a <joint type="floating"> frees the base from: no rod across the world to the base.
void ViewModel::UrdfSkeleton(const UrdfLooks& looks) {
  json& shapes = geometry_["shapes"];
  const json color = Rgba(0.6, 0.62, 0.7);
  for (const auto& [parent, child] : looks.links) {
    const int a = Frame(parent), b = Frame(child);
    if (a >= 0 && b >= 0) shapes.push_back(Rod(a, b, kSkeletonRadius, color));
  }
  for (int k = 0; k < kinematics_->num_frames(); ++k) shapes.push_back(Sphere(k, 1.5 * kSkeletonRadius, color));
}

json ViewModel::Poses(ConstVecRef q, const BasePose& base) const {
  std::lock_guard lock(data_mutex_);
  kinematics_->ComputeFramePlacements(*data_, q);
  json poses = json::array();
  for (int k = 0; k < kinematics_->num_frames(); ++k)
    poses.push_back(Pose(base.R * data_->rotation(k), base.R * data_->position(k) + base.p));
  return poses;
}

}  // namespace lagrange::cli::view
