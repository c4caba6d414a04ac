// The C++ side of tests/python/test_model.py for what lagrangectl eval does
// not print: inverse dynamics and a frame's Jacobian and J̇ qd in its own axes
// (FrameAxes::kLocal; eval prints world-aligned ones). Builds the plant as eval
// does (a built-in plant with its defaults, or a URDF robot) and prints tau =
// M qdd + C qd + G, then with FRAME its local J (6 x n, row by row) and J̇ qd
// (6), each double as %.17g (which reads back to the same double), one per line.
//
//   model_reference (--plant NAME | --urdf FILE) METHOD q1,..,qn qd1,.. qdd1,.. [FRAME]

#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"

namespace {

lagrange::VectorXd Numbers(const std::string& text) {
  std::vector<double> values;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) values.push_back(std::stod(item));
  return Eigen::Map<const lagrange::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 7 && argc != 8) {
    std::fprintf(stderr, "usage: model_reference (--plant NAME | --urdf FILE) METHOD q qd qdd [FRAME]\n");
    return 2;
  }
  using namespace lagrange;
  const std::string kind = argv[1], what = argv[2];
  const PlantSpec spec = kind == "--urdf" ? UrdfPlantSpec(std::make_shared<const UrdfRobot>(LoadUrdf(what)))
                                          : DefaultPlantSpec(*ParsePlantType(what));
  const std::unique_ptr<Dynamics> dynamics = MakeDynamics(spec, *ParseMethod(argv[3]));
  const std::unique_ptr<DynamicsData> data = dynamics->MakeData();
  const VectorXd q = Numbers(argv[4]), qd = Numbers(argv[5]), qdd = Numbers(argv[6]);
  VectorXd tau(dynamics->num_dofs());
  dynamics->ComputeInverseDynamics(*data, q, qd, qdd, DynamicsTerms{}, tau);
  for (double x : tau) std::printf("%.17g\n", x);
  if (argc == 8) {
    const Kinematics kinematics(MakeRigidTree(spec));
    const std::unique_ptr<KinematicsData> kd = kinematics.MakeData();
    const int k = *kinematics.FrameIndex(argv[7]);
    kinematics.ComputeFrameJacobian(*kd, q, k, FrameAxes::kLocal);
    const Matrix6Xd J = kd->jacobian(k, FrameAxes::kLocal);
    kinematics.ComputeFrameBiasAcceleration(*kd, q, qd, k, FrameAxes::kLocal);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < J.cols(); ++c) std::printf("%.17g\n", J(r, c));
    for (double x : kd->bias_acceleration(k, FrameAxes::kLocal)) std::printf("%.17g\n", x);
  }
  return 0;
}
