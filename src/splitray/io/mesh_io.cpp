#include "splitray/io/mesh_io.hpp"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <cmath>
#include <filesystem>
#include <limits>
#include <new>
#include <optional>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/io/assimp_buffer_io.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/materials.hpp"
#include "splitray/io/read_file.hpp"
#include "splitray/io/triangulate.hpp"

namespace splitray {
namespace {

// Sanity limits against hostile node graphs that instance one mesh without end, and against
// polygons built to make ear clipping slow (about a second of work).
constexpr std::size_t kMaxTriangles = std::size_t{1} << 28;
constexpr std::size_t kMaxNodeVisits = 10'000'000;
constexpr int kMaxNodeDepth = 1000;
constexpr std::uint64_t kMaxTriangulationWork = 500'000'000;

bool finite(const aiVector3D& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Before any post-processing: joining identical vertices compares coordinates, and a NaN
// could be merged away into (or hide behind) a finite vertex.
void check_finite(const aiScene& scene, const std::string& path) {
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[m];
    for (unsigned v = 0; v < mesh.mNumVertices; ++v)
      if (!finite(mesh.mVertices[v]))
        throw Error(path, "vertex " + std::to_string(v) + " of mesh " + std::to_string(m) +
                              " has a NaN or infinite coordinate");
  }
}

struct Part {
  std::size_t first_vertex, vertex_count, first_face, face_count;
  bool has_normals, has_uvs;
};

// Area-weighted normals for one part's vertices, from that part's faces only.
void compute_part_normals(Mesh& mesh, const Part& part) {
  Mesh piece;
  piece.positions.assign(mesh.positions.begin() + part.first_vertex,
                         mesh.positions.begin() + part.first_vertex + part.vertex_count);
  for (std::size_t f = part.first_face; f < part.first_face + part.face_count; ++f) {
    auto face = mesh.faces[f];
    for (auto& i : face) i -= static_cast<std::uint32_t>(part.first_vertex);
    piece.faces.push_back(face);
  }
  piece.compute_vertex_normals();
  std::copy(piece.normals.begin(), piece.normals.end(), mesh.normals.begin() + part.first_vertex);
}

class Merger {
 public:
  Merger(const aiScene& scene, const std::string& path) : scene_(scene), path_(path) {}

  Mesh run() {
    // Depth-first over the node graph with an explicit stack (no recursion on hostile depth).
    struct Item {
      const aiNode* node;
      aiMatrix4x4 world;
      int depth;
    };
    std::vector<Item> stack{{scene_.mRootNode, aiMatrix4x4{}, 0}};
    std::size_t visits = 0;
    while (!stack.empty()) {
      const Item item = stack.back();
      stack.pop_back();
      if (++visits > kMaxNodeVisits) throw Error(path_, "the node graph is too large or cyclic");
      if (item.depth > kMaxNodeDepth)
        throw Error(path_,
                    "the node graph is deeper than " + std::to_string(kMaxNodeDepth) + " levels");
      const aiMatrix4x4 world = item.world * item.node->mTransformation;
      for (unsigned k = 0; k < item.node->mNumMeshes; ++k)
        add(*scene_.mMeshes[item.node->mMeshes[k]], world);
      // Children pushed in reverse so that they are visited in file order.
      for (unsigned c = item.node->mNumChildren; c-- > 0;)
        stack.push_back({item.node->mChildren[c], world, item.depth + 1});
    }
    if (mesh_.faces.empty()) {
      if (skipped_ > 0)
        throw Error(path_, "the file has no triangles (only " + std::to_string(skipped_) +
                               " points and lines)");
      throw Error(path_, "the file has no triangles");
    }
    finish_normals();
    return std::move(mesh_);
  }

  std::size_t skipped() const { return skipped_; }
  // After run(): texture coordinates per vertex (empty when no part has any) and assimp's
  // material index per face.
  std::vector<Vec2> uvs() {
    if (!uvs_.empty()) uvs_.resize(vertex_count_);
    return std::move(uvs_);
  }
  std::vector<std::uint32_t> face_materials() { return std::move(face_materials_); }

