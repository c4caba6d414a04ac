#include "plant/urdf.hpp"

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <sstream>
#include <system_error>

namespace lagrange {
namespace {

constexpr std::size_t kMaxUrdfBytes = 16u << 20;  // a real robot's URDF is well under 1 MiB
constexpr std::size_t kMaxNameChars = 64;         // of a name quoted in a message
constexpr std::size_t kMaxMessageChars = 240;     // of one urdfdom message relayed
constexpr int kMaxXmlDepth = 64;                  // element nesting; a URDF needs about 5
constexpr double kMinAxisNorm = 1e-12;            // below this an <axis> has no direction
// Inertia checks allow rounding in the file: 1e-9 of the largest principal moment.
constexpr double kInertiaTolerance = 1e-9;
// A joint "moves nothing" when the inertia its motion meets is below this
// fraction of its subtree's inertia about the joint origin.
constexpr double kMotionInertiaTolerance = 1e-12;

// Text from the file, made safe for a one-line message: control characters
// escaped, at most `max_bytes` bytes (cut at a UTF-8 character boundary).
std::string Printable(std::string_view text, std::size_t max_bytes = kMaxNameChars) {
  std::size_t end = std::min(text.size(), max_bytes);
  while (end < text.size() && end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
  std::string out;
  for (const char ch : text.substr(0, end)) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7F) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
    } else {
      out += ch;
    }
  }
  return end < text.size() ? out + "..." : out;
}
[[noreturn]] void Fail(const std::string& file, const std::string& element, const std::string& reason) {
  throw UrdfError(Printable(file, file.size()) + ": " + element + ": " + reason);
}

std::string Quoted(std::string_view name) { return "'" + Printable(name) + "'"; }
std::string LinkElement(std::string_view name) { return "link " + Quoted(name); }
std::string JointElement(std::string_view name) { return "joint " + Quoted(name); }

std::string Number(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

// tinyxml (and urdfdom with it) parses nested elements recursively: a file of
// a million nested tags overflows the stack. A URDF nests five deep or so;
// count before parsing. Returns the 1-based line of the first element deeper
// than kMaxXmlDepth, or 0. Comments, CDATA, declarations and quoted attribute
// values are skipped; anything malformed is left to tinyxml.
int LineTooDeep(std::string_view text) {
  int depth = 0, line = 1;
  std::size_t i = 0;
  const auto skip_past = [&](std::string_view end) {
    const std::size_t at = text.find(end, i);
    const std::size_t stop = at == std::string_view::npos ? text.size() : at + end.size();
    for (; i < stop; ++i) line += text[i] == '\n';
  };
  while (i < text.size()) {
    if (text[i] == '\n') ++line;
    if (text[i] != '<') {
      ++i;
      continue;
    }
    const std::string_view rest = text.substr(i);
    if (rest.starts_with("<!--")) {
      skip_past("-->");
    } else if (rest.starts_with("<![CDATA[")) {
      skip_past("]]>");
    } else if (rest.starts_with("<?")) {
      skip_past("?>");
    } else if (rest.starts_with("<!")) {
      skip_past(">");
    } else if (rest.starts_with("</")) {
      --depth;
      skip_past(">");
    } else {  // a start tag: find its '>' outside quoted values
      const int at_line = line;
      char quote = 0, last = 0;
      for (++i; i < text.size() && (quote || text[i] != '>'); ++i) {
        line += text[i] == '\n';
        if (quote) {
          quote = text[i] == quote ? 0 : quote;
        } else if (text[i] == '"' || text[i] == '\'') {
          quote = text[i];
        }
        last = text[i];
      }
      ++i;
      if (last != '/' && ++depth > kMaxXmlDepth) return at_line;
    }
  }
  return 0;
}

// ---------------------------------------------------------------------------
// The XML, read first: what urdfdom does not keep (file order, which
// attributes are present), and checks whose messages should name the element.

struct XmlJoint {
  const TiXmlElement* element;
  std::string name, type, parent, child;
};

struct XmlRobot {
  std::string name;
  std::vector<std::string> links;  // file order
  std::vector<XmlJoint> joints;    // file order
};

// Numeric attributes we use, checked before urdfdom reads them so a bad one is
// named: urdfdom refuses most (its parser fails on nan, inf and overflow) but
// names neither the link nor the attribute, and for <inertial> it only logs
// and keeps the link with a zero inertia.
struct NumberAttribute {
  const char* child;
  const char* attribute;
  int count;
};
constexpr NumberAttribute kJointNumbers[] = {
    {"origin", "xyz", 3},     {"origin", "rpy", 3},       {"axis", "xyz", 3},
    {"limit", "lower", 1},    {"limit", "upper", 1},      {"limit", "effort", 1},
    {"limit", "velocity", 1}, {"dynamics", "damping", 1}, {"dynamics", "friction", 1},
};
constexpr NumberAttribute kInertialNumbers[] = {
    {"origin", "xyz", 3},  {"origin", "rpy", 3},  {"mass", "value", 1},  {"inertia", "ixx", 1}, {"inertia", "ixy", 1},
    {"inertia", "ixz", 1}, {"inertia", "iyy", 1}, {"inertia", "iyz", 1}, {"inertia", "izz", 1},
};

// Whether `text` is exactly `count` finite decimal numbers separated by white space.
bool AreFiniteNumbers(std::string_view text, int count) {
  int found = 0;
  std::size_t i = 0;
  while (true) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i == text.size()) break;
    std::size_t end = i;
    while (end < text.size() && !std::isspace(static_cast<unsigned char>(text[end]))) ++end;
    std::string_view token = text.substr(i, end - i);
    if (token.front() == '+') token.remove_prefix(1);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || ptr != token.data() + token.size() || !std::isfinite(value)) return false;
    ++found;
    i = end;
  }
  return found == count;
}

