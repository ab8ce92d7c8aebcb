// The fitter's self-check: the fitted set is consistent and proves, in double precision, every
// triangle inside its owner sphere in the bind pose. See sphere_fitter.h and fit_stages.h.
#include <string>

#include "fit_stages.h"

namespace skinspheres::lib {

int CountUncoveredTriangles(const RawCharacter& ch, const runtime::SphereSet& set, int* first_bad) {
  std::vector<int32_t> owner(ch.triangle_count(), -1);
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      if (set.triangles[k] < owner.size()) owner[set.triangles[k]] = static_cast<int32_t>(s);
    }
  }
  constexpr int32_t kInPieces = -2;  // checked piece by piece below
  for (const runtime::TrianglePiece& piece : set.pieces) {
    if (piece.triangle < owner.size() && owner[piece.triangle] == -1) owner[piece.triangle] = kInPieces;
  }
  int bad = 0;
  for (size_t t = 0; t < owner.size(); ++t) {
    if (owner[t] == kInPieces) continue;
    bool inside = owner[t] >= 0;
    if (inside) {
      const Eigen::Vector3d c = set.centers_rest[owner[t]].cast<double>();
      const double r = set.radii_rest[owner[t]] * (1.0 + 1e-6);
      for (int k = 0; k < 3 && inside; ++k) {
        inside = (ch.positions_rest[ch.triangles[t][k]].cast<double>() - c).norm() <= r;
      }
    }
    if (!inside) {
      if (bad == 0 && first_bad) *first_bad = static_cast<int>(t);
      ++bad;
    }
  }
  // A cut triangle (docs/TRIANGLE_PIECES.md): each piece's corners inside its owner; the triangle
  // counts once however many of its pieces fail (an uncut one owned by nobody failed above).
  std::vector<char> failed(ch.triangle_count(), 0);
  for (size_t s = 0; s < set.size(); ++s) {
    const Eigen::Vector3d c = set.centers_rest[s].cast<double>();
    const double r = set.radii_rest[s] * (1.0 + 1e-6);
    for (const runtime::TrianglePiece& piece : set.PiecesOf(s)) {
      const Eigen::Vector3i& tri = ch.triangles[piece.triangle];
      uint8_t corners[3][2];
      bool inside = runtime::PieceCorners(piece.level, piece.index, corners);
      for (int v = 0; v < 3 && inside; ++v) {
        const Eigen::Vector3f p =
            runtime::GridPoint(ch.positions_rest[tri[0]], ch.positions_rest[tri[1]], ch.positions_rest[tri[2]],
                               piece.level, corners[v][0], corners[v][1]);
        inside = (p.cast<double>() - c).norm() <= r;
      }
      if (inside || failed[piece.triangle]) continue;
      failed[piece.triangle] = 1;
      if (bad == 0 && first_bad) *first_bad = static_cast<int>(piece.triangle);
      ++bad;
    }
  }
  return bad;
}

std::optional<Error> CheckFittedSet(const RawCharacter& ch, const runtime::SphereSet& set) {
  const std::string name = ch.Name();
  if (auto err = set.Validate())
    return MakeError(ErrorCode::kInvalidData, name + ": fitted set is inconsistent: " + err->message);
  int first_bad = -1;
  const int uncovered = CountUncoveredTriangles(ch, set, &first_bad);
  if (uncovered) {
    return MakeError(ErrorCode::kCheckFailed,
                     name + ": bind-pose check failed: " + std::to_string(uncovered) +
                         " triangles outside their sphere (first: " + std::to_string(first_bad) + ")");
  }
  return std::nullopt;
}

}  // namespace skinspheres::lib
