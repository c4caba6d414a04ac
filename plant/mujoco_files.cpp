#include "plant/mujoco_files.hpp"

#include <mujoco/mujoco.h>
#include <tinyxml2.h>

#include <cstring>
#include <map>
#include <stdexcept>
#include <utility>

#include "base/bounded_file.hpp"

namespace lagrange {
namespace {

[[noreturn]] void Refuse(const std::string& model, const std::string& why) {
  throw std::invalid_argument(model + ": " + why);
}

std::string NameOf(const std::string& path) { return path.substr(path.find_last_of('/') + 1); }

// "/d/world.xml" => "/d/", "world.xml" => "": what MuJoCo puts before a name the model gives.
std::string DirectoryOf(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

bool IsAbsolute(const std::string& path) { return !path.empty() && path[0] == '/'; }

std::string Bound(std::size_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// A file the model names, found while walking it, read once the compiler's settings are known.
struct Reference {
  std::string element;   // <mesh file="F">, for messages
  std::string file;      // F
  bool texture = false;  // under texturedir, else meshdir
};

// What <compiler> says of where files are (the last element to say it wins, as in MuJoCo's reader).
struct Directories {
  std::string meshdir, texturedir;
  bool strippath = false;
};

class FileReader {
 public:
  FileReader(std::string model_path, std::string model_text)
      : model_(std::move(model_path)), directory_(DirectoryOf(model_)) {
    total_ = model_text.size();
    names_[NameOf(model_)] = model_;
    files_.push_back({model_, NameOf(model_), std::move(model_text)});
  }

  std::vector<MujocoFile> Read() {
    auto doc = std::make_unique<tinyxml2::XMLDocument>();
    const std::string& text = files_[0].data;
    // A model tinyxml2 cannot parse, MuJoCo (which parses it with tinyxml2 too) refuses before reading more.
    if (doc->Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS || doc->RootElement() == nullptr) {
      return std::move(files_);
    }
    const tinyxml2::XMLElement* root = doc->RootElement();
    if (std::strcmp(root->Name(), "robot") == 0) {
      WalkUrdf(*root);
    } else {
      Walk(*root);
    }
    for (const Reference& r : references_) ReadAsset(r);
    return std::move(files_);
  }

 private:
  // Every element under `e`, includes read and walked where they stand.
  void Walk(const tinyxml2::XMLElement& e) {
    const char* name = e.Name();
    if (std::strcmp(name, "include") == 0) {
      if (const char* file = e.Attribute("file")) ReadInclude(file);
    } else if (std::strcmp(name, "compiler") == 0) {
      if (const char* v = e.Attribute("meshdir")) directories_.meshdir = v;
      if (const char* v = e.Attribute("texturedir")) directories_.texturedir = v;
      if (const char* v = e.Attribute("strippath")) directories_.strippath = std::strcmp(v, "true") == 0;
    } else if (std::strcmp(name, "mesh") == 0 || std::strcmp(name, "skin") == 0 || std::strcmp(name, "hfield") == 0) {
      Refer(e, "file", false);
    } else if (std::strcmp(name, "texture") == 0) {
      for (const char* a : {"file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback"}) {
        Refer(e, a, true);
      }
    }
    for (const tinyxml2::XMLElement* c = e.FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) Walk(*c);
  }

  // A URDF as MuJoCo imports it: strippath forced; <collision> meshes only.
  void WalkUrdf(const tinyxml2::XMLElement& robot) {
    directories_.strippath = true;
    for (const tinyxml2::XMLElement* m = robot.FirstChildElement("mujoco"); m != nullptr;
         m = m->NextSiblingElement("mujoco")) {
      for (const tinyxml2::XMLElement* c = m->FirstChildElement("compiler"); c != nullptr;
           c = c->NextSiblingElement("compiler")) {
        if (const char* v = c->Attribute("meshdir")) directories_.meshdir = v;
      }
    }
    WalkUrdfCollisions(robot);
  }
  void WalkUrdfCollisions(const tinyxml2::XMLElement& e) {
    for (const tinyxml2::XMLElement* c = e.FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
      if (std::strcmp(c->Name(), "collision") == 0) {
        if (const tinyxml2::XMLElement* g = c->FirstChildElement("geometry")) {
          for (const tinyxml2::XMLElement* m = g->FirstChildElement("mesh"); m != nullptr;
               m = m->NextSiblingElement("mesh")) {
            Refer(*m, "filename", false);
          }
        }
      } else {
        WalkUrdfCollisions(*c);
      }
    }
  }

  void Refer(const tinyxml2::XMLElement& e, const char* attribute, bool texture) {
    const char* file = e.Attribute(attribute);
    if (file == nullptr) return;
    std::string element(1, '<');
    element.append(e.Name()).append(" ").append(attribute).append("=\"").append(file).append("\">");
    references_.push_back({std::move(element), file, texture});
  }

  // MuJoCo 2.2.2: the model's directory + F, whatever F is.
  void ReadInclude(const std::string& file) {
    const std::string path = directory_ + file;
    const std::string element = "<include file=\"" + file + "\">";
    if (!Add(element, path, kMaxMujocoXmlBytes)) return;  // read already: MuJoCo says it is included twice
    const std::string& text = files_.back().data;
    auto doc = std::make_unique<tinyxml2::XMLDocument>();
    if (doc->Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS || doc->RootElement() == nullptr) return;
    Walk(*doc->RootElement());
  }

  // MuJoCo 2.2.2: F (its name alone under strippath); if relative, under the
  // compiler's directory, itself under the model's directory if relative.
  void ReadAsset(const Reference& r) {
    const std::string file = directories_.strippath ? NameOf(r.file) : r.file;
    std::string path = file;
    if (!IsAbsolute(file)) {
      std::string dir = r.texture ? directories_.texturedir : directories_.meshdir;
      if (!dir.empty() && dir.back() != '/') dir += '/';
      path = (IsAbsolute(dir) ? dir : directory_ + dir) + file;
    }
    Add(r.element, path, kMaxMujocoAssetBytes);
  }

  // Reads `path` (named by `element`) within `max_bytes` and the model's
  // bounds; false when it was read already.
  bool Add(const std::string& element, const std::string& path, std::size_t max_bytes) {
    const std::string name = NameOf(path);
    if (const auto it = names_.find(name); it != names_.end()) {
      if (it->second == path) return false;
      Refuse(model_, element + ": " + path + " and " + it->second + " share the name '" + name +
                         "', and MuJoCo 2.2.2 holds one file per name in memory: expected distinct names");
    }
    if (files_.size() >= static_cast<std::size_t>(mjMAXVFS)) {
      Refuse(model_, element + ": more than " + std::to_string(mjMAXVFS) + " files, MuJoCo 2.2.2's most in memory");
    }
    std::string data;
    try {
      data = ReadBoundedFile(path, max_bytes);
    } catch (const FileReadError& e) {
      Refuse(model_, element + ": " + path + ": " + e.what());
    }
    // MuJoCo's VFS takes no empty file (mj_makeEmptyFileVFS ends the process), and no model, mesh or image is empty.
    if (data.empty()) Refuse(model_, element + ": " + path + ": empty");
    total_ += data.size();
    if (total_ > kMaxMujocoModelBytes) {
      Refuse(model_,
             element + ": " + path + ": the model's files together are larger than " + Bound(kMaxMujocoModelBytes));
    }
    names_[name] = path;
    files_.push_back({path, name, std::move(data)});
    return true;
  }

  const std::string model_, directory_;
  std::vector<MujocoFile> files_;
  std::map<std::string, std::string> names_;  // name => path of every file read
  std::size_t total_ = 0;
  Directories directories_;
  std::vector<Reference> references_;
};

}  // namespace

std::string ReadMujocoModelText(const std::string& model_path) {
  std::string text;
  try {
    text = ReadBoundedFile(model_path, kMaxMujocoXmlBytes);
  } catch (const FileReadError& e) {
    Refuse(model_path, e.what());
  }
  if (text.empty()) Refuse(model_path, "empty: expected an MJCF or URDF model");
  return text;
}

std::vector<MujocoFile> ReadMujocoFiles(const std::string& model_path, std::string model_text) {
  return FileReader(model_path, std::move(model_text)).Read();
}

void MujocoVfsDeleter::operator()(mjVFS_* vfs) const {
  mj_deleteVFS(vfs);
  delete vfs;
}

MujocoVfs MakeMujocoVfs(const std::string& model_path, const std::vector<MujocoFile>& files) {
  MujocoVfs vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  for (const MujocoFile& f : files) {
    // Not empty (ReadMujocoFiles): MuJoCo 2.2.2 ends the process for an empty file.
    if (f.data.empty() || mj_makeEmptyFileVFS(vfs.get(), f.name.c_str(), static_cast<int>(f.data.size())) != 0) {
      Refuse(model_path, f.path + ": MuJoCo could not hold it in memory");
    }
    std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), f.name.c_str())], f.data.data(), f.data.size());
  }
  return vfs;
}

}  // namespace lagrange
