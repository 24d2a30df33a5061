// The relation of two ellipsoids, as every query reports it (ellipsim/core/relation.py: the same
// int8 codes).
#pragma once

#include "math.hpp"

namespace ellipsim {

constexpr int8_t SEPARATED = 0;    // closed ellipsoids disjoint
constexpr int8_t TOUCHING = 1;     // boundaries meet, interiors disjoint
constexpr int8_t OVERLAPPING = 2;  // interiors intersect (includes containment)
// What a certified float path returns for a pair it cannot prove (exact arithmetic decides it).
constexpr int8_t UNDECIDED = -1;

}  // namespace ellipsim
