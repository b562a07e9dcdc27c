// Triangle meshes for vehicle insertion: an indexed triangle list in double
// precision and readers for PLY (ascii, binary little/big endian), Wavefront
// OBJ and glTF 2.0 (.gltf / .glb, through tinygltf).
//
// Readers keep the file's coordinates verbatim (no unit or axis change);
// polygons are fan-triangulated (v0, vi, vi+1). Bad input throws
// scene::InputError "<file>: <where>: <what>" where <where> is a header line,
// an element ("face 17"), an OBJ line or a glTF object ("mesh 0 primitive 1").
// glTF assets are y-up by the glTF spec; gltf_y_up_to_z_up() turns them into
// the engine's z-up convention.
#pragma once

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace icube::world {

struct TriangleMesh {
  std::vector<glm::dvec3> positions;
  std::vector<glm::uvec3> triangles;  // indices into positions
};

struct MeshBounds {
  glm::dvec3 min{0.0}, max{0.0};  // both 0 for an empty mesh
};
MeshBounds mesh_bounds(const TriangleMesh& mesh);

// PLY: vertex x, y, z (any scalar type); face "vertex_indices" or
// "vertex_index" list (any integer count and index types). Other elements and
// properties are skipped. `name` is used in error messages.
TriangleMesh parse_ply(std::string_view bytes, const std::string& name);
// OBJ: "v x y z [w]" and "f a b c ..." with a, a/t, a//n, a/t/n and negative
// (relative) indices, each naming a vertex defined above it; every other
// statement (vt, vn, g, o, s, usemtl, mtllib, l, p, ...) is ignored.
TriangleMesh parse_obj(std::string_view text, const std::string& name);
// glTF 2.0 JSON or GLB bytes: every TRIANGLES (also strip/fan) primitive of
// every mesh of the nodes of the default scene (scene 0 when none is named),
// each with its node's world transform: the product of the local transforms
// (matrix, or T * R * S) from the root down, so a node instanced by several
// parents appears once per path. Without scenes, the root nodes (those no
// node lists as a child) are walked; without nodes, every mesh is taken
// untransformed. POSITION may be float or, as KHR_mesh_quantization allows,
// 8/16-bit integers, normalized or not. Only embedded (GLB or data: URI)
// buffers when parsing from memory; load_mesh() also resolves external
// buffers next to the file.
TriangleMesh parse_gltf(std::string_view bytes, const std::string& name, const std::string& base_dir = "");

enum class MeshFormat { Ply, Obj, Gltf };
const char* mesh_format_name(MeshFormat format);  // "PLY", "OBJ", "glTF"
// The reader load_mesh() uses for these bytes: "ply" + newline, the GLB
// "glTF" magic or a JSON object (glTF), else OBJ.
MeshFormat mesh_format_of(std::string_view bytes);

// Reads a file with the reader mesh_format_of() picks; `format` (optional)
// gets that reader. Throws InputError when it cannot be read.
TriangleMesh load_mesh(const std::string& path, MeshFormat* format = nullptr);

// (x, y, z) -> (x, -z, y): a rotation of +90 degrees about x taking glTF's +y up to +z up.
void gltf_y_up_to_z_up(TriangleMesh& mesh);

// The mesh as OBJ text: `header` lines as "# ..." comments, then "v" lines
// with 6 decimals (negative zero written as 0) and 1-based "f" lines.
std::string mesh_to_obj(const TriangleMesh& mesh, const std::vector<std::string>& header = {});

}  // namespace icube::world
