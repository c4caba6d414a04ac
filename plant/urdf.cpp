#include "plant/urdf.hpp"

#include <tinyxml.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <span>
#include <sstream>
#include <system_error>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/bounded_file.hpp"
#include "base/escape.hpp"

namespace lagrange {
namespace {

constexpr std::size_t kMaxNameChars = 64;        // of a name quoted in a message
constexpr int kMaxXmlDepth = 64;                 // element nesting; a URDF needs about 5
// Elements, links and joints: what one file may cost (its DOM, the tree's
// maps); a robot has tens of links.
constexpr std::size_t kMaxXmlElements = 65536;
constexpr std::size_t kMaxLinks = 4096;
constexpr std::size_t kMaxJoints = 4096;
constexpr double kMinAxisNorm = 1e-12;  // below this an <axis> has no direction
// A joint "moves nothing" when the inertia its motion meets is below this
// fraction of its subtree's inertia about the joint origin.
constexpr double kMotionInertiaTolerance = 1e-12;

// Text from the file, made safe for a one-line message (base/escape.hpp):
// callers print the message as it is.
std::string Printable(std::string_view text, std::size_t max_bytes = kMaxNameChars) { return Escape(text, max_bytes); }

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

// TinyXML 2.6.2 parses nested elements recursively: a file of a million
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
// The robot as the file states it, read from the one TinyXML DOM of the text.
// By hand, not by urdfdom (urdf.hpp says more): urdfdom parses only text, so
// the file would be parsed twice, and its model drops the file's joint order
// and which attributes are absent, both of which we need. What it did for us
// is done here: the numbers, the rotation of rpy, and its refusals of what we
// read.

// A fixed placement: x_parent = p + R x_child.
struct Frame {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
};

Frame Compose(const Frame& a, const Frame& b) { return {a.R * b.R, a.p + a.R * b.p}; }

// URDF's rpy, fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll), by
// its unit quaternion q = (x, y, z, w), with s and c the sine and cosine of
// half the roll (r), pitch (p) and yaw (y):
//   x = sr cp cy − cr sp sy    y = cr sp cy + sr cp sy
//   z = cr cp sy − sr sp cy    w = cr cp cy + sr sp sy
// The products are urdfdom's (urdf_model/pose.h, Rotation::setFromRPY) in its
// order, and normalised as it and then Eigen did, so a file loads to the same
// bits as when urdfdom read it.
Eigen::Matrix3d RotationFromRpy(double roll, double pitch, double yaw) {
  const double sr = std::sin(roll / 2.0), cr = std::cos(roll / 2.0);
  const double sp = std::sin(pitch / 2.0), cp = std::cos(pitch / 2.0);
  const double sy = std::sin(yaw / 2.0), cy = std::cos(yaw / 2.0);
  Eigen::Vector4d q(sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
                    cr * cp * cy + sr * sp * sy);  // x, y, z, w
  q /= std::sqrt(q.x() * q.x() + q.y() * q.y() + q.z() * q.z() + q.w() * q.w());
  return Eigen::Quaterniond(q).normalized().toRotationMatrix();
}

struct FileInertial {
  Frame origin;       // <origin>: the centre of mass (p) and the axes the tensor is given in (R), link frame
  double mass = 0.0;  // kg
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();  // about the centre of mass, <origin> axes, kg·m²
};

struct FileLink {
  std::string name;
  std::optional<FileInertial> inertial;
};

enum class FileJointType { kRevolute, kContinuous, kPrismatic, kFixed, kFloating };

// <mimic joint multiplier offset>: q = multiplier · q_joint + offset (URDF's defaults 1 and 0).
struct FileMimic {
  std::string joint;
  double multiplier = 1.0;
  double offset = 0.0;
};

struct FileJoint {
  std::string name;
  FileJointType type = FileJointType::kFixed;
  std::string parent, child;                        // link names
  Frame origin;                                     // the joint frame in the parent link's frame
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // <axis xyz> as written (absent: URDF's x)
  UrdfJointProperties properties;                   // what <limit> and <dynamics> say, absent stays nullopt
  std::optional<FileMimic> mimic;                   // <mimic>
};

struct FileRobot {
  std::string name;
  std::vector<FileLink> links;    // file order
  std::vector<FileJoint> joints;  // file order
  UrdfLooks looks;                // <visual>s: read leniently (ReadLooks), for viewers
};

// Whether `text` is exactly out.size() finite decimal numbers separated by
// white space; they go into `out`, each the double nearest to it (as strtod
// reads it in the C locale, and urdfdom did).
bool ParseFiniteNumbers(std::string_view text, std::span<double> out) {
  std::size_t found = 0;
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
    if (found == out.size() || ec != std::errc() || ptr != token.data() + token.size() || !std::isfinite(value)) {
      return false;
    }
    out[found++] = value;
    i = end;
  }
  return found == out.size();
}

// "joint 'j1'" and "limit" => "joint 'j1' <limit>": where a message points.
std::string Within(const std::string& element, std::string_view child) {
  return element + " <" + std::string(child) + ">";
}

// `attribute` of `e` as out.size() finite numbers, read into `out`: false if
// the attribute is absent, refused if it is not such numbers.
bool ReadNumbers(const TiXmlElement& e, const char* attribute, std::span<double> out, const std::string& file,
                 const std::string& where) {
  const char* text = e.Attribute(attribute);
  if (text == nullptr) return false;
  if (!ParseFiniteNumbers(text, out)) {
    const std::string expected = out.size() == 1 ? "a finite number" : std::to_string(out.size()) + " finite numbers";
    Fail(file, where, std::string(attribute) + " " + Quoted(text) + " is not " + expected);
  }
  return true;
}

std::optional<double> OptionalNumber(const TiXmlElement& e, const char* attribute, const std::string& file,
                                     const std::string& where) {
  double value = 0.0;
  if (!ReadNumbers(e, attribute, {&value, 1}, file, where)) return std::nullopt;
  return value;
}

double RequiredNumber(const TiXmlElement& e, const char* attribute, const std::string& file, const std::string& where) {
  const std::optional<double> value = OptionalNumber(e, attribute, file, where);
  if (!value) Fail(file, where, std::string("no ") + attribute + " attribute");
  return *value;
}

// <origin xyz rpy> of `parent`: the identity where it or either attribute is absent.
Frame ReadOrigin(const TiXmlElement& parent, const std::string& file, const std::string& element) {
  Frame f;
  const TiXmlElement* origin = parent.FirstChildElement("origin");
  if (origin == nullptr) return f;
  const std::string where = Within(element, "origin");
  std::array<double, 3> v{};
  if (ReadNumbers(*origin, "xyz", v, file, where)) f.p = Eigen::Vector3d(v[0], v[1], v[2]);
  if (ReadNumbers(*origin, "rpy", v, file, where)) f.R = RotationFromRpy(v[0], v[1], v[2]);
  return f;
}

// A link's <inertial>: URDF requires <mass value> and all six moments of <inertia>.
std::optional<FileInertial> ReadInertial(const TiXmlElement& link, const std::string& name, const std::string& file) {
  const TiXmlElement* inertial = link.FirstChildElement("inertial");
  if (inertial == nullptr) return std::nullopt;
  const std::string where = LinkElement(name) + " <inertial>";
  FileInertial in;
  in.origin = ReadOrigin(*inertial, file, where);
  const TiXmlElement* mass = inertial->FirstChildElement("mass");
  if (mass == nullptr) Fail(file, where, "no <mass> (an <inertial> needs <mass value> and <inertia>)");
  in.mass = RequiredNumber(*mass, "value", file, Within(where, "mass"));
  const TiXmlElement* inertia = inertial->FirstChildElement("inertia");
  if (inertia == nullptr) Fail(file, where, "no <inertia> (an <inertial> needs <mass value> and <inertia>)");
  const std::string at = Within(where, "inertia");
  const auto moment = [&](const char* attribute) { return RequiredNumber(*inertia, attribute, file, at); };
  const double ixx = moment("ixx"), ixy = moment("ixy"), ixz = moment("ixz");
  const double iyy = moment("iyy"), iyz = moment("iyz"), izz = moment("izz");
  in.I << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
  return in;
}

std::string RequiredName(const TiXmlElement& element, const char* kind, int index, const std::string& file) {
  const char* name = element.Attribute("name");
  if (name == nullptr) Fail(file, std::string(kind) + " #" + std::to_string(index + 1), "no name attribute");
  return name;
}

std::string LinkOf(const TiXmlElement& joint, const char* role, const std::string& name, const std::string& file) {
  const TiXmlElement* e = joint.FirstChildElement(role);
  const char* link = e ? e->Attribute("link") : nullptr;
  if (link == nullptr) Fail(file, JointElement(name), std::string("no <") + role + " link=\"...\">");
  return link;
}

FileJointType ReadJointType(const TiXmlElement& joint, const std::string& file, const std::string& where) {
  const char* type = joint.Attribute("type");
  if (type == nullptr) Fail(file, where, "no type attribute");
  const std::string_view t = type;
  if (t == "revolute") return FileJointType::kRevolute;
  if (t == "continuous") return FileJointType::kContinuous;
  if (t == "prismatic") return FileJointType::kPrismatic;
  if (t == "fixed") return FileJointType::kFixed;
  if (t == "floating") return FileJointType::kFloating;  // the base's: TreeBuilder::BaseLink
  if (t == "planar") {
    Fail(file, where,
         "type 'planar' is not supported (revolute, continuous, prismatic, fixed; floating for a floating base)");
  }
  Fail(file, where, "unknown type " + Quoted(t) + " (revolute, continuous, prismatic, fixed, floating)");
}

// <limit>: required on revolute and prismatic joints, and wherever it is, with
// effort and velocity. A continuous joint has no position limits, whatever it says.
void ReadLimit(const TiXmlElement& joint, FileJoint& j, const std::string& file, const std::string& where) {
  const TiXmlElement* limit = joint.FirstChildElement("limit");
  if (limit == nullptr) {
    if (j.type == FileJointType::kRevolute || j.type == FileJointType::kPrismatic) {
      Fail(file, where, "no <limit> (a revolute or prismatic joint needs <limit effort velocity>)");
    }
    return;
  }
  const std::string at = Within(where, "limit");
  UrdfJointProperties& p = j.properties;
  p.lower = OptionalNumber(*limit, "lower", file, at);
  p.upper = OptionalNumber(*limit, "upper", file, at);
  p.effort = RequiredNumber(*limit, "effort", file, at);
  p.velocity = RequiredNumber(*limit, "velocity", file, at);
  if (j.type == FileJointType::kContinuous) p.lower = p.upper = std::nullopt;
}

// <dynamics>: damping, friction or both.
void ReadDynamics(const TiXmlElement& joint, UrdfJointProperties& p, const std::string& file,
                  const std::string& where) {
  const TiXmlElement* dynamics = joint.FirstChildElement("dynamics");
  if (dynamics == nullptr) return;
  const std::string at = Within(where, "dynamics");
  p.damping = OptionalNumber(*dynamics, "damping", file, at);
  p.friction = OptionalNumber(*dynamics, "friction", file, at);
  if (!p.damping && !p.friction) Fail(file, at, "neither damping nor friction");
}

// <mimic joint="NAME" multiplier="m" offset="o"/>: on a moving joint only;
// the joint named is checked once the tree is built (ResolveMimics).
std::optional<FileMimic> ReadMimic(const TiXmlElement& joint, FileJointType type, const std::string& file,
                                   const std::string& where) {
  const TiXmlElement* e = joint.FirstChildElement("mimic");
  if (e == nullptr) return std::nullopt;
  const std::string at = Within(where, "mimic");
  if (e->NextSiblingElement("mimic") != nullptr) Fail(file, at, "more than one <mimic>");
  if (type == FileJointType::kFixed) Fail(file, at, "a fixed joint cannot mimic (it has no position to follow with)");
  if (type == FileJointType::kFloating) Fail(file, at, "a floating joint cannot mimic (it is the base's six freedoms)");
  const char* name = e->Attribute("joint");
  if (name == nullptr || *name == '\0') Fail(file, at, "no joint attribute (the joint this one follows)");
  FileMimic mimic{name};
  mimic.multiplier = OptionalNumber(*e, "multiplier", file, at).value_or(1.0);
  mimic.offset = OptionalNumber(*e, "offset", file, at).value_or(0.0);
  return mimic;
}

FileJoint ReadJoint(const TiXmlElement& e, int index, const std::string& file) {
  FileJoint j;
  j.name = RequiredName(e, "joint", index, file);
  const std::string where = JointElement(j.name);
  j.type = ReadJointType(e, file, where);
  j.mimic = ReadMimic(e, j.type, file, where);
  j.origin = ReadOrigin(e, file, where);
  if (const TiXmlElement* axis = e.FirstChildElement("axis")) {
    std::array<double, 3> v{};
    if (ReadNumbers(*axis, "xyz", v, file, Within(where, "axis"))) {
      j.axis = Eigen::Vector3d(v[0], v[1], v[2]);
    } else if (j.type != FileJointType::kFixed && j.type != FileJointType::kFloating) {
      Fail(file, Within(where, "axis"), "no xyz attribute");
    }
  }
  ReadLimit(e, j, file, where);
  ReadDynamics(e, j.properties, file, where);
  j.parent = LinkOf(e, "parent", j.name, file);
  j.child = LinkOf(e, "child", j.name, file);
  return j;
}

void CheckCount(const TiXmlElement& robot, const char* kind, std::size_t limit, const std::string& file,
                const std::string& name) {
  std::size_t count = 0;
  for (const TiXmlElement* e = robot.FirstChildElement(kind); e; e = e->NextSiblingElement(kind)) ++count;
  if (count > limit) {
    Fail(file, "robot " + Quoted(name), std::to_string(count) + " " + kind + "s, more than " + std::to_string(limit));
  }
}

// "major.minor" in decimal, equal to 1.0: the only URDF version there is to read.
bool IsVersionOne(std::string_view version) {
  const auto field = [](std::string_view digits, unsigned expected) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    return !digits.empty() && ec == std::errc() && end == digits.data() + digits.size() && value == expected;
  };
  const std::size_t dot = version.find('.');
  return dot != std::string_view::npos && field(version.substr(0, dot), 1) && field(version.substr(dot + 1), 0);
}

