#pragma once
// The files of a MuJoCo model, read as lagrange reads a URDF
// (base/bounded_file.hpp) before MuJoCo sees any of them: only regular
// files, opened without blocking (a FIFO would wait for a writer forever),
// each up to a bound. Part of lagrange_mujoco.
//
// MuJoCo 2.2.2 reads a model's files itself, with fopen and no bound: the
// model, its <include>s, meshes, textures, height fields and skins. Given a
// virtual file system (mjVFS: mj_loadXML(file, vfs, ...)) it takes each from
// there instead, looked up by its name without the directory, and opens no
// file. So lagrange finds every file the model names, resolved as MuJoCo
// 2.2.2 resolves it (each rule checked against its own reads):
//   <include file="F">                    the model's directory + F, nested includes alike (F as written)
//   <mesh|skin|hfield file="F">           <compiler meshdir="D">: D + F, D relative to the model's directory
//                                         unless absolute; F itself when absolute
//   <texture file|fileright|..="F">       <compiler texturedir> likewise
//   <compiler strippath="true">           F's name alone (forced for a URDF)
//   a URDF (root <robot>)                 the <mesh filename> of its <collision>s (MuJoCo discards its
//                                         <visual>s unread), meshdir from its <mujoco><compiler>
// reads each, and MuJoCo loads them from memory. The XML is walked with
// tinyxml2, MuJoCo's own parser: a file it cannot parse is handed to MuJoCo
// as it is, which then refuses it with its own message before reading further.
//
// Bounds: an XML file (the model, an include) as a URDF, kMaxMujocoXmlBytes
// (2 MiB); a mesh, texture, height field or skin kMaxMujocoAssetBytes
// (64 MiB); all of them together kMaxMujocoModelBytes (256 MiB); at most
// mjMAXVFS (2000) files. MuJoCo's VFS holds one file per name, so two files
// of one name in different directories are refused; and no empty file (2.2.2
// ends the process for one), so an empty file is refused (no model, mesh or
// image is empty).
//
// Errors: std::invalid_argument, one line naming the model and the file:
//   "/d/world.xml: larger than 2 MiB"
//   "/d/world.xml: <include file="parts.xml">: /d/parts.xml: not a regular file (a FIFO)"

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "plant/urdf.hpp"

struct mjVFS_;  // MuJoCo's (mujoco/mjmodel.h)

namespace lagrange {

inline constexpr std::size_t kMaxMujocoXmlBytes = kMaxUrdfBytes;  // a URDF's bound (plant/urdf.hpp): 2 MiB
inline constexpr std::size_t kMaxMujocoAssetBytes = 64u << 20;    // a mesh, texture, height field or skin
inline constexpr std::size_t kMaxMujocoModelBytes = 256u << 20;   // every file of the model together

struct MujocoFile {
  std::string path;  // as read (the model's directory joined as MuJoCo joins it)
  std::string name;  // the name MuJoCo looks it up by: the path's last component
  std::string data;
};

// The model file and every file it names, files[0] the model. `model_text`
// is the model's content as MuJoCo is to read it (lagrange may have edited
// it: ReadMujocoModelText, then the edits); what it names is found in it.
std::vector<MujocoFile> ReadMujocoFiles(const std::string& model_path, std::string model_text);

// The model file alone, bounded as above. Throws std::invalid_argument "FILE: why".
std::string ReadMujocoModelText(const std::string& model_path);

// A VFS holding `files` (mj_deleteVFS'd with it; 2 MB of names: on the heap).
struct MujocoVfsDeleter {
  void operator()(mjVFS_* vfs) const;
};
using MujocoVfs = std::unique_ptr<mjVFS_, MujocoVfsDeleter>;
MujocoVfs MakeMujocoVfs(const std::string& model_path, const std::vector<MujocoFile>& files);

}  // namespace lagrange
