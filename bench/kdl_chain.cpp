#include "bench/kdl_chain.hpp"

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

namespace lagrange::bench {
namespace {

void CheckSerial(const RigidTree& tree) {
  for (int i = 0; i < tree.num_dofs(); ++i) {
    const TreeJoint& j = tree.joints[static_cast<std::size_t>(i)];
    if (j.parent != i - 1) {
      throw std::invalid_argument("ToKdlChain: joint '" + j.name + "' does not continue a serial chain");
    }
  }
}

// Joint i's segment, placed at `placement` in the chain's current tip frame.
KDL::Segment JointSegment(const RigidTree& tree, int i, const KDL::Frame& placement) {
  const TreeJoint& j = tree.joints[static_cast<std::size_t>(i)];
  const KDL::Vector axis = placement.M * ToKdl(j.axis);
  const KDL::Joint joint(j.name, placement.p, axis,
                         j.type == JointType::kRevolute ? KDL::Joint::RotAxis : KDL::Joint::TransAxis);
  const RigidBody& b = tree.bodies[static_cast<std::size_t>(i)];
  const Eigen::Matrix3d& I = b.inertia;
  const KDL::RigidBodyInertia inertia(b.mass, ToKdl(b.com),
                                      KDL::RotationalInertia(I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)));
  return KDL::Segment(j.name, joint, placement, inertia);
}

}  // namespace

KDL::Vector ToKdl(const Eigen::Vector3d& v) { return KDL::Vector(v.x(), v.y(), v.z()); }

KDL::Frame ToKdl(const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  return KDL::Frame(KDL::Rotation(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)),
                    ToKdl(p));
}

KDL::JntArray ToJntArray(const Eigen::VectorXd& v) {
  KDL::JntArray a(static_cast<unsigned int>(v.size()));
  a.data = v;
  return a;
}

KDL::Chain ToKdlChain(const RigidTree& tree) {
  CheckSerial(tree);
  KDL::Chain chain;
  for (int i = 0; i < tree.num_dofs(); ++i) {
    const TreeJoint& j = tree.joints[static_cast<std::size_t>(i)];
    chain.addSegment(JointSegment(tree, i, ToKdl(j.rotation, j.position)));
  }
  return chain;
}

KdlFrameChain ToKdlFrameChain(const RigidTree& tree) {
  CheckSerial(tree);
  KdlFrameChain out;
  out.segment.assign(tree.frames.size(), -1);
  // The chain's tip in the current body's frame (the world's before joint 0).
  Eigen::Matrix3d tip_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d tip_p = Eigen::Vector3d::Zero();
  const auto tip = [&] { return ToKdl(tip_R, tip_p); };
  const auto add_frames_of = [&](int body) {
    for (std::size_t k = 0; k < tree.frames.size(); ++k) {
      const TreeFrame& f = tree.frames[k];
      if (f.body != body) continue;
      if (f.rotation != tip_R || f.position != tip_p) {
        out.chain.addSegment(
            KDL::Segment(f.name, KDL::Joint(KDL::Joint::None), tip().Inverse() * ToKdl(f.rotation, f.position)));
        tip_R = f.rotation;
        tip_p = f.position;
      }
      out.segment[k] = static_cast<int>(out.chain.getNrOfSegments()) - 1;
    }
  };
  add_frames_of(-1);
  for (int i = 0; i < tree.num_dofs(); ++i) {
    const TreeJoint& j = tree.joints[static_cast<std::size_t>(i)];
    out.chain.addSegment(JointSegment(tree, i, tip().Inverse() * ToKdl(j.rotation, j.position)));
    tip_R.setIdentity();
    tip_p.setZero();
    add_frames_of(i);
  }
  return out;
}

bool ReportAgreement(const std::string& program, const std::string& title, const char* first, const char* second,
                     const std::vector<AgreementRow>& rows, double limit, const std::string& csv_path) {
  bool ok = true;
  std::fprintf(stderr, "%s: %s (limit %.0e relative)\n", program.c_str(), title.c_str(), limit);
  std::fprintf(stderr, "  %-20s %-11s %-8s %12s %12s\n", "robot", first, second, "max |diff|", "relative");
  for (const AgreementRow& r : rows) {
    const bool good = r.diff.relative <= limit;  // false for NaN too
    ok = ok && good;
    std::fprintf(stderr, "  %-20s %-11s %-8s %12.3e %12.3e%s\n", r.robot.c_str(), r.first.c_str(), r.second.c_str(),
                 r.diff.absolute, r.diff.relative, good ? "" : "  DISAGREE");
  }
  if (!csv_path.empty()) {
    std::ofstream csv(csv_path);
    csv << "robot," << first << ',' << second << ",max_abs_diff,max_rel_diff,limit_rel\n";
    csv.precision(4);
    for (const AgreementRow& r : rows) {
      csv << r.robot << ',' << r.first << ',' << r.second << ',' << std::scientific << r.diff.absolute << ','
          << r.diff.relative << ',' << limit << '\n';
    }
    if (!csv) throw std::runtime_error(program + ": cannot write " + csv_path);
  }
  return ok;
}

}  // namespace lagrange::bench
