#include "tools/urdf_visuals.hpp"

#include <tinyxml.h>

#include <Eigen/Geometry>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "plant/escape.hpp"

namespace lagrange::cli {
namespace {

namespace fs = std::filesystem;

// `count` finite numbers separated by white space, or nullopt.
std::optional<std::vector<double>> Numbers(const char* text, std::size_t count) {
  if (text == nullptr) return std::nullopt;
  std::vector<double> out;
  const std::string_view s(text);
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i == s.size()) break;
    std::size_t end = i;
    while (end < s.size() && !std::isspace(static_cast<unsigned char>(s[end]))) ++end;
    std::size_t start = i + (s[i] == '+' ? 1 : 0);
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data() + start, s.data() + end, v);
    if (ec != std::errc() || ptr != s.data() + end || !std::isfinite(v)) return std::nullopt;
    out.push_back(v);
    i = end;
  }
  if (out.size() != count) return std::nullopt;
  return out;
}

// Built by appending: g++ 12 warns falsely (-Wrestrict) on "'" + std::string.
std::string Quoted(const char* text) {
  std::string q(1, '\'');
  q += Escape(text ? text : "");
  q += '\'';
  return q;
}

// The file a mesh's filename names, or "" with `why` set.
std::string ResolveMesh(const std::string& name, const fs::path& urdf_dir, const std::vector<std::string>& package_path,
                        std::string& why) {
  std::error_code error;
  const std::string package = "package://", file = "file://";
  std::vector<fs::path> candidates;
  if (name.rfind(package, 0) == 0) {
    const std::string rest = name.substr(package.size());
    for (const std::string& dir : package_path) candidates.push_back(fs::path(dir) / rest);
    if (package_path.empty()) {
      why = "not found (no --package-path given for package:// URLs)";
      return "";
    }
  } else if (name.rfind(file, 0) == 0) {
    candidates.push_back(name.substr(file.size()));
  } else if (fs::path(name).is_absolute()) {
    candidates.push_back(name);
  } else {
    candidates.push_back(urdf_dir / name);
  }
  for (const fs::path& c : candidates) {
    if (fs::is_regular_file(c, error)) return c.lexically_normal().string();
  }
  why = "not found (looked for";
  for (const fs::path& c : candidates) {
    why += ' ';
    why += Escape(c.string());
  }
  why += ")";
  return "";
}