void CheckNumbers(const TiXmlElement* parent, std::span<const NumberAttribute> attributes, const std::string& file,
                  const std::string& element) {
  for (const NumberAttribute& a : attributes) {
    const TiXmlElement* child = parent->FirstChildElement(a.child);
    const char* text = child ? child->Attribute(a.attribute) : nullptr;
    if (text == nullptr || AreFiniteNumbers(text, a.count)) continue;
    const std::string expected = a.count == 1 ? "a finite number" : std::to_string(a.count) + " finite numbers";
    Fail(file, element + " <" + a.child + ">", std::string(a.attribute) + " " + Quoted(text) + " is not " + expected);
  }
}

std::string RequiredName(const TiXmlElement* element, const char* kind, int index, const std::string& file) {
  const char* name = element->Attribute("name");
  if (name == nullptr) Fail(file, std::string(kind) + " #" + std::to_string(index + 1), "no name attribute");
  return name;
}

std::string LinkOf(const TiXmlElement* joint, const char* role, const std::string& name, const std::string& file) {
  const TiXmlElement* e = joint->FirstChildElement(role);
  const char* link = e ? e->Attribute("link") : nullptr;
  if (link == nullptr) Fail(file, JointElement(name), std::string("no <") + role + " link=\"...\">");
  return link;
}

XmlJoint ReadJoint(const TiXmlElement* e, int index, const std::string& file) {
  XmlJoint j{e, RequiredName(e, "joint", index, file), "", "", ""};
  const std::string where = JointElement(j.name);
  const char* type = e->Attribute("type");
  if (type == nullptr) Fail(file, where, "no type attribute");
  j.type = type;
  if (j.type == "floating" || j.type == "planar") {
    Fail(file, where,
         "type " + Quoted(j.type) + " is not supported (a fixed-base tree: revolute, continuous, prismatic, fixed)");
  }
  if (j.type != "revolute" && j.type != "continuous" && j.type != "prismatic" && j.type != "fixed") {
    Fail(file, where, "unknown type " + Quoted(j.type) + " (revolute, continuous, prismatic, fixed)");
  }
  if (e->FirstChildElement("mimic") != nullptr) {
    Fail(file, where + " <mimic>", "mimic joints are not supported (each moving joint is one degree of freedom)");
  }
  CheckNumbers(e, kJointNumbers, file, where);
  j.parent = LinkOf(e, "parent", j.name, file);
  j.child = LinkOf(e, "child", j.name, file);
  return j;
}

XmlRobot ReadXml(const TiXmlDocument& doc, const std::string& file) {
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) Fail(file, "<robot>", "no <robot> element at the top level");
  const char* name = robot->Attribute("name");
  if (name == nullptr) Fail(file, "<robot>", "no name attribute");
  XmlRobot xml{name, {}, {}};
  int index = 0;
  for (const TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link"), ++index) {
    xml.links.push_back(RequiredName(e, "link", index, file));
    if (const TiXmlElement* inertial = e->FirstChildElement("inertial")) {
      CheckNumbers(inertial, kInertialNumbers, file, LinkElement(xml.links.back()) + " <inertial>");
    }
  }
  index = 0;
  for (const TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint"), ++index) {
    xml.joints.push_back(ReadJoint(e, index, file));
  }
  return xml;
}