// ---------------------------------------------------------------------------
// How the links look (<visual>, <material>), for viewers. Read leniently: the
// dynamics never use a visual, so one that does not read is a note naming it
// and what is wrong, never a refusal of the robot. Its numbers and rpy are
// read as every other number and rpy of the file (ParseFiniteNumbers,
// RotationFromRpy).

// `attribute` of `e` as out.size() finite numbers into `out`; false when absent or not such numbers.
bool LenientNumbers(const TiXmlElement& e, const char* attribute, std::span<double> out) {
  const char* text = e.Attribute(attribute);
  return text != nullptr && ParseFiniteNumbers(text, out);
}

// <material><color rgba> of a <material>, when it gives one that reads.
std::optional<std::array<double, 4>> ColorOf(const TiXmlElement& material) {
  const TiXmlElement* color = material.FirstChildElement("color");
  std::array<double, 4> rgba{};
  if (color == nullptr || !LenientNumbers(*color, "rgba", rgba)) return std::nullopt;
  return rgba;
}

// A <visual>'s <origin> into `v`; why not, when it does not read.
std::optional<std::string> ReadVisualOrigin(const TiXmlElement& visual, UrdfVisual& v) {
  const TiXmlElement* origin = visual.FirstChildElement("origin");
  if (origin == nullptr) return std::nullopt;
  std::array<double, 3> xyz{}, rpy{};
  if ((origin->Attribute("xyz") && !LenientNumbers(*origin, "xyz", xyz)) ||
      (origin->Attribute("rpy") && !LenientNumbers(*origin, "rpy", rpy))) {
    return "<origin> is not xyz/rpy of 3 finite numbers";
  }
  v.p = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]);
  v.R = RotationFromRpy(rpy[0], rpy[1], rpy[2]);
  return std::nullopt;
}