std::string LowerExtension(const std::string& file) {
  std::string ext = fs::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

UrdfLooks ReadUrdfLooks(const std::string& path, const std::vector<std::string>& package_path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + Escape(path));
  std::ostringstream text;
  text << in.rdbuf();
  TiXmlDocument doc;
  doc.Parse(text.str().c_str(), nullptr, TIXML_ENCODING_UTF8);
  UrdfLooks looks;
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (doc.Error() || robot == nullptr) throw std::runtime_error(Escape(path) + ": not a URDF robot");
  const fs::path dir = fs::path(path).parent_path();

  std::map<std::string, std::array<double, 4>> named;  // <material name><color> at the robot level
  for (const TiXmlElement* m = robot->FirstChildElement("material"); m; m = m->NextSiblingElement("material")) {
    const TiXmlElement* color = m->FirstChildElement("color");
    const auto rgba = color ? Numbers(color->Attribute("rgba"), 4) : std::nullopt;
    if (m->Attribute("name") && rgba) named[m->Attribute("name")] = {(*rgba)[0], (*rgba)[1], (*rgba)[2], (*rgba)[3]};
  }
  for (const TiXmlElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const TiXmlElement* parent = j->FirstChildElement("parent");
    const TiXmlElement* child = j->FirstChildElement("child");
    if (parent && child && parent->Attribute("link") && child->Attribute("link"))
      looks.links.push_back({parent->Attribute("link"), child->Attribute("link")});
  }
  for (const TiXmlElement* link = robot->FirstChildElement("link"); link; link = link->NextSiblingElement("link")) {
    const std::string name = link->Attribute("name") ? link->Attribute("name") : "";
    int index = 0;
    for (const TiXmlElement* v = link->FirstChildElement("visual"); v; v = v->NextSiblingElement("visual"), ++index) {
      const std::string where = "link " + Quoted(name.c_str()) + " <visual> " + std::to_string(index + 1);
      UrdfVisual visual;
      visual.link = name;
      if (const TiXmlElement* origin = v->FirstChildElement("origin")) {
        const auto xyz = origin->Attribute("xyz") ? Numbers(origin->Attribute("xyz"), 3) : std::vector<double>{0, 0, 0};
        const auto rpy = origin->Attribute("rpy") ? Numbers(origin->Attribute("rpy"), 3) : std::vector<double>{0, 0, 0};
        if (!xyz || !rpy) {
          looks.missing.push_back(where + ": <origin> is not xyz/rpy of 3 finite numbers; not drawn");
          continue;
        }
        visual.p = Eigen::Vector3d((*xyz)[0], (*xyz)[1], (*xyz)[2]);
        // URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
        visual.R = (Eigen::AngleAxisd((*rpy)[2], Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd((*rpy)[1], Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd((*rpy)[0], Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
      }
      if (const TiXmlElement* material = v->FirstChildElement("material")) {
        const TiXmlElement* color = material->FirstChildElement("color");
        if (const auto rgba = color ? Numbers(color->Attribute("rgba"), 4) : std::nullopt) {
          visual.rgba = {(*rgba)[0], (*rgba)[1], (*rgba)[2], (*rgba)[3]};
        } else if (material->Attribute("name") && named.count(material->Attribute("name"))) {
          visual.rgba = named.at(material->Attribute("name"));
        }
      }
      const TiXmlElement* geometry = v->FirstChildElement("geometry");
      const TiXmlElement* shape = geometry ? geometry->FirstChildElement() : nullptr;
      if (shape == nullptr) {
        looks.missing.push_back(where + ": no <geometry>; not drawn");
        continue;
      }
      const std::string kind = shape->Value();
      if (kind == "box") {
        const auto size = Numbers(shape->Attribute("size"), 3);
        if (!size) {
          looks.missing.push_back(where + ": <box size> is not 3 finite numbers; not drawn");
          continue;
        }
        visual.kind = UrdfVisual::Kind::kBox;
        visual.size = Eigen::Vector3d((*size)[0], (*size)[1], (*size)[2]);
      } else if (kind == "cylinder") {
        const auto radius = Numbers(shape->Attribute("radius"), 1), length = Numbers(shape->Attribute("length"), 1);
        if (!radius || !length) {
          looks.missing.push_back(where + ": <cylinder> needs radius and length; not drawn");
          continue;
        }
        visual.kind = UrdfVisual::Kind::kCylinder;
        visual.size = Eigen::Vector3d((*radius)[0], (*length)[0], 0.0);
      } else if (kind == "sphere") {
        const auto radius = Numbers(shape->Attribute("radius"), 1);
        if (!radius) {
          looks.missing.push_back(where + ": <sphere> needs a radius; not drawn");
          continue;
        }
        visual.kind = UrdfVisual::Kind::kSphere;
        visual.size = Eigen::Vector3d((*radius)[0], 0.0, 0.0);
      } else if (kind == "mesh") {
        const char* filename = shape->Attribute("filename");
        const std::string mesh = filename ? filename : "";
        if (shape->Attribute("scale")) {
          const auto scale = Numbers(shape->Attribute("scale"), 3);
          if (!scale) {
            looks.missing.push_back(where + ": <mesh scale> is not 3 finite numbers; not drawn");
            continue;
          }
          visual.scale = Eigen::Vector3d((*scale)[0], (*scale)[1], (*scale)[2]);
        }
        std::string why;
        visual.mesh_file = ResolveMesh(mesh, dir, package_path, why);
        const std::string ext = LowerExtension(mesh);
        if (visual.mesh_file.empty()) {
          looks.missing.push_back(where + ": mesh " + Quoted(mesh.c_str()) + " " + why + "; its frame is drawn");
          continue;
        }
        if (ext != ".stl" && ext != ".dae") {
          looks.missing.push_back(where + ": mesh " + Quoted(mesh.c_str()) +
                                  " is neither STL nor Collada (.dae); its frame is drawn");
          continue;
        }
        visual.kind = UrdfVisual::Kind::kMesh;
        visual.mesh_format = ext.substr(1);
      } else {
        looks.missing.push_back(where + ": geometry " + Quoted(kind.c_str()) + " is not box, cylinder, sphere or mesh; not drawn");
        continue;
      }
      looks.visuals.push_back(std::move(visual));
    }
  }
  return looks;
}

}  // namespace lagrange::cli