// A tree: unique names, joints between defined links, one parent per link,
// one root, every link reachable from it. Returns the root link's name.
std::string CheckTree(const XmlRobot& xml, const std::string& file) {
  const std::string robot = "robot " + Quoted(xml.name);
  if (xml.links.empty()) Fail(file, robot, "no <link>");
  std::map<std::string, std::string> parent_joint;  // link => the joint whose child it is ("" for none yet)
  for (const std::string& link : xml.links) {
    if (!parent_joint.emplace(link, "").second) Fail(file, LinkElement(link), "defined twice");
  }
  std::map<std::string, int> joints;
  for (const XmlJoint& j : xml.joints) {
    if (!joints.emplace(j.name, 0).second) Fail(file, JointElement(j.name), "defined twice");
    for (const std::string* link : {&j.parent, &j.child}) {
      if (!parent_joint.contains(*link)) Fail(file, JointElement(j.name), "link " + Quoted(*link) + " is not defined");
    }
    if (j.parent == j.child) Fail(file, JointElement(j.name), "link " + Quoted(j.child) + " is its own parent");
    std::string& previous = parent_joint[j.child];
    if (!previous.empty()) {
      Fail(file, LinkElement(j.child),
           "child of two joints (" + Quoted(previous) + " and " + Quoted(j.name) +
               "): a tree gives each link one parent");
    }
    previous = j.name;
  }
  std::vector<std::string> roots;
  for (const std::string& link : xml.links) {
    if (parent_joint[link].empty()) roots.push_back(link);
  }
  if (roots.empty()) Fail(file, robot, "no root link: the joints form a loop");
  if (roots.size() > 1) {
    Fail(file, robot,
         "several root links (" + Quoted(roots[0]) + ", " + Quoted(roots[1]) + (roots.size() > 2 ? ", ..." : "") +
             "): every link but the root needs a parent joint");
  }
  // With one parent per link and one root, a link the root cannot reach is on a loop.
  std::map<std::string, std::vector<std::string>> children;
  for (const XmlJoint& j : xml.joints) children[j.parent].push_back(j.child);
  std::map<std::string, bool> reached{{roots[0], true}};
  std::vector<std::string> stack{roots[0]};
  while (!stack.empty()) {
    const std::string link = std::move(stack.back());
    stack.pop_back();
    for (const std::string& child : children[link]) {
      reached[child] = true;
      stack.push_back(child);
    }
  }
  for (const std::string& link : xml.links) {
    if (!reached.contains(link)) {
      Fail(file, LinkElement(link), "not connected to the root link " + Quoted(roots[0]) + ": the joints form a loop");
    }
  }
  return roots[0];
}

// ---------------------------------------------------------------------------
// urdfdom, with its console_bridge messages captured instead of printed.

class CapturingHandler final : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && errors.size() < 4) errors.push_back(text);
  }
  std::vector<std::string> errors;
};

// urdfdom reports errors only through console_bridge's process-wide handler:
// for the call we install our own (and the error level) under a lock of our
// own, and restore both after. It returns null for most errors, but for a bad
// <inertial> it logs and keeps the link with zero mass, so any error refuses.
urdf::ModelInterfaceSharedPtr ParseWithUrdfdom(const std::string& text, const std::string& file,
                                               const std::string& robot) {
  static std::mutex mutex;
  const std::lock_guard lock(mutex);
  CapturingHandler handler;
  const console_bridge::LogLevel level = console_bridge::getLogLevel();
  console_bridge::useOutputHandler(&handler);
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_ERROR);
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(text);
  } catch (const std::exception& e) {
    handler.errors.push_back(e.what());
  }
  console_bridge::setLogLevel(level);
  console_bridge::restorePreviousOutputHandler();
  if (model != nullptr && handler.errors.empty()) return model;
  std::string why;
  for (const std::string& e : handler.errors) why += (why.empty() ? "" : "; ") + Printable(e, kMaxMessageChars);
  Fail(file, "robot " + Quoted(robot), "urdfdom refused it: " + (why.empty() ? "no reason given" : why));
}

