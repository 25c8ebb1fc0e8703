// Writes .vdb fixtures with OpenVDB.
#include "vdb_fixtures.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Prune.h>

#include <cmath>

namespace cdsm_test {
namespace {

template <class GridT>
typename GridT::Ptr box_grid(const VdbFixtureGrid& g, typename GridT::ValueType value,
                             typename GridT::ValueType background) {
  auto grid = GridT::create(background);
  grid->tree().fill(
      openvdb::CoordBBox(openvdb::Coord(g.lo[0], g.lo[1], g.lo[2]), openvdb::Coord(g.hi[0], g.hi[1], g.hi[2])), value,
      true);
  if (!g.active_tiles) grid->tree().voxelizeActiveTiles();
  return grid;
}

}  // namespace

void write_vdb(const std::string& path, const std::vector<VdbFixtureGrid>& grids) {
  openvdb::initialize();
  openvdb::GridPtrVec out;
  for (const VdbFixtureGrid& g : grids) {
    openvdb::GridBase::Ptr grid;
    switch (g.kind) {
      case VdbFixtureGrid::Kind::Float:
      case VdbFixtureGrid::Kind::Half: {
        auto f = box_grid<openvdb::FloatGrid>(g, g.value, g.background);
        if (g.nan_voxel) f->tree().setValue(openvdb::Coord(g.lo[0], g.lo[1], g.lo[2]), std::nanf(""));
        f->setSaveFloatAsHalf(g.kind == VdbFixtureGrid::Kind::Half);
        f->setGridClass(openvdb::GRID_FOG_VOLUME);
        grid = f;
        break;
      }
      case VdbFixtureGrid::Kind::Double: grid = box_grid<openvdb::DoubleGrid>(g, g.value, g.background); break;
      case VdbFixtureGrid::Kind::Int32: grid = box_grid<openvdb::Int32Grid>(g, int(g.value), int(g.background)); break;
      case VdbFixtureGrid::Kind::Vec3:
        grid = box_grid<openvdb::Vec3SGrid>(g, openvdb::Vec3s(g.value), openvdb::Vec3s(g.background));
        break;
    }
    // OpenVDB matrices act on row vectors: the transpose of ours.
    openvdb::Mat4d m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(c, r) = double(g.index_to_world.m[r][c]);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    grid->setName(g.name);
    out.push_back(grid);
  }
  openvdb::io::File file(path);
  file.write(out);
  file.close();
}

}  // namespace cdsm_test