// A <visual>'s <geometry> into `v`; why not, when it does not read.
std::optional<std::string> ReadVisualGeometry(const TiXmlElement& visual, UrdfVisual& v) {
  const TiXmlElement* geometry = visual.FirstChildElement("geometry");
  const TiXmlElement* shape = geometry ? geometry->FirstChildElement() : nullptr;
  if (shape == nullptr) return "no <geometry>";
  const std::string_view kind = shape->Value();
  std::array<double, 3> a{};
  double radius = 0.0, length = 0.0;
  if (kind == "box") {
    if (!LenientNumbers(*shape, "size", a)) return "<box size> is not 3 finite numbers";
    v.geometry = UrdfVisual::Geometry::kBox;
    v.size = Eigen::Vector3d(a[0], a[1], a[2]);
  } else if (kind == "cylinder") {
    if (!LenientNumbers(*shape, "radius", {&radius, 1}) || !LenientNumbers(*shape, "length", {&length, 1}))
      return "<cylinder> needs radius and length";
    v.geometry = UrdfVisual::Geometry::kCylinder;
    v.size = Eigen::Vector3d(radius, length, 0.0);
  } else if (kind == "sphere") {
    if (!LenientNumbers(*shape, "radius", {&radius, 1})) return "<sphere> needs a radius";
    v.geometry = UrdfVisual::Geometry::kSphere;
    v.size = Eigen::Vector3d(radius, 0.0, 0.0);
  } else if (kind == "mesh") {
    const char* filename = shape->Attribute("filename");
    if (filename == nullptr || *filename == '\0') return "<mesh> has no filename";
    if (shape->Attribute("scale") && !LenientNumbers(*shape, "scale", a)) return "<mesh scale> is not 3 finite numbers";
    if (shape->Attribute("scale")) v.scale = Eigen::Vector3d(a[0], a[1], a[2]);
    v.geometry = UrdfVisual::Geometry::kMesh;
    v.mesh = filename;
  } else {
    return "geometry " + Quoted(kind) + " is not box, cylinder, sphere or mesh";
  }
  return std::nullopt;
}

