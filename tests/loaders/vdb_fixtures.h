// .vdb fixtures written with OpenVDB (vdb_fixtures.cpp is the only test
// file that includes it: it compiles slowly).
#pragma once

#include <string>
#include <vector>

#include "cdsm/math.h"

namespace cdsm_test {

struct VdbFixtureGrid {
  enum class Kind { Float, Half, Double, Int32, Vec3 };
  std::string name = "density";
  Kind kind = Kind::Float;
  int lo[3] = {0, 0, 0}, hi[3] = {7, 7, 7};  // active voxels: the box [lo, hi], inclusive
  float value = 1.0f;                        // their value
  float background = 0.0f;
  cdsm::Mat4 index_to_world;  // affine
  bool nan_voxel = false;     // one active voxel NaN
  bool active_tiles = false;  // prune constant regions into active tiles
};

// Writes the grids into one .vdb file (names may repeat).
void write_vdb(const std::string& path, const std::vector<VdbFixtureGrid>& grids);

}  // namespace cdsm_test
