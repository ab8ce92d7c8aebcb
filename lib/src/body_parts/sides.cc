// Which side is the character's left: from where the feet point (toes ahead of ankles), else from
// the joint names, else glTF's convention (facing +Z). See split_stages.h and body_parts.h.
#include <Eigen/Geometry>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "split_stages.h"

namespace skinspheres::lib {
namespace {

using Vec3 = Eigen::Vector3d;

// +1 for a name that says left, -1 for right, 0 otherwise. Tokens split at non-alphanumerics,
// lower->upper case changes and letter/digit changes: "mixamorig:LeftArm" -> mixamorig left arm,
// "UpperLeg.L" -> upper leg l, "leg_joint_R_1" -> leg joint r 1.
int NameSide(const std::string& name) {
  std::vector<std::string> tokens;
  std::string cur;
  auto flush = [&] {
    if (!cur.empty()) tokens.push_back(cur);
    cur.clear();
  };
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (!std::isalnum(c)) {
      flush();
      continue;
    }
    if (!cur.empty()) {
      const unsigned char p = static_cast<unsigned char>(name[i - 1]);
      const bool case_break = std::islower(p) && std::isupper(c);
      const bool digit_break = (std::isdigit(p) != 0) != (std::isdigit(c) != 0);
      if (case_break || digit_break) flush();
    }
    cur.push_back(static_cast<char>(std::tolower(c)));
  }
  flush();
  int side = 0;
  for (const std::string& t : tokens) {
    if (t == "left" || t == "l" || t == "lft") side += 1;
    if (t == "right" || t == "r" || t == "rt" || t == "rgt") side -= 1;
  }
  return side > 0 ? 1 : (side < 0 ? -1 : 0);
}

// Points of a part: its joints' positions and the vertices whose dominant joint it holds.
std::vector<Vec3> PartPoints(const RawCharacter& ch, const WeightedSkeleton& ws, std::span<const int32_t> joint_part,
                             int32_t part) {
  std::vector<Vec3> pts;
  for (int32_t j = 0; j < ws.n; ++j) {
    if (joint_part[j] == part) pts.push_back(ws.jpos[j]);
  }
  for (size_t v = 0; v < ws.vertex_joint.size(); ++v) {
    if (ws.vertex_joint[v] >= 0 && joint_part[ws.vertex_joint[v]] == part) {
      pts.push_back(ch.positions_rest[v].cast<double>());
    }
  }
  return pts;
}

// How far the foot reaches along `d` beyond the shin: centroid of the lowest 10% of the leg
// minus centroid of the 10%..30% band. Returns {offset, leg length}.
std::pair<double, double> FootReach(const RawCharacter& ch, const WeightedSkeleton& ws,
                                    std::span<const int32_t> joint_part, int32_t leg_part, const Vec3& u,
                                    const Vec3& d) {
  const std::vector<Vec3> pts = PartPoints(ch, ws, joint_part, leg_part);
  double hmin = std::numeric_limits<double>::infinity(), hmax = -hmin;
  for (const Vec3& p : pts) {
    hmin = std::min(hmin, p.dot(u));
    hmax = std::max(hmax, p.dot(u));
  }
  const double len = hmax - hmin;
  if (!(len > 0.0)) return {0.0, 0.0};
  PointStats foot, shin;
  for (const Vec3& p : pts) {
    const double h = (p.dot(u) - hmin) / len;
    if (h <= 0.1) {
      foot.sum += p;
      foot.count += 1.0;
    } else if (h <= 0.3) {
      shin.sum += p;
      shin.count += 1.0;
    }
  }
  if (foot.count == 0.0 || shin.count == 0.0) return {0.0, len};
  return {(foot.Centroid() - shin.Centroid()).dot(d), len};
}

}  // namespace

// up u: legs -> head; l0: between the arms; forward from the feet; left = u x forward.
Sides FindSides(const RawCharacter& ch, const WeightedSkeleton& ws, const HumanoidCandidate& c,
                std::span<const int32_t> joint_part) {
  Sides out;
  const Vec3 L[2] = {ws.subtree[c.leg[0]].Centroid(), ws.subtree[c.leg[1]].Centroid()};
  const Vec3 A[2] = {ws.subtree[c.arm[0]].Centroid(), ws.subtree[c.arm[1]].Centroid()};
  const Vec3 H = ws.subtree[c.head].Centroid();
  const Vec3 mid_leg = 0.5 * (L[0] + L[1]);
  const Vec3 u = (H - mid_leg).normalized();
  Vec3 lat = (A[0] - A[1]) - (A[0] - A[1]).dot(u) * u;
  if (lat.norm() < 1e-12) lat = (L[0] - L[1]) - (L[0] - L[1]).dot(u) * u;
  const Vec3 l0 = lat.normalized();
  const Vec3 d = u.cross(l0);
  const auto r0 = FootReach(ch, ws, joint_part, 4, u, d), r1 = FootReach(ch, ws, joint_part, 5, u, d);
  const double reach = r0.first + r1.first, leg_len = 0.5 * (r0.second + r1.second);
  Vec3 left;
  if (leg_len > 0.0 && std::abs(reach) > 0.02 * leg_len) {
    left = u.cross(reach > 0.0 ? d : Vec3(-d));
    out.from = "feet";
  } else {
    // Names break the tie: each limb votes with its side of the l0 axis.
    int vote = 0;
    auto side_vote = [&](int part, const Vec3& centroid) {
      int name_score = 0;
      for (int32_t j = 0; j < ws.n; ++j) {
        if (joint_part[j] == part) name_score += NameSide(ch.skeleton.joint_names[j]);
      }
      const double s = (centroid - mid_leg).dot(l0);
      vote += (s > 0 ? 1 : (s < 0 ? -1 : 0)) * (name_score > 0 ? 1 : (name_score < 0 ? -1 : 0));
    };
    for (int i = 0; i < 2; ++i) {
      side_vote(2 + i, A[i]);
      side_vote(4 + i, L[i]);
    }
    if (vote != 0) {
      left = vote > 0 ? l0 : Vec3(-l0);
      out.from = "names";
    } else {
      // glTF convention: the character faces +Z.
      Vec3 fwd = Vec3::UnitZ() - Vec3::UnitZ().dot(u) * u;
      if (fwd.norm() < 1e-6) fwd = Vec3::UnitX() - Vec3::UnitX().dot(u) * u;
      left = u.cross(fwd.normalized());
      out.from = "convention";
    }
  }
  out.up = u;
  out.left = left;
  out.swap_arms = (A[0] - mid_leg).dot(left) < (A[1] - mid_leg).dot(left);
  out.swap_legs = (L[0] - mid_leg).dot(left) < (L[1] - mid_leg).dot(left);
  return out;
}

}  // namespace skinspheres::lib
