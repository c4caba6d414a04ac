#include "plant/urdf.hpp"

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

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

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "plant/escape.hpp"

namespace lagrange {
namespace {

constexpr std::size_t kMaxUrdfBytes = 2u << 20;  // a real robot's URDF is well under 1 MiB
constexpr std::size_t kMaxNameChars = 64;        // of a name quoted in a message
constexpr std::size_t kMaxMessageChars = 240;    // of one urdfdom message relayed
constexpr int kMaxXmlDepth = 64;                 // element nesting; a URDF needs about 5
// Elements, links and joints: two DOMs of a big file cost gigabytes, and
// urdfdom frees a long chain of links recursively.
constexpr std::size_t kMaxXmlElements = 65536;
constexpr std::size_t kMaxLinks = 4096;
constexpr std::size_t kMaxJoints = 4096;
constexpr double kMinAxisNorm = 1e-12;  // below this an <axis> has no direction
// A joint "moves nothing" when the inertia its motion meets is below this
// fraction of its subtree's inertia about the joint origin.
constexpr double kMotionInertiaTolerance = 1e-12;

// Text from the file, made safe for a one-line message (plant/escape.hpp):
// callers print the message as it is.
std::string Printable(std::string_view text, std::size_t max_bytes = kMaxNameChars) {
  return Escape(text, max_bytes);
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

// tinyxml 2.6.2 (ours, and urdfdom's) parses nested elements recursively: a file of a million
// nested tags overflows the stack. A URDF nests five deep or so; the text is
// scanned first the way tinyxml tokenises it, so its depth here is never below
// tinyxml's while tinyxml goes on parsing (where tinyxml stops at an error,
// what follows does not matter). With valid UTF-8 and no U+FEFF, U+FFFE or
// U+FFFF after the start (checked before), tinyxml's UTF-8 and legacy modes
// split the text at the same bytes:
//   "<?xml" (any case)  a declaration: to a '>' outside the quoted values of
//                       its version, encoding and standalone attributes
//   "<!--"              to the next "-->" after it
//   "<![CDATA["         to the next "]]>" after it
//   "</"                an end tag, to '>': depth − 1, never below 0 (at the
//                       top level tinyxml reads it as an unknown node)
//   "<" letter, '_' or a byte >= 0x7f   a start tag, to a '>' outside quoted
//                       values: depth + 1 unless it ends "/>"
//   "<" anything else   an unknown node ("<!DOCTYPE", "<?pi", "<1"), to '>'
bool IsXmlSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r'; }
bool StartsXmlName(unsigned char c) { return c >= 0x7F || std::isalpha(c) || c == '_'; }
bool InXmlName(unsigned char c) { return StartsXmlName(c) || std::isdigit(c) || c == '-' || c == '.' || c == ':'; }

bool StartsWithNoCase(std::string_view text, std::string_view prefix) {
  return text.size() >= prefix.size() && std::equal(prefix.begin(), prefix.end(), text.begin(), [](char a, char b) {
           return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
         });
}

// Past tinyxml's declaration whose "<?xml" ends before `i`; text.size() where tinyxml stops.
std::size_t PastDeclaration(std::string_view t, std::size_t i) {
  const std::size_t n = t.size();
  const auto skip_space = [&] {
    while (i < n && IsXmlSpace(t[i])) ++i;
  };
  while (i < n) {
    if (t[i] == '>') return i + 1;
    skip_space();
    const std::string_view rest = t.substr(i);
    if (StartsWithNoCase(rest, "version") || StartsWithNoCase(rest, "encoding") ||
        StartsWithNoCase(rest, "standalone")) {
      while (i < n && InXmlName(static_cast<unsigned char>(t[i]))) ++i;
      skip_space();
      if (i == n || t[i] != '=') return n;
      ++i;
      skip_space();
      if (i < n && (t[i] == '"' || t[i] == '\'')) {
        const std::size_t close = t.find(t[i], i + 1);
        if (close == std::string_view::npos) return n;
        i = close + 1;
      } else {
        for (; i < n && !IsXmlSpace(t[i]) && t[i] != '/' && t[i] != '>'; ++i) {
          if (t[i] == '"' || t[i] == '\'') return n;
        }
      }
    } else {
      while (i < n && t[i] != '>' && !IsXmlSpace(t[i])) ++i;
    }
  }
  return n;
}

struct XmlShape {
  std::size_t too_deep_at = std::string_view::npos;  // offset of the first element deeper than kMaxXmlDepth
  std::size_t elements = 0;                          // start tags
};

XmlShape ScanXml(std::string_view t) {
  XmlShape shape;
  int depth = 0;
  const auto past = [&](std::size_t from, std::string_view end) {
    const std::size_t at = t.find(end, from);
    return at == std::string_view::npos ? t.size() : at + end.size();
  };
  for (std::size_t i = t.find('<'); i != std::string_view::npos; i = t.find('<', i)) {
    const std::string_view rest = t.substr(i);
    if (StartsWithNoCase(rest, "<?xml")) {
      i = PastDeclaration(t, i + 5);
    } else if (rest.starts_with("<!--")) {
      i = past(i + 4, "-->");
    } else if (rest.starts_with("<![CDATA[")) {
      i = past(i + 9, "]]>");
    } else if (rest.starts_with("</")) {
      depth = std::max(depth - 1, 0);
      i = past(i + 2, ">");
    } else if (rest.size() > 1 && StartsXmlName(static_cast<unsigned char>(rest[1]))) {
      std::size_t end = i + 1;
      for (char quote = 0; end < t.size() && (quote || t[end] != '>'); ++end) {
        if (quote) {
          quote = t[end] == quote ? 0 : quote;
        } else if (t[end] == '"' || t[end] == '\'') {
          quote = t[end];
        }
      }
      ++shape.elements;
      if (end < t.size() && t[end - 1] != '/' && ++depth > kMaxXmlDepth) {
        shape.too_deep_at = i;
        return shape;
      }
      i = std::min(end + 1, t.size());
    } else {
      i = past(i + 1, ">");
    }
  }
  return shape;
}

// The offset of the first byte that does not belong to valid UTF-8, or npos.
std::size_t InvalidUtf8At(std::string_view t) {
  for (std::size_t i = 0; i < t.size();) {
    const auto c = static_cast<unsigned char>(t[i]);
    const int length = c < 0x80                 ? 1
                       : c >= 0xC2 && c <= 0xDF ? 2
                       : c >= 0xE0 && c <= 0xEF ? 3
                       : c >= 0xF0 && c <= 0xF4 ? 4
                                                : 0;
    if (length == 0 || i + length > t.size()) return i;
    for (int k = 1; k < length; ++k) {
      if ((static_cast<unsigned char>(t[i + k]) & 0xC0) != 0x80) return i;
    }
    const auto c1 = static_cast<unsigned char>(t[i + 1 < t.size() ? i + 1 : i]);
    if ((c == 0xE0 && c1 < 0xA0) || (c == 0xED && c1 >= 0xA0) || (c == 0xF0 && c1 < 0x90) ||
        (c == 0xF4 && c1 >= 0x90)) {
      return i;  // overlong, a surrogate, or above U+10FFFF
    }
    i += length;
  }
  return std::string_view::npos;
}

std::string LineOf(std::string_view t, std::size_t at) {
  return "line " + std::to_string(1 + std::count(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// What must hold before tinyxml sees the text (see ScanXml).
void CheckXmlText(std::string_view t, const std::string& file) {
  if (t.size() > kMaxUrdfBytes) Fail(file, "file", "larger than " + std::to_string(kMaxUrdfBytes >> 20) + " MiB");
  if (t.find('\0') != std::string_view::npos) Fail(file, "file", "contains a NUL byte: not an XML text file");
  if (const std::size_t at = InvalidUtf8At(t); at != std::string_view::npos) {
    char byte[8];
    std::snprintf(byte, sizeof byte, "0x%02x", static_cast<unsigned char>(t[at]));
    Fail(file, LineOf(t, at), std::string("not UTF-8 text (byte ") + byte + ")");
  }
  for (const char* bom : {"\xEF\xBB\xBF", "\xEF\xBF\xBE", "\xEF\xBF\xBF"}) {
    if (const std::size_t at = t.find(bom, 1); at != std::string_view::npos) {
      Fail(file, LineOf(t, at),
           "U+FEFF, U+FFFE or U+FFFF after the start of the file (tinyxml takes it for white space)");
    }
  }
  const XmlShape shape = ScanXml(t);
  if (shape.too_deep_at != std::string_view::npos) {
    Fail(file, LineOf(t, shape.too_deep_at), "elements nested deeper than " + std::to_string(kMaxXmlDepth));
  }
  if (shape.elements > kMaxXmlElements) {
    Fail(file, "file", std::to_string(shape.elements) + " XML elements, more than " + std::to_string(kMaxXmlElements));
  }
}

// ---------------------------------------------------------------------------
// The XML, read first: what urdfdom does not keep (file order, which
// attributes are present), and checks whose messages should name the element.

struct XmlJoint {
  std::string name, type, parent, child;
  // Which of <limit lower upper> and <dynamics damping friction> the file
  // gives: urdfdom reads an absent one as 0.
  bool limit = false, lower = false, upper = false, dynamics = false, damping = false, friction = false;
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
  XmlJoint j;
  j.name = RequiredName(e, "joint", index, file);
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
  if (const TiXmlElement* limit = e->FirstChildElement("limit")) {
    j.limit = true;
    j.lower = limit->Attribute("lower") != nullptr;
    j.upper = limit->Attribute("upper") != nullptr;
  }
  if (const TiXmlElement* dynamics = e->FirstChildElement("dynamics")) {
    j.dynamics = true;
    j.damping = dynamics->Attribute("damping") != nullptr;
    j.friction = dynamics->Attribute("friction") != nullptr;
  }
  return j;
}

void CheckCount(const TiXmlElement* robot, const char* kind, std::size_t limit, const std::string& file,
                const std::string& name) {
  std::size_t count = 0;
  for (const TiXmlElement* e = robot->FirstChildElement(kind); e; e = e->NextSiblingElement(kind)) ++count;
  if (count > limit) {
    Fail(file, "robot " + Quoted(name), std::to_string(count) + " " + kind + "s, more than " + std::to_string(limit));
  }
}

XmlRobot ReadRobot(const TiXmlDocument& doc, const std::string& file) {
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) Fail(file, "<robot>", "no <robot> element at the top level");
  const char* name = robot->Attribute("name");
  if (name == nullptr) Fail(file, "<robot>", "no name attribute");
  CheckCount(robot, "link", kMaxLinks, file, name);
  CheckCount(robot, "joint", kMaxJoints, file, name);
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

// Our DOM lives only here: what we need is copied out before urdfdom builds its own.
XmlRobot ReadXml(const std::string& text, const std::string& file) {
  TiXmlDocument doc;
  doc.Parse(text.c_str());
  if (doc.Error()) {
    Fail(file, "line " + std::to_string(doc.ErrorRow()) + ", column " + std::to_string(doc.ErrorCol()),
         "malformed XML (" + Printable(doc.ErrorDesc()) + ")");
  }
  return ReadRobot(doc, file);
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

// A link's <inertial> in its own frame: centre of mass at <origin xyz>, the
// tensor (given in the <origin> frame) turned into link axes.
MassProps LinkMassProps(const urdf::Link& link, const std::string& file) {
  if (!link.inertial) return {};
  const urdf::Inertial& in = *link.inertial;
  const std::string where = LinkElement(link.name) + " <inertial>";
  if (in.mass < 0.0) Fail(file, where + " <mass>", "mass must be >= 0 kg, got " + Number(in.mass));
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  if (const auto why = CheckRotationalInertia(I)) Fail(file, where + " <inertia>", *why);
  const Frame f = ToFrame(in.origin);
  return {in.mass, f.p, f.R * I * f.R.transpose()};
}

// ---------------------------------------------------------------------------
// The tree, depth-first from the root.

UrdfJointProperties JointProperties(const XmlJoint& xml, const urdf::Joint& joint, const std::string& file) {
  UrdfJointProperties p;
  const std::string where = JointElement(xml.name);
  if (xml.limit && joint.limits) {
    // urdfdom requires effort and velocity in <limit> and reads absent lower/upper as 0.
    p.effort = joint.limits->effort;
    p.velocity = joint.limits->velocity;
    if (joint.type != urdf::Joint::CONTINUOUS) {
      if (xml.lower) p.lower = joint.limits->lower;
      if (xml.upper) p.upper = joint.limits->upper;
    }
    if (*p.effort < 0.0) Fail(file, where + " <limit>", "effort must be >= 0, got " + Number(*p.effort));
    if (*p.velocity < 0.0) Fail(file, where + " <limit>", "velocity must be >= 0, got " + Number(*p.velocity));
    if (p.lower && p.upper && *p.lower > *p.upper) {
      Fail(file, where + " <limit>", "lower " + Number(*p.lower) + " is above upper " + Number(*p.upper));
    }
  }
  if (xml.dynamics && joint.dynamics) {
    if (xml.damping) p.damping = joint.dynamics->damping;
    if (xml.friction) p.friction = joint.dynamics->friction;
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
  CheckXmlText(xml, file);
  const std::string text(xml);
  const XmlRobot robot_xml = ReadXml(text, file);
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

namespace {

std::string FileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a file";
}

class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

std::string SystemReason(int error) { return std::generic_category().message(error); }

}  // namespace

UrdfRobot LoadUrdf(const std::string& path) {
  // Non-blocking: opening a FIFO for reading would wait for a writer. Only a regular file is read.
  const FileDescriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
  if (fd.get() < 0) {
    const int error = errno;
    Fail(path, "file", "cannot be opened (" + SystemReason(error) + ")");
  }
  struct stat status {};
  if (::fstat(fd.get(), &status) != 0) {
    const int error = errno;
    Fail(path, "file", "cannot be read (" + SystemReason(error) + ")");
  }
  if (!S_ISREG(status.st_mode)) Fail(path, "file", "not a regular file (" + FileKind(status.st_mode) + ")");
  std::string text;
  char buffer[1 << 16];
  while (true) {
    const ssize_t n = ::read(fd.get(), buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      Fail(path, "file", "cannot be read (" + SystemReason(error) + ")");
    }
    if (n == 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
    if (text.size() > kMaxUrdfBytes) Fail(path, "file", "larger than " + std::to_string(kMaxUrdfBytes >> 20) + " MiB");
  }
  return ParseUrdf(text, path);
}

}  // namespace lagrange