// ---------------------------------------------------------------------------
// Rigid-body algebra for building the tree.

// A fixed placement: x_parent = p + R x_child.
struct Frame {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
};

Frame Compose(const Frame& a, const Frame& b) { return {a.R * b.R, a.p + a.R * b.p}; }

// urdfdom keeps <origin rpy> as the unit quaternion of R = Rz(yaw) Ry(pitch) Rx(roll).
Frame ToFrame(const urdf::Pose& pose) {
  const urdf::Rotation& r = pose.rotation;
  return {Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix(),
          Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z)};
}

// Mass, centre of mass c and inertia about c, in one frame.
struct MassProps {
  double m = 0.0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
};

// The parallel-axis term: m · Steiner(d) moves an inertia about c to c + d.
Eigen::Matrix3d Steiner(const Eigen::Vector3d& d) {
  return d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose();
}

MassProps Transformed(const MassProps& a, const Frame& f) {
  return {a.m, f.p + f.R * a.c, f.R * a.I * f.R.transpose()};
}

MassProps Combined(const MassProps& a, const MassProps& b) {
  const double m = a.m + b.m;
  if (m == 0.0) return {0.0, Eigen::Vector3d::Zero(), a.I + b.I};
  const Eigen::Vector3d c = (a.m * a.c + b.m * b.c) / m;
  return {m, c, a.I + a.m * Steiner(a.c - c) + b.I + b.m * Steiner(b.c - c)};
}

// Why a symmetric inertia is not a rigid body's (about its centre of mass), or nullopt.
std::optional<std::string> InertiaProblem(const Eigen::Matrix3d& I) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(I, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d l = solver.eigenvalues();  // ascending
  const double tolerance = kInertiaTolerance * l.cwiseAbs().maxCoeff();
  if (l[0] < -tolerance) return "inertia is not positive semi-definite (eigenvalue " + Number(l[0]) + " kg·m²)";
  if (l[0] + l[1] < l[2] - tolerance) {
    return "principal moments " + Number(l[0]) + ", " + Number(l[1]) + ", " + Number(l[2]) +
           " kg·m² violate the triangle inequality (" + Number(l[0]) + " + " + Number(l[1]) + " < " + Number(l[2]) +
           "): no rigid body has them";
  }
  return std::nullopt;
}

// A link's <inertial> in its own frame: centre of mass at <origin xyz>, the
// tensor (given in the <origin> frame) turned into link axes.
MassProps LinkMassProps(const urdf::Link& link, const std::string& file) {
  if (!link.inertial) return {};
  const urdf::Inertial& in = *link.inertial;
  const std::string where = LinkElement(link.name) + " <inertial>";
  if (in.mass < 0.0) Fail(file, where + " <mass>", "mass must be >= 0 kg, got " + Number(in.mass));
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  if (const auto why = InertiaProblem(I)) Fail(file, where + " <inertia>", *why);
  const Frame f = ToFrame(in.origin);
  return {in.mass, f.p, f.R * I * f.R.transpose()};
}

// ---------------------------------------------------------------------------
// The tree, depth-first from the root.

UrdfJointProperties JointProperties(const XmlJoint& xml, const urdf::Joint& joint, const std::string& file) {
  UrdfJointProperties p;
  const std::string where = JointElement(xml.name);
  if (const TiXmlElement* limit = xml.element->FirstChildElement("limit"); limit && joint.limits) {
    // urdfdom requires effort and velocity in <limit> and reads absent lower/upper as 0.
    p.effort = joint.limits->effort;
    p.velocity = joint.limits->velocity;
    if (joint.type != urdf::Joint::CONTINUOUS) {
      if (limit->Attribute("lower") != nullptr) p.lower = joint.limits->lower;
      if (limit->Attribute("upper") != nullptr) p.upper = joint.limits->upper;
    }
    if (*p.effort < 0.0) Fail(file, where + " <limit>", "effort must be >= 0, got " + Number(*p.effort));
    if (*p.velocity < 0.0) Fail(file, where + " <limit>", "velocity must be >= 0, got " + Number(*p.velocity));
    if (p.lower && p.upper && *p.lower > *p.upper) {
      Fail(file, where + " <limit>", "lower " + Number(*p.lower) + " is above upper " + Number(*p.upper));
    }
  }
  if (const TiXmlElement* dynamics = xml.element->FirstChildElement("dynamics"); dynamics && joint.dynamics) {
    if (dynamics->Attribute("damping") != nullptr) p.damping = joint.dynamics->damping;
    if (dynamics->Attribute("friction") != nullptr) p.friction = joint.dynamics->friction;
    if (p.damping && *p.damping < 0.0) {
      Fail(file, where + " <dynamics>", "damping must be >= 0, got " + Number(*p.damping));
    }
    if (p.friction && *p.friction < 0.0) {
      Fail(file, where + " <dynamics>", "friction must be >= 0, got " + Number(*p.friction));
    }
  }
  return p;
}

