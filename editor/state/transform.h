// Object transforms as the Objects panel edits them: translate, rotate
// (degrees about X, then Y, then Z) and scale, i.e. cdsm::make_transform's
// T * Rz * Ry * Rx * S.
#pragma once

#include "cdsm/scene.h"

namespace cdsm::editor {

struct Trs {
  Vec3 translate{0, 0, 0};
  Vec3 rotate_deg{0, 0, 0};  // XYZ order, degrees
  Vec3 scale{1, 1, 1};
};

// make_transform(t.translate, t.rotate_deg, t.scale).
Mat4 compose(const Trs& t);

// The T, R, S of a matrix. Translation is the last column (exact); scales
// are the columns' lengths (the first one negative when the matrix
// mirrors); angles are the XYZ Euler angles of the rotation that remains
// (Y within [-90, 90], X and Z within (-180, 180]; Y = +-90 puts all of the
// rotation about the remaining axis into Z). The result is then snapped to
// the shortest decimals that still compose to the same matrix: for a matrix
// make_transform() made from such values (degrees and scales with up to 6
// decimals, the usual case: a scene file, the panel), compose(decompose(m))
// equals m bit for bit and the values are the ones given (or an equivalent
// Euler triple). Other matrices — a shear, or rotations no short decimal
// reproduces — give the nearest T * R * S with no exactness promise (a shear
// is lost). A singular matrix gives scale 0 on the collapsed axes.
Trs decompose(const Mat4& m);

// The same, choosing among the equivalent answers (the two Euler triples,
// the axis a mirror is put on) the one nearest to `near` — the values the
// panel showed before, so a rotation dragged past Y = 90 keeps going
// instead of jumping to the other triple.
Trs decompose(const Mat4& m, const Trs& near);

}  // namespace cdsm::editor
