#pragma once
// STL files (the CAD exchange format for triangle meshes) read into an indexed triangle mesh.
// Reads: one file, binary or ASCII. Writes: welded vertices and triangles. Load time only; throws
// InputError (file, ASCII line, what would be valid) on bad input.
//
// Format detection. A binary STL is an 80-byte header, a little-endian uint32 triangle count n and
// n records of 50 bytes (normal, three vertices as 12 float32, a 2-byte attribute), so its size is
// exactly 84 + 50 n. An ASCII STL starts with the word "solid", but some binary exporters also
// begin their header with "solid"; so a file whose size matches 84 + 50 n for the count in bytes
// 80..83 is binary, whatever its first word. Otherwise a file starting with "solid" is parsed as
// ASCII; anything else is not an STL file.
//
// ASCII grammar (keywords case-insensitive, any whitespace between tokens, one or more solids):
//   solid [name]
//     facet normal nx ny nz
//       outer loop
//         vertex x y z      (three times)
//       endloop
//     endfacet              (any number of facets)
//   endsolid [name]
//
// Policy. The stored facet normals are ignored: a triangle's front side is given by its vertex order
// (counter-clockwise seen from the front, STL's right-hand rule), which every exporter writes and
// many get the stored normal wrong or zero. Coordinates are multiplied by `scale` (0.001 for a file
// in millimetres) and must be finite. Vertices with bitwise identical scaled coordinates are welded
// into one (-0 and +0 count as equal), which gives the connectivity; nothing closer than identical
// is merged. Degenerate triangles (two welded corners alike, or three collinear corners: twice the
// area at most 1e-12 times the longest edge squared) and repeats of a triangle already read (the
// same three corners in any order) are skipped and counted. A file left with no triangle is rejected.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "engine/triangle_mesh.h"
#include "engine/types.h"

namespace dem {

/// An indexed triangle mesh as read from an STL file.
struct StlMesh {
  std::vector<Vec3> vertices;                            // distinct, in order of first use [m]
  std::vector<std::array<std::uint32_t, 3>> triangles;   // corner indices, counter-clockwise seen from the front
  std::size_t degenerate_skipped = 0;                    // triangles dropped as degenerate
  std::size_t duplicate_skipped = 0;                     // triangles dropped as repeats
  bool binary = false;                                   // which encoding the file used
};

/// Reads the STL file at `path`, scaling coordinates by `scale` (> 0, finite; e.g. 0.001 for mm).
/// Throws InputError naming the file (and the line, for ASCII) on anything that is not a valid STL.
StlMesh read_stl(const std::string& path, Real scale = 1);

/// The same from the file's bytes; `name` is the file named in error messages.
StlMesh parse_stl(std::string_view bytes, const std::string& name, Real scale = 1);

/// read_stl, then the TriangleMesh of its triangles (connectivity, facets, lookup grid).
TriangleMesh read_stl_mesh(const std::string& path, Real scale = 1);

}  // namespace dem
