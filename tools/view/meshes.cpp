#include "tools/view/meshes.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>

#include "base/escape.hpp"

namespace lagrange::cli::view {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kHeadBytes = 4096;  // read of a mesh to check it when the view starts

bool StartsWith(std::string_view text, std::size_t at, std::string_view prefix) {
  return at <= text.size() && text.substr(at).starts_with(prefix);
}

std::size_t SkipSpace(std::string_view text, std::size_t at) {
  while (at < text.size() && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
  return at;
}

std::string CheckStl(std::string_view head, std::uintmax_t size) {
  if (size >= 84 && head.size() >= 84) {
    std::uint32_t triangles = 0;  // little-endian, after the 80-byte header
    for (int k = 3; k >= 0; --k) triangles = (triangles << 8) | static_cast<unsigned char>(head[80 + k]);
    if (size == 84 + 50 * static_cast<std::uintmax_t>(triangles)) return "";
  }
  const std::size_t at = SkipSpace(head, 0);
  if (StartsWith(head, at, "solid") && (at + 5 == head.size() || std::isspace(static_cast<unsigned char>(head[at + 5]))))
    return "";
  return std::string("is not an STL file (neither binary, whose 80-byte header and triangle count account for its ") +
         std::to_string(size) + " bytes, nor ASCII, starting 'solid')";
}

// XML whose root element is <COLLADA>: past a byte-order mark, white space, the declaration, processing
// instructions, comments and a doctype.
std::string CheckCollada(std::string_view head) {
  std::size_t at = StartsWith(head, 0, "\xEF\xBB\xBF") ? 3 : 0;
  for (;;) {
    at = SkipSpace(head, at);
    const char* end = StartsWith(head, at, "<?") ? "?>" : StartsWith(head, at, "<!--") ? "-->"
                      : StartsWith(head, at, "<!")  ? ">"
                                                     : nullptr;
    if (end == nullptr) break;
    const std::size_t close = head.find(end, at + 2);
    if (close == std::string_view::npos) break;
    at = close + std::strlen(end);
  }
  const std::size_t after = at + 8;
  if (StartsWith(head, at, "<COLLADA") &&
      (after == head.size() || std::isspace(static_cast<unsigned char>(head[after])) || head[after] == '>' ||
       head[after] == '/'))
    return "";
  return std::string("is not a Collada file (no <COLLADA> root element in its first ") +
         std::to_string(kHeadBytes / 1024) + " KiB)";
}

std::string LowerExtension(const std::string& file) {
  std::string ext = fs::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// Up to `max` bytes of an open file.
std::string ReadUpTo(int fd, std::size_t max) {
  std::string bytes(max, '\0');
  std::size_t got = 0;
  while (got < max) {
    const ssize_t n = read(fd, bytes.data() + got, max - got);
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

// The file at `canonical`, opened without following a symlink (nor blocking on a FIFO): checked as a
// `format` mesh; or why not.
std::variant<MeshFile, std::string> Inspect(const fs::path& canonical, MeshFormat format) {
  const int fd = open(canonical.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return std::string("cannot be opened (") + std::strerror(errno) + ")";
  struct stat st {};
  std::string why;
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    why = "is not a regular file";
  } else if (static_cast<std::uintmax_t>(st.st_size) > kMaxMeshBytes) {
    why = std::string("is larger than ") + std::to_string(kMaxMeshBytes >> 20) + " MiB";
  } else {
    why = CheckMeshBytes(ReadUpTo(fd, kHeadBytes), static_cast<std::uintmax_t>(st.st_size), format);
  }
  close(fd);
  if (!why.empty()) return why;
  return MeshFile{canonical.string(), format, st.st_dev, st.st_ino};
}

// Whether `path` is `root` or lies under it, component by component (both canonical).
bool Under(const fs::path& path, const fs::path& root) {
  return std::mismatch(root.begin(), root.end(), path.begin(), path.end()).first == root.end();
}

}  // namespace

std::string CheckMeshBytes(std::string_view head, std::uintmax_t size, MeshFormat format) {
  return format == MeshFormat::kStl ? CheckStl(head, size) : CheckCollada(head);
}

MeshRoots::MeshRoots(const std::string& urdf_file, const std::vector<std::string>& package_path)
    : urdf_dir_(fs::path(urdf_file).parent_path()), package_path_(package_path) {
  std::error_code error;
  for (const fs::path& dir : std::vector<fs::path>{urdf_dir_.empty() ? fs::path(".") : urdf_dir_}) {
    if (fs::path root = fs::canonical(dir, error); !error) roots_.push_back(std::move(root));
  }
  for (const std::string& dir : package_path) {
    if (fs::path root = fs::canonical(dir, error); !error) roots_.push_back(std::move(root));
  }
}

std::vector<fs::path> MeshRoots::Candidates(const std::string& name, std::string& why) const {
  const std::string package = "package://", file = "file://";
  if (name.rfind(package, 0) == 0) {
    if (package_path_.empty()) why = "not found (no --package-path given for package:// URLs)";
    std::vector<fs::path> candidates;
    for (const std::string& dir : package_path_) candidates.push_back(fs::path(dir) / name.substr(package.size()));
    return candidates;
  }
  if (name.rfind(file, 0) == 0) return {fs::path(name.substr(file.size()))};
  if (fs::path(name).is_absolute()) return {fs::path(name)};
  return {urdf_dir_ / name};
}

bool MeshRoots::Confined(const fs::path& canonical) const {
  return std::any_of(roots_.begin(), roots_.end(), [&](const fs::path& root) { return Under(canonical, root); });
}

std::variant<MeshFile, std::string> MeshRoots::Find(const std::string& filename) const {
  const std::string ext = LowerExtension(filename);
  if (ext != ".stl" && ext != ".dae") return std::string("is neither STL nor Collada (.dae)");
  const MeshFormat format = ext == ".stl" ? MeshFormat::kStl : MeshFormat::kCollada;
  std::string why;
  const std::vector<fs::path> candidates = Candidates(filename, why);
  if (!why.empty()) return why;
  for (const fs::path& c : candidates) {
    std::error_code error;
    const fs::path canonical = fs::canonical(c, error);  // every symlink and ".." resolved; missing: an error
    if (error) continue;
    if (!Confined(canonical))
      return std::string("leads outside the URDF's folder and every --package-path: not served "
                         "(give its package's root as --package-path)");
    return Inspect(canonical, format);
  }
  why = "not found (looked for";
  for (const fs::path& c : candidates) {
    why += ' ';
    why += Escape(c.lexically_normal().string());
  }
  return why + ")";
}

std::optional<std::string> ReadMesh(const MeshFile& mesh) {
  const int fd = open(mesh.path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  struct stat st {};
  std::optional<std::string> bytes;
  if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_dev == mesh.device && st.st_ino == mesh.inode &&
      static_cast<std::uintmax_t>(st.st_size) <= kMaxMeshBytes) {
    bytes = ReadUpTo(fd, static_cast<std::size_t>(st.st_size));
    if (!CheckMeshBytes(*bytes, bytes->size(), mesh.format).empty()) bytes.reset();
  }
  close(fd);
  return bytes;
}

}  // namespace lagrange::cli::view
