// Which joint each vertex follows, and each joint's heaviest child (internal to lib/colliders).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"

namespace skinspheres::lib::colliders {

// Per vertex, the joint of its largest skin weight (the first on ties); 0 without a skin.
std::vector<uint32_t> DominantJoints(const RawCharacter& c);

// Per joint, its child with the most vertices at or below it (`owned`: vertices per joint), -1 for
// a leaf.
std::vector<int32_t> HeaviestChildren(std::span<const int32_t> parents, std::span<const size_t> owned);

}  // namespace skinspheres::lib::colliders