class TreeBuilder {
 public:
  TreeBuilder(const XmlRobot& xml, const urdf::ModelInterface& model, const std::string& file)
      : xml_(xml), model_(model), file_(file) {
    for (const XmlJoint& j : xml.joints) children_[j.parent].push_back(&j);
  }

  // (root link) => robot: moving joints numbered depth-first, children in file
  // order; fixed joints' links merged into the body they hang from.
  UrdfRobot Build(const std::string& root) {
    LinkMassProps(*model_.getLink(root), file_);  // checked, then ignored: the base is fixed
    std::vector<Pending> stack;
    PushChildren(root, -1, Frame{}, stack);
    while (!stack.empty()) {
      const Pending next = stack.back();
      stack.pop_back();
      Visit(next, stack);
    }
    for (std::size_t i = 0; i < parts_.size(); ++i) {
      MassProps body;
      for (const MassProps& part : parts_[i]) body = Combined(body, part);
      robot_.tree.bodies[i] = {body.m, body.c, body.I};
    }
    robot_.name = xml_.name;
    robot_.file = file_;
    return std::move(robot_);
  }

  // Child link of each moving joint, for messages.
  const std::vector<std::string>& child_links() const { return child_links_; }

 private:
  struct Pending {
    const XmlJoint* joint;
    int body;            // body the joint's parent link belongs to; −1: the world
    Frame link_in_body;  // the parent link's frame in that body's frame
  };

  void PushChildren(const std::string& link, int body, const Frame& link_in_body, std::vector<Pending>& stack) const {
    const auto it = children_.find(link);
    if (it == children_.end()) return;
    for (auto j = it->second.rbegin(); j != it->second.rend(); ++j) stack.push_back({*j, body, link_in_body});
  }

  void Visit(const Pending& at, std::vector<Pending>& stack) {
    const urdf::Joint& joint = *model_.getJoint(at.joint->name);
    const urdf::Link& child = *model_.getLink(at.joint->child);
    const Frame origin = Compose(at.link_in_body, ToFrame(joint.parent_to_joint_origin_transform));
    int body = at.body;
    Frame child_in_body = origin;  // a fixed joint: the child link rides on the same body
    if (joint.type != urdf::Joint::FIXED) {
      body = AddJoint(*at.joint, joint, at.body, origin);
      child_in_body = Frame{};
    }
    const MassProps link = LinkMassProps(child, file_);
    if (body >= 0) parts_[body].push_back(Transformed(link, child_in_body));
    PushChildren(at.joint->child, body, child_in_body, stack);
  }

  int AddJoint(const XmlJoint& xml, const urdf::Joint& joint, int parent, const Frame& origin) {
    if (robot_.tree.num_dofs() == kMaxDofs) {
      Fail(file_, "robot " + Quoted(xml_.name), "more than " + std::to_string(kMaxDofs) + " moving joints");
    }
    const Eigen::Vector3d axis(joint.axis.x, joint.axis.y, joint.axis.z);
    if (!(axis.norm() > kMinAxisNorm)) {
      Fail(file_, JointElement(xml.name) + " <axis>",
           "axis (" + Number(axis.x()) + ", " + Number(axis.y()) + ", " + Number(axis.z()) + ") has no direction");
    }
    TreeJoint j;
    j.name = xml.name;
    j.type = joint.type == urdf::Joint::PRISMATIC ? JointType::kPrismatic : JointType::kRevolute;
    j.parent = parent;
    j.position = origin.p;
    j.rotation = origin.R;
    j.axis = axis.normalized();
    robot_.tree.joints.push_back(j);
    robot_.tree.bodies.emplace_back();
    robot_.properties.push_back(JointProperties(xml, joint, file_));
    parts_.emplace_back();
    child_links_.push_back(xml.child);
    return robot_.tree.num_dofs() - 1;
  }

