#pragma once
// A RigidTree (plant/rigid_tree.hpp) as an Orocos KDL chain, for the
// benchmarks that run KDL beside lagrange (kdl_bench, kinematics_bench).
//
// KDL's conventions: a segment's joint sits in the parent segment's tip
// frame with its origin and axis given there (a revolute joint turns about
// the line through the origin along the axis); the segment's tip frame is
// the joint's pose times f_tip, so f_tip is the joint frame's fixed
// placement; the segment's inertia is given in its tip frame (the body
// frame) as (mass, centre of mass, rotational inertia about the centre of
// mass) by RigidBodyInertia's 3-argument constructor, which shifts it to the
// frame origin itself.

#include <kdl/chain.hpp>
#include <kdl/jntarray.hpp>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "plant/rigid_tree.hpp"

namespace lagrange::bench {

KDL::Vector ToKdl(const Eigen::Vector3d& v);
// The frame with axes R and origin p.
KDL::Frame ToKdl(const Eigen::Matrix3d& R, const Eigen::Vector3d& p);
KDL::JntArray ToJntArray(const Eigen::VectorXd& v);

// A serial RigidTree (joint i's parent is joint i − 1) as a KDL chain, one
// segment per joint, segment i's tip frame body i's frame. Throws
// std::invalid_argument for a tree that branches.
KDL::Chain ToKdlChain(const RigidTree& tree);

// The same chain with the tree's named frames as segments too, as
// kdl_parser builds one from a URDF: a frame placed exactly at its body's
// origin with its axes (or exactly where the frame before it on that body
// is) is that segment; any other gets a fixed segment (KDL::Joint::None)
// after its body's, and the next joint is placed from there. segment[k] is
// the index of frame k's segment, −1 for a frame at the world's origin with
// its axes (KDL's base). Throws std::invalid_argument for a tree that branches.
struct KdlFrameChain {
  KDL::Chain chain;
  std::vector<int> segment;  // (num_frames)
};
KdlFrameChain ToKdlFrameChain(const RigidTree& tree);

// ---- agreement with KDL, checked before anything is timed ----

// The largest gap between lagrange and KDL on one quantity over the states checked.
struct Difference {
  double absolute = 0.0;  // max |lagrange − KDL|, in the quantity's units
  double relative = 0.0;  // max |lagrange − KDL| / (1 + max |KDL|)
  bool compared = false;  // some state was compared
};
// One line of the table: the robot and two labels (kdl_bench: method, term;
// kinematics_bench: term, quantity).
struct AgreementRow {
  std::string robot, first, second;
  Difference diff;
};
// Prints `rows` to stderr under `title`, columns robot, `first`, `second`, and
// as CSV to `csv_path` when it is not empty (robot,FIRST,SECOND,max_abs_diff,
// max_rel_diff,limit_rel); false when any row is above `limit` relative or
// NaN. Throws std::runtime_error naming `program` when the CSV cannot be written.
bool ReportAgreement(const std::string& program, const std::string& title, const char* first, const char* second,
                     const std::vector<AgreementRow>& rows, double limit, const std::string& csv_path);

}  // namespace lagrange::bench