 private:
  void add(const aiMesh& in, const aiMatrix4x4& world) {
    if (mesh_.positions.size() + in.mNumVertices > std::numeric_limits<std::uint32_t>::max())
      throw Error(path_, "more than 2^32 vertices");
    const bool identity = world.IsIdentity();
    const aiMatrix3x3 normal_matrix = aiMatrix3x3(world).Inverse().Transpose();
    Part part{mesh_.positions.size(), in.mNumVertices,       mesh_.faces.size(), 0,
              in.HasNormals(),        in.HasTextureCoords(0)};
    for (unsigned v = 0; v < in.mNumVertices; ++v) {
      const aiVector3D p = identity ? in.mVertices[v] : world * in.mVertices[v];
      mesh_.positions.push_back({p.x, p.y, p.z});
    }
    if (part.has_normals) {
      mesh_.normals.resize(mesh_.positions.size());
      for (unsigned v = 0; v < in.mNumVertices; ++v) {
        aiVector3D n = identity ? in.mNormals[v] : normal_matrix * in.mNormals[v];
        const float len = n.Length();
        // An unusable normal (zero, NaN, or a singular transform) makes the part's normals
        // computed instead: normals only shade, they are not geometry.
        if (!(len > 0) || !std::isfinite(len))
          part.has_normals = false;
        else
          n /= len;
        mesh_.normals[part.first_vertex + v] = {n.x, n.y, n.z};
      }
    }
    if (part.has_uvs) {
      uvs_.resize(mesh_.positions.size());
      for (unsigned v = 0; v < in.mNumVertices; ++v)
        uvs_[part.first_vertex + v] = {in.mTextureCoords[0][v].x, in.mTextureCoords[0][v].y};
    }
    const auto base = static_cast<std::uint32_t>(part.first_vertex);
    for (unsigned f = 0; f < in.mNumFaces; ++f) {
      const aiFace& face = in.mFaces[f];
      if (face.mNumIndices < 3) {  // points and lines: not surfaces
        ++skipped_;
        continue;
      }
      if (face.mNumIndices == 3) {
        mesh_.faces.push_back(
            {base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
        ++part.face_count;
        continue;
      }
      // Quads and polygons, in the mesh's own space (the node transform is affine).
      corners_.clear();
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        const aiVector3D& v = in.mVertices[face.mIndices[k]];
        corners_.push_back({v.x, v.y, v.z});
      }
      local_.clear();
      work_ += triangulate_polygon(corners_, local_);
      if (work_ > kMaxTriangulationWork)
        throw Error(path_,
                    "the polygons are too large or contorted to triangulate in reasonable time");
      for (const auto& t : local_)
        mesh_.faces.push_back(
            {base + face.mIndices[t[0]], base + face.mIndices[t[1]], base + face.mIndices[t[2]]});
      part.face_count += local_.size();
    }
    face_materials_.resize(mesh_.faces.size(), in.mMaterialIndex);
    if (mesh_.faces.size() > kMaxTriangles)
      throw Error(path_, "more than " + std::to_string(kMaxTriangles) +
                             " triangles after applying the node graph");
    parts_.push_back(part);
  }

  // Normals are kept when the file has them; parts without (or with unusable) normals get
  // computed ones, unless no part has any: then the mesh has none and shading uses the
  // geometric normal.
  void finish_normals() {
    bool any = false;
    for (const Part& p : parts_) any = any || p.has_normals;
    vertex_count_ = mesh_.positions.size();
    if (!any) {
      mesh_.normals.clear();
      return;
    }
    mesh_.normals.resize(mesh_.positions.size());
    for (const Part& p : parts_)
      if (!p.has_normals) compute_part_normals(mesh_, p);
  }

  const aiScene& scene_;
  const std::string& path_;
  Mesh mesh_;
  std::vector<Part> parts_;
  std::size_t skipped_ = 0;
  std::size_t vertex_count_ = 0;
  std::vector<Vec2> uvs_;
  std::vector<std::uint32_t> face_materials_;
  std::vector<Vec3> corners_;
  std::vector<std::array<std::uint32_t, 3>> local_;
  std::uint64_t work_ = 0;
};

// assimp's messages may quote pages of the file: keep them short and on one line.
std::string clean(std::string message) {
  for (char& c : message)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = ' ';
  if (message.size() > 200) message = message.substr(0, 200) + "...";
  return message;
}

// Triangles in assimp's meshes once polygons are triangulated (n corners: n - 2).
std::size_t count_triangles(const aiScene& scene) {
  std::size_t n = 0;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m)
    for (unsigned f = 0; f < scene.mMeshes[m]->mNumFaces; ++f) {
      const unsigned corners = scene.mMeshes[m]->mFaces[f].mNumIndices;
      n += corners >= 3 ? corners - 2 : 0;
    }
  return n;
}

const aiScene* import(Assimp::Importer& importer, const std::string& name, unsigned flags,
                      const std::string& path, bool post_process) {
  try {
    const aiScene* scene =
        post_process ? importer.ApplyPostProcessing(flags) : importer.ReadFile(name, flags);
    if (!scene) throw Error(path, "assimp cannot read it: " + clean(importer.GetErrorString()));
    return scene;
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw Error(path, "out of memory while reading (absurd counts in the file?)");
  } catch (const std::exception& e) {
    throw Error(path, "assimp cannot read it: " + clean(e.what()));
  }
}

// The file has materials of its own: more than assimp's stand-in for files without any.
bool has_own_materials(const aiScene& scene) {
  if (scene.mNumMaterials == 0) return false;
  return scene.mNumMaterials > 1 ||
         std::string(scene.mMaterials[0]->GetName().C_Str()) != AI_DEFAULT_MATERIAL_NAME;
}

}  // namespace

Mesh load_mesh(const std::string& path, const MeshLoadOptions& options) {
  const std::string extension = inner_extension(path);
  if (extension.empty())
    throw Error(path, "the file name has no extension, so the mesh format is unknown");
  // The bytes outlive the importer, which reads them through its IOSystem.
  const Bytes bytes = read_maybe_gzipped(path);
  Assimp::Importer importer;
  if (!importer.IsExtensionSupported("." + extension))
    throw Error(path, "'." + extension + "' is not a mesh format that assimp reads");
  const std::optional<std::size_t> expected = check_mesh_format(bytes, extension, path);
  if (expected == 0u) throw Error(path, "the file has no triangles (it lists no faces)");

  // assimp sees the content under the name without .gz: the format comes from the inner
  // extension and referenced files resolve beside the original.
  const std::string name = has_gz_suffix(path) ? path.substr(0, path.size() - 3) : path;
  const std::string folder = std::filesystem::path(path).parent_path().string();
  const std::string root =
      options.references_root.empty() ? (folder.empty() ? "." : folder) : options.references_root;
  auto* io = new BufferIOSystem(name, bytes, root);
  importer.SetIOHandler(io);  // owned by the importer
  importer.SetPropertyBool(AI_CONFIG_IMPORT_NO_SKELETON_MESHES, true);
  // A refused reference (outside the folder) is named, whatever assimp made of its absence.
  const auto check_references = [&] {
    if (!io->refused().empty())
      throw Error(path, "refers to the file " + io->refused() +
                            ", which lies outside the folder of the model; refusing to read it");
  };

  const aiScene* scene = [&] {
    try {
      return import(importer, name, aiProcess_ValidateDataStructure, path, false);
    } catch (const Error&) {
      check_references();
      throw;
    }
  }();
  check_references();
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || scene->mNumMeshes == 0)
    throw Error(path, "the file holds no meshes");
  check_finite(*scene, path);
  // Share identical vertices. Deliberately absent: Triangulate (wrong for some concave
  // polygons in assimp 5.2; the Merger triangulates), FindDegenerates (degenerate triangles
  // are valid input), PreTransformVertices (the Merger applies the node graph itself).
  scene = import(importer, name, aiProcess_JoinIdenticalVertices | aiProcess_ValidateDataStructure,
                 path, true);

  if (expected && *expected != count_triangles(*scene))
    throw Error(
        path,
        "the file describes " + std::to_string(*expected) + " triangles but assimp made " +
            std::to_string(count_triangles(*scene)) +
            " of them (it dropped faces with an index out of range?); refusing a changed mesh");

  Merger merger(*scene, path);
  Mesh mesh = merger.run();
  mesh.name = path;
  if (options.materials) {
    mesh.uvs = merger.uvs();
    if (has_own_materials(*scene)) {
      std::vector<std::string> ignored;
      const std::vector<Material> all = convert_materials(
          *scene, folder, root, path, options.warnings ? *options.warnings : ignored);
      // Only the materials faces use (assimp adds a stand-in first, files list unused ones),
      // renumbered in order of first use.
      mesh.face_materials = merger.face_materials();
      std::vector<std::uint32_t> index(all.size(), kInvalidId);
      for (std::uint32_t& m : mesh.face_materials) {
        if (index[m] == kInvalidId) {
          index[m] = static_cast<std::uint32_t>(mesh.materials.size());
          mesh.materials.push_back(all[m]);
        }
        m = index[m];
      }
    }
  }
  mesh.validate(path);
  return mesh;
}

}  // namespace splitray