  const XmlRobot& xml_;
  const urdf::ModelInterface& model_;
  const std::string& file_;
  std::map<std::string, std::vector<const XmlJoint*>> children_;  // link => child joints, file order
  UrdfRobot robot_;
  std::vector<std::vector<MassProps>> parts_;  // per body: its links in the body frame
  std::vector<std::string> child_links_;
};

// Each joint must move some inertia at q = 0, else its row of M is zero: the
// composite inertia of its subtree projected on its motion, S_iᵀ I_c S_i > 0
// (the moment about a revolute axis, the mass for a prismatic joint).
void CheckEveryJointMovesInertia(const RigidTree& tree, const std::vector<std::string>& child_links,
                                 const std::string& file) {
  const int n = tree.num_dofs();
  std::vector<MassProps> composite(n);
  for (int i = 0; i < n; ++i) composite[i] = {tree.bodies[i].mass, tree.bodies[i].com, tree.bodies[i].inertia};
  for (int i = n - 1; i >= 0; --i) {  // children come after their parents
    const TreeJoint& j = tree.joints[i];
    const MassProps& s = composite[i];
    const double scale = s.I.trace() + s.m * s.c.squaredNorm();
    if (s.m == 0.0 && s.I.trace() == 0.0) {
      Fail(file, LinkElement(child_links[i]),
           "massless leaf makes the mass matrix singular (joint " + Quoted(j.name) + " moves nothing)");
    }
    const double moved =
        j.type == JointType::kPrismatic ? s.m : j.axis.dot(s.I * j.axis) + s.m * s.c.cross(j.axis).squaredNorm();
    if (moved <= kMotionInertiaTolerance * scale) {
      Fail(file, JointElement(j.name),
           j.type == JointType::kPrismatic ? "moves no mass (link " + Quoted(child_links[i]) +
                                                 " and beyond are massless), so the mass matrix is singular"
                                           : "moves no inertia (everything from link " + Quoted(child_links[i]) +
                                                 " on lies on its axis), so the mass matrix is singular");
    }
    if (j.parent >= 0) composite[j.parent] = Combined(composite[j.parent], Transformed(s, {j.rotation, j.position}));
  }
}

}  // namespace

UrdfRobot ParseUrdf(std::string_view xml, const std::string& file) {
  if (xml.find('\0') != std::string_view::npos) Fail(file, "file", "contains a NUL byte: not an XML text file");
  if (const int line = LineTooDeep(xml)) {
    Fail(file, "line " + std::to_string(line), "elements nested deeper than " + std::to_string(kMaxXmlDepth));
  }
  const std::string text(xml);
  TiXmlDocument doc;
  doc.Parse(text.c_str());
  if (doc.Error()) {
    Fail(file, "line " + std::to_string(doc.ErrorRow()) + ", column " + std::to_string(doc.ErrorCol()),
         "malformed XML (" + Printable(doc.ErrorDesc()) + ")");
  }
  const XmlRobot robot_xml = ReadXml(doc, file);
  const std::string root = CheckTree(robot_xml, file);
  const urdf::ModelInterfaceSharedPtr model = ParseWithUrdfdom(text, file, robot_xml.name);
  TreeBuilder builder(robot_xml, *model, file);
  UrdfRobot robot = builder.Build(root);
  if (robot.tree.num_dofs() == 0) {
    Fail(file, "robot " + Quoted(robot.name),
         "no moving joint (a fixed-base robot needs a revolute, continuous or prismatic joint)");
  }
  CheckEveryJointMovesInertia(robot.tree, builder.child_links(), file);
  if (const auto why = ValidateRigidTree(robot.tree)) throw UrdfError(Printable(file, file.size()) + ": " + *why);
  return robot;
}

UrdfRobot LoadUrdf(const std::string& path) {
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) Fail(path, "file", "cannot be opened (" + std::generic_category().message(errno) + ")");
  std::string text;
  char buffer[1 << 16];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, f.get())) > 0) {
    text.append(buffer, n);
    if (text.size() > kMaxUrdfBytes) Fail(path, "file", "larger than " + std::to_string(kMaxUrdfBytes >> 20) + " MiB");
  }
  if (std::ferror(f.get())) Fail(path, "file", "cannot be read (" + std::generic_category().message(errno) + ")");
  return ParseUrdf(text, path);
}

}  // namespace lagrange
