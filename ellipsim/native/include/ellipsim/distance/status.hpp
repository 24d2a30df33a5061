// What signed_distance reports per pair, by name: DistanceStatus, and DerivativeStatus for its derivatives
// (ellipsim/core/distance/status.py; the int8 codes of ellipsoid_pair.hpp, derivatives.hpp and, for ONE_SIDED
// and ContactFeature, of the pairs/ folder).  tests/test_native_distance.py checks they are status.py's.
#pragma once

#include "../math.hpp"

namespace ellipsim::distance {

// signed_distance's status, per pair.
enum class DistanceStatus : int8_t {
  GLOBAL = 0,    // the returned maximum is proven global, to ellipsoid_pair's tolerance
  UNPROVEN = 1,  // the proof's budget ran out: the best maximum found, not proven global
};

// signed_distance(..., derivatives=True)'s derivative status, per pair.
enum class DerivativeStatus : int8_t {
  SMOOTH = 0,     // unique, nondegenerate maximiser: the derivatives
  BRANCH = 1,     // a deep maximum's derivatives; a tie with another maximiser is not excluded
  FLAT = 2,       // a flat maximum (circle of maxima or nearly): NaN
  UNPROVEN = 3,   // the maximum is not proven: NaN
  ONE_SIDED = 4,  // shape_distance: the contact where two features of the other body meet: the named one's
};

// shape_distance(..., derivatives=True)'s feature of the capsule, box or cylinder that carries the contact.
enum class ContactFeature : int8_t {
  FACE = 0,    // a box face
  EDGE = 1,    // a box edge
  VERTEX = 2,  // a box vertex
  SIDE = 3,    // a capsule's or a cylinder's side
  END = 4,     // a capsule's hemispherical end
  CAP = 5,     // a cylinder's flat cap
  RIM = 6,     // a cylinder's rim circle
};

}  // namespace ellipsim::distance