// One <visual> of `link`: into looks.visuals, or a note into looks.notes.
void ReadVisual(const TiXmlElement& visual, const std::string& link, int index,
                const std::map<std::string, std::array<double, 4>>& named, UrdfLooks& looks) {
  UrdfVisual v;
  v.link = link;
  v.index = index;
  std::optional<std::string> why = ReadVisualOrigin(visual, v);
  if (!why) why = ReadVisualGeometry(visual, v);
  if (why) {
    looks.notes.push_back(LinkElement(link) + " <visual> " + std::to_string(index) + ": " + *why);
    return;
  }
  if (const TiXmlElement* material = visual.FirstChildElement("material")) {
    const char* name = material->Attribute("name");
    if (const auto rgba = ColorOf(*material)) {
      v.rgba = *rgba;
    } else if (name != nullptr && named.contains(name)) {
      v.rgba = named.at(name);
    }
  }
  looks.visuals.push_back(std::move(v));
}

// Every link's <visual>s, the robot's named <material>s, and which link hangs from which.
UrdfLooks ReadLooks(const TiXmlElement& robot, const std::vector<FileJoint>& joints) {
  UrdfLooks looks;
  std::map<std::string, std::array<double, 4>> named;  // <material name><color> at the robot's level
  for (const TiXmlElement* m = robot.FirstChildElement("material"); m; m = m->NextSiblingElement("material")) {
    const auto rgba = ColorOf(*m);
    if (m->Attribute("name") && rgba) named[m->Attribute("name")] = *rgba;
  }
  for (const TiXmlElement* e = robot.FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const std::string link = e->Attribute("name");  // present: ReadRobot read the links first
    int index = 1;
    for (const TiXmlElement* v = e->FirstChildElement("visual"); v; v = v->NextSiblingElement("visual"), ++index) {
      ReadVisual(*v, link, index, named, looks);
    }
  }
  for (const FileJoint& j : joints) looks.links.push_back({j.parent, j.child});
  return looks;
}

FileRobot ReadRobot(const TiXmlDocument& doc, const std::string& file) {
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) Fail(file, "<robot>", "no <robot> element at the top level");
  const char* name = robot->Attribute("name");
  if (name == nullptr) Fail(file, "<robot>", "no name attribute");
  if (const char* version = robot->Attribute("version"); version != nullptr && !IsVersionOne(version)) {
    Fail(file, "robot " + Quoted(name), "version " + Quoted(version) + " is not supported (URDF 1.0)");
  }
  CheckCount(*robot, "link", kMaxLinks, file, name);
  CheckCount(*robot, "joint", kMaxJoints, file, name);
  FileRobot out{name, {}, {}, {}};
  int index = 0;
  for (const TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link"), ++index) {
    std::string link = RequiredName(*e, "link", index, file);
    std::optional<FileInertial> inertial = ReadInertial(*e, link, file);
    out.links.push_back({std::move(link), std::move(inertial)});
  }
  index = 0;
  for (const TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint"), ++index) {
    out.joints.push_back(ReadJoint(*e, index, file));
  }
  out.looks = ReadLooks(*robot, out.joints);
  return out;
}

// The one parse of the text. The DOM lives only here: the robot is copied out of it.
FileRobot ReadText(const std::string& text, const std::string& file) {
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
std::string CheckTree(const FileRobot& robot, const std::string& file) {
  const std::string where = "robot " + Quoted(robot.name);
  if (robot.links.empty()) Fail(file, where, "no <link>");
  std::map<std::string, std::string> parent_joint;  // link => the joint whose child it is ("" for none yet)
  for (const FileLink& link : robot.links) {
    if (!parent_joint.emplace(link.name, "").second) Fail(file, LinkElement(link.name), "defined twice");
  }
  std::map<std::string, int> joints;
  for (const FileJoint& j : robot.joints) {
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
  for (const FileLink& link : robot.links) {
    if (parent_joint[link.name].empty()) roots.push_back(link.name);
  }
  if (roots.empty()) Fail(file, where, "no root link: the joints form a loop");
  if (roots.size() > 1) {
    Fail(file, where,
         "several root links (" + Quoted(roots[0]) + ", " + Quoted(roots[1]) + (roots.size() > 2 ? ", ..." : "") +
             "): every link but the root needs a parent joint");
  }
  // With one parent per link and one root, a link the root cannot reach is on a loop.
  std::map<std::string, std::vector<std::string>> children;
  for (const FileJoint& j : robot.joints) children[j.parent].push_back(j.child);
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
  for (const FileLink& link : robot.links) {
    if (!reached.contains(link.name)) {
      Fail(file, LinkElement(link.name),
           "not connected to the root link " + Quoted(roots[0]) + ": the joints form a loop");
    }
  }
  return roots[0];
}

// ---------------------------------------------------------------------------
// Rigid-body algebra for building the tree.

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
MassProps LinkMassProps(const FileLink& link, const std::string& file) {
  if (!link.inertial) return {};
  const FileInertial& in = *link.inertial;
  const std::string where = LinkElement(link.name) + " <inertial>";
  if (in.mass < 0.0) Fail(file, Within(where, "mass"), "mass must be >= 0 kg, got " + Number(in.mass));
  if (const auto why = CheckRotationalInertia(in.I)) Fail(file, Within(where, "inertia"), *why);
  const Frame& f = in.origin;
  return {in.mass, f.p, f.R * in.I * f.R.transpose()};
}

// ---------------------------------------------------------------------------
// The tree, depth-first from the root.

// A moving joint's <limit> and <dynamics>: effort, velocity, damping and
// friction >= 0, lower <= upper.
const UrdfJointProperties& CheckedProperties(const FileJoint& joint, const std::string& file) {
  const UrdfJointProperties& p = joint.properties;
  const std::string limit = Within(JointElement(joint.name), "limit");
  const std::string dynamics = Within(JointElement(joint.name), "dynamics");
  if (p.effort && *p.effort < 0.0) Fail(file, limit, "effort must be >= 0, got " + Number(*p.effort));
  if (p.velocity && *p.velocity < 0.0) Fail(file, limit, "velocity must be >= 0, got " + Number(*p.velocity));
  if (p.lower && p.upper && *p.lower > *p.upper) {
    Fail(file, limit, "lower " + Number(*p.lower) + " is above upper " + Number(*p.upper));
  }
  if (p.damping && *p.damping < 0.0) Fail(file, dynamics, "damping must be >= 0, got " + Number(*p.damping));
  if (p.friction && *p.friction < 0.0) Fail(file, dynamics, "friction must be >= 0, got " + Number(*p.friction));
  return p;
}

class TreeBuilder {
 public:
  TreeBuilder(const FileRobot& robot, const std::string& file) : robot_(robot), file_(file) {
    for (const FileLink& link : robot.links) links_[link.name] = &link;
    for (const FileJoint& j : robot.joints) children_[j.parent].push_back(&j);
  }

  // (root link) => robot: moving joints numbered depth-first, children in file
  // order; fixed joints' links merged into the body they hang from (the base,
  // for links fixed to a floating base's link).
  UrdfRobot Build(const std::string& root, const UrdfOptions& options) {
    const std::string base = BaseLink(root, options);
    const MassProps base_link = LinkMassProps(*links_.at(base), file_);  // a fixed base's: checked, then ignored
    if (base != root) LinkMassProps(*links_.at(root), file_);            // the world's: checked, then ignored
    out_.tree.floating_base = options.floating_base;
    base_parts_.push_back(base_link);
    std::vector<Pending> stack;
    out_.tree.frames.push_back({base, -1, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()});
    PushChildren(base, -1, Frame{}, stack);
    while (!stack.empty()) {
      const Pending next = stack.back();
      stack.pop_back();
      Visit(next, stack);
    }
    ResolveMimics();
    for (std::size_t i = 0; i < parts_.size(); ++i) out_.tree.bodies[i] = Merged(parts_[i]);
    if (options.floating_base) {
      out_.tree.base = Merged(base_parts_);
      if (!(out_.tree.base.mass > 0.0)) {
        Fail(file_, LinkElement(base),
             "a floating base needs mass > 0 kg (its <inertial> and those of links fixed to it), got " +
                 Number(out_.tree.base.mass));
      }
    }
    out_.name = robot_.name;
    out_.file = file_;
    out_.looks = robot_.looks;
    return std::move(out_);
  }

  // Child link of each moving joint, for messages.
  const std::vector<std::string>& child_links() const { return child_links_; }

 private:
  static RigidBody Merged(const std::vector<MassProps>& parts) {
    MassProps body;
    for (const MassProps& part : parts) body = Combined(body, part);
    return {body.m, body.c, body.I};
  }

  // The link the tree starts from: the root link, or, when the root link's
  // joint is floating, its child (the root link is then the world: it must
  // have that joint alone, placed at the identity, and floating_base on).
  std::string BaseLink(const std::string& root, const UrdfOptions& options) const {
    const auto it = children_.find(root);
    if (it == children_.end()) return root;
    const FileJoint* floating = nullptr;
    for (const FileJoint* j : it->second) {
      if (j->type == FileJointType::kFloating) floating = j;
    }
    if (floating == nullptr) return root;
    const std::string where = JointElement(floating->name);
    if (!options.floating_base) {
      Fail(file_, where,
           "type 'floating' makes a floating-base robot: read it with floating_base (lagrangectl eval "
           "--floating-base)");
    }
    if (it->second.size() > 1) {
      Fail(file_, where,
           "a floating joint must be the root link " + Quoted(root) + "'s only joint (the root link is the world; " +
               JointElement(it->second[it->second[0] == floating ? 1 : 0]->name) + " would fix a second tree to it)");
    }
    if (!floating->origin.p.isZero(0.0) || !floating->origin.R.isIdentity(0.0)) {
      Fail(file_, Within(where, "origin"),
           "a floating joint's <origin> must be the identity (q places the base " + Quoted(floating->child) +
               " in the world)");
    }
    return floating->child;
  }

  struct Pending {
    const FileJoint* joint;
    int body;            // body the joint's parent link belongs to; −1: the world
    Frame link_in_body;  // the parent link's frame in that body's frame
  };

  void PushChildren(const std::string& link, int body, const Frame& link_in_body, std::vector<Pending>& stack) const {
    const auto it = children_.find(link);
    if (it == children_.end()) return;
    for (auto j = it->second.rbegin(); j != it->second.rend(); ++j) stack.push_back({*j, body, link_in_body});
  }

  void Visit(const Pending& at, std::vector<Pending>& stack) {
    const FileJoint& joint = *at.joint;
    if (joint.type == FileJointType::kFloating) {
      Fail(file_, JointElement(joint.name),
           "a floating joint is read only from the root link (its parent here is " + LinkElement(joint.parent) +
               "): a tree has one floating base, at its root");
    }
    const Frame origin = Compose(at.link_in_body, joint.origin);
    int body = at.body;
    Frame child_in_body = origin;  // a fixed joint: the child link rides on the same body
    if (joint.type != FileJointType::kFixed) {
      body = AddJoint(joint, at.body, origin);
      child_in_body = Frame{};
    }
    const MassProps link = LinkMassProps(*links_.at(joint.child), file_);
    (body >= 0 ? parts_[body] : base_parts_).push_back(Transformed(link, child_in_body));
    out_.tree.frames.push_back({joint.child, body, child_in_body.p, child_in_body.R});
    PushChildren(joint.child, body, child_in_body, stack);
  }

  int AddJoint(const FileJoint& joint, int parent, const Frame& origin) {
    if (out_.tree.num_joints() == kMaxDofs) {
      Fail(file_, "robot " + Quoted(robot_.name), "more than " + std::to_string(kMaxDofs) + " moving joints");
    }
    const Eigen::Vector3d& axis = joint.axis;
    if (!(axis.norm() > kMinAxisNorm)) {
      Fail(file_, Within(JointElement(joint.name), "axis"),
           "axis (" + Number(axis.x()) + ", " + Number(axis.y()) + ", " + Number(axis.z()) + ") has no direction");
    }
    TreeJoint j;
    j.name = joint.name;
    j.type = joint.type == FileJointType::kPrismatic ? JointType::kPrismatic : JointType::kRevolute;
    j.parent = parent;
    j.position = origin.p;
    j.rotation = origin.R;
    j.axis = axis.normalized();
    const UrdfJointProperties& properties = CheckedProperties(joint, file_);
    if (joint.mimic) {
      j.multiplier = joint.mimic->multiplier;
      j.offset = joint.mimic->offset;
      mimics_.push_back({out_.tree.num_joints(), &joint});  // resolved once every joint is in
    } else {
      out_.properties.push_back(properties);  // a mimic's own <limit> and <dynamics> are not used
    }
    out_.tree.joints.push_back(j);
    out_.tree.bodies.emplace_back();
    parts_.emplace_back();
    child_links_.push_back(joint.child);
    return out_.tree.num_joints() - 1;
  }

  // Each mimic's followed joint by name: a moving joint of the tree that is
  // itself a degree of freedom.
  void ResolveMimics() {
    std::map<std::string_view, int> index;  // moving joint name => index
    for (int i = 0; i < out_.tree.num_joints(); ++i) index[out_.tree.joints[static_cast<std::size_t>(i)].name] = i;
    std::map<std::string_view, const FileJoint*> file_joints;
    for (const FileJoint& j : robot_.joints) file_joints[j.name] = &j;
    for (const auto& [i, joint] : mimics_) {
      const std::string at = Within(JointElement(joint->name), "mimic");
      const std::string& name = joint->mimic->joint;
      const auto it = index.find(name);
      if (name == joint->name) Fail(file_, at, "the joint follows itself");
      if (it == index.end()) {
        Fail(file_, at,
             file_joints.count(name) != 0
                 ? "follows joint " + Quoted(name) + ", which is fixed or not in the tree (it must move)"
                 : "follows joint " + Quoted(name) + ", which the robot does not have");
      }
      const FileJoint& followed = *file_joints.at(name);
      if (followed.mimic) {
        Fail(file_, at,
             followed.mimic->joint == joint->name
                 ? "follows joint " + Quoted(name) + ", which follows this one (a cycle of mimics)"
                 : "follows joint " + Quoted(name) + ", itself a mimic of " + Quoted(followed.mimic->joint) +
                       " (chains of mimics are not supported: follow " + Quoted(followed.mimic->joint) +
                       " with the product of the multipliers)");
      }
      out_.tree.joints[static_cast<std::size_t>(i)].mimic = it->second;
    }
  }

  const FileRobot& robot_;
  const std::string& file_;
  std::map<std::string, const FileLink*> links_;                   // name => link
  std::map<std::string, std::vector<const FileJoint*>> children_;  // link => child joints, file order
  UrdfRobot out_;
  std::vector<std::vector<MassProps>> parts_;  // per body: its links in the body frame
  std::vector<MassProps> base_parts_;          // the base's links in its frame (ignored for a fixed base)
  std::vector<std::string> child_links_;
  std::vector<std::pair<int, const FileJoint*>> mimics_;  // (joint index, its file joint) of each mimic
};

// Each joint must move some inertia at q = 0, else its row of M is zero: the
// composite inertia of its subtree projected on its motion, S_iᵀ I_c S_i > 0
// (the moment about a revolute axis, the mass for a prismatic joint).
void CheckEveryJointMovesInertia(const RigidTree& tree, const std::vector<std::string>& child_links,
                                 const std::string& file) {
  const int n = tree.num_joints();
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

UrdfRobot ParseUrdf(std::string_view xml, const std::string& file, const UrdfOptions& options) {
  CheckXmlText(xml, file);
  const std::string text(xml);
  const FileRobot read = ReadText(text, file);
  const std::string root = CheckTree(read, file);
  TreeBuilder builder(read, file);
  UrdfRobot robot = builder.Build(root, options);
  if (robot.tree.num_dofs() == 0 && !options.floating_base) {
    Fail(file, "robot " + Quoted(robot.name),
         "no moving joint (a fixed-base robot needs a revolute, continuous or prismatic joint)");
  }
  CheckEveryJointMovesInertia(robot.tree, builder.child_links(), file);
  const auto why = options.floating_base ? ValidateFloatingTree(robot.tree) : ValidateRigidTree(robot.tree);
  if (why) throw UrdfError(Printable(file, file.size()) + ": " + *why);
  return robot;
}

std::string ReadUrdfFile(const std::string& path) {
  try {
    return ReadBoundedFile(path, kMaxUrdfBytes);
  } catch (const FileReadError& e) {
    Fail(path, "file", e.what());
  }
}

UrdfRobot LoadUrdf(const std::string& path, const UrdfOptions& options) {
  return ParseUrdf(ReadUrdfFile(path), path, options);
}

}  // namespace lagrange
