// The two rest poses side by side (retarget_stages.h, AlignRestPoses): the rotation A that aligns
// them (Kabsch, least squares over the matched joints of the torso, head and legs, whose rest
// directions A-pose and T-pose rigs share), the ratio of the hip heights, and the angle between
// each matched bone's rest directions, per limb.
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>

#include "retarget_stages.h"

namespace skinspheres::lib::retarget {
namespace {

using Vec3 = Eigen::Vector3d;

// The rotation R minimising Σ |R (s_i - s̄) - (t_i - t̄)|², or the identity when the points do not
// span a plane (a rotation about their line is not determined).
Eigen::Quaterniond Kabsch(const std::vector<Vec3>& s, const std::vector<Vec3>& t) {
  if (s.size() < 3) return Eigen::Quaterniond::Identity();
  Vec3 cs = Vec3::Zero(), ct = Vec3::Zero();
  for (size_t i = 0; i < s.size(); ++i) cs += s[i], ct += t[i];
  cs /= static_cast<double>(s.size());
  ct /= static_cast<double>(t.size());
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < s.size(); ++i) h += (s[i] - cs) * (t[i] - ct).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3& sv = svd.singularValues();
  if (!(sv[1] > 1e-9 * sv[0])) return Eigen::Quaterniond::Identity();
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return Eigen::Quaterniond(svd.matrixV() * d * svd.matrixU().transpose()).normalized();
}

Vec3 D(const Eigen::Vector3f& v) { return v.cast<double>(); }

// Height of `root` above the lowest of `points` along `up`, or 0.
double HeightAbove(const Vec3& root, const std::vector<Vec3>& points, const Vec3& up) {
  double lowest = root.dot(up);
  for (const Vec3& p : points) lowest = std::min(lowest, p.dot(up));
  return root.dot(up) - lowest;
}

double Spread(const std::vector<Vec3>& p) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& x : p) c += x;
  c /= std::max<double>(1.0, static_cast<double>(p.size()));
  double sum = 0.0;
  for (const Vec3& x : p) sum += (x - c).squaredNorm();
  return std::sqrt(sum / std::max<double>(1.0, static_cast<double>(p.size())));
}

// Per limb, the matched bone (a -> b, a the parent of b) whose rest directions differ most.
void RestDifferences(const WorldPose& source_rest, const WorldPose& target_rest, const Correspondence& c,
                     const RawCharacter& target, const BodyParts* parts, const Eigen::Quaterniond& a, double size,
                     RetargetReport* report) {
  const skinning::Skeleton& t = target.skeleton;
  std::map<std::string, RestDifference> by_limb;
  report->largest_rest_difference = {};
  for (size_t b = 0; b < t.size(); ++b) {
    const int32_t pa = t.parents[b];
    if (pa < 0 || c.node_of[b] < 0 || c.node_of[static_cast<size_t>(pa)] < 0) continue;
    const Vec3 dt = D(target_rest.position[b]) - D(target_rest.position[static_cast<size_t>(pa)]);
    const Vec3 ds = a * (D(source_rest.position[static_cast<size_t>(c.node_of[b])]) -
                         D(source_rest.position[static_cast<size_t>(c.node_of[static_cast<size_t>(pa)])]));
    if (!(dt.norm() > 1e-4 * size) || !(ds.norm() > 0.0)) continue;
    const double cosine = std::clamp(dt.normalized().dot(ds.normalized()), -1.0, 1.0);
    RestDifference d;
    d.joint = t.joint_names[static_cast<size_t>(pa)];
    d.degrees = static_cast<float>(std::acos(cosine) * 180.0 / M_PI);
    const int32_t part = parts != nullptr && static_cast<size_t>(pa) < parts->joint_part.size()
                             ? parts->joint_part[static_cast<size_t>(pa)]
                             : -1;
    d.limb = part >= 0 ? parts->parts[static_cast<size_t>(part)].name : d.joint;
    if (d.degrees > report->largest_rest_difference.degrees) report->largest_rest_difference = d;
    auto [it, fresh] = by_limb.emplace(d.limb, d);
    if (!fresh && d.degrees > it->second.degrees) it->second = d;
  }
  report->rest_differences.clear();
  for (const auto& [limb, d] : by_limb) report->rest_differences.push_back(d);
  std::stable_sort(report->rest_differences.begin(), report->rest_differences.end(),
                   [](const RestDifference& x, const RestDifference& y) { return x.degrees > y.degrees; });
}

// Per target joint, the smallest rotation that lays its rest bone (towards its mapped child with
// the most mapped joints below it) along A times the source's rest bone; the identity for a joint
// without a mapped child or with a bone too short to have a direction.
std::vector<Quatf> RestSwings(const WorldPose& source_rest, const WorldPose& target_rest, const Correspondence& c,
                              const skinning::Skeleton& t, const Eigen::Quaterniond& a, double size) {
  std::vector<int32_t> mapped_below(t.size(), 0);
  for (size_t j = t.size(); j-- > 0;) {
    if (t.parents[j] >= 0) {
      mapped_below[static_cast<size_t>(t.parents[j])] += mapped_below[j] + (c.node_of[j] >= 0 ? 1 : 0);
    }
  }
  std::vector<int32_t> child(t.size(), -1);
  for (size_t j = 0; j < t.size(); ++j) {
    const int32_t p = t.parents[j];
    if (p < 0 || c.node_of[j] < 0) continue;
    const int32_t& best = child[static_cast<size_t>(p)];
    if (best < 0 || mapped_below[j] > mapped_below[static_cast<size_t>(best)])
      child[static_cast<size_t>(p)] = static_cast<int32_t>(j);
  }
  std::vector<Quatf> swing(t.size(), Quatf::Identity());
  for (size_t j = 0; j < t.size(); ++j) {
    const int32_t k = child[j];
    if (c.node_of[j] < 0 || k < 0) continue;
    const Vec3 dt = D(target_rest.position[static_cast<size_t>(k)]) - D(target_rest.position[j]);
    const Vec3 ds = a * (D(source_rest.position[static_cast<size_t>(c.node_of[static_cast<size_t>(k)])]) -
                         D(source_rest.position[static_cast<size_t>(c.node_of[j])]));
    if (!(dt.norm() > 1e-4 * size) || !(ds.norm() > 1e-4 * size)) continue;
    swing[j] = Quatf(Eigen::Quaterniond::FromTwoVectors(dt, ds).normalized().cast<float>());
  }
  return swing;
}

}  // namespace

std::vector<char> AligningJoints(const RawCharacter& target, const BodyParts* parts, const CoreJoints& core) {
  const skinning::Skeleton& t = target.skeleton;
  std::vector<char> aligning(t.size(), 1);
  if (parts != nullptr && parts->humanoid && parts->joint_part.size() == t.size()) {
    for (size_t j = 0; j < t.size(); ++j) {
      const int32_t p = parts->joint_part[j];
      const PartKind kind = p >= 0 ? parts->parts[static_cast<size_t>(p)].kind : PartKind::kChain;
      aligning[j] = kind == PartKind::kTorso || kind == PartKind::kHead || kind == PartKind::kLegLeft ||
                    kind == PartKind::kLegRight;
    }
    return aligning;
  }
  for (size_t j = 0; j < t.size(); ++j) {
    for (int32_t a = static_cast<int32_t>(j); a >= 0; a = t.parents[static_cast<size_t>(a)]) {
      if (a == core.joint[2] || a == core.joint[3]) aligning[j] = 0;
    }
  }
  return aligning;
}

Alignment AlignRestPoses(const WorldPose& source_rest, const WorldPose& target_rest, const Correspondence& c,
                         const RawCharacter& target, const AlignmentSettings& settings, RetargetReport* report) {
  const BodyParts* parts = settings.parts;
  const int32_t root_joint = settings.root_joint;
  std::vector<Vec3> body_s, body_t, all_s, all_t;
  for (size_t j = 0; j < c.node_of.size(); ++j) {
    const int32_t n = c.node_of[j];
    if (n < 0) continue;
    all_s.push_back(D(source_rest.position[static_cast<size_t>(n)]));
    all_t.push_back(D(target_rest.position[j]));
    if (j < settings.aligning.size() && settings.aligning[j]) {
      body_s.push_back(all_s.back());
      body_t.push_back(all_t.back());
    }
  }
  const bool body = body_s.size() >= 3;
  const Eigen::Quaterniond a = Kabsch(body ? body_s : all_s, body ? body_t : all_t);
  Alignment out;
  out.rotation = Quatf(a.cast<float>());
  report->alignment_degrees = static_cast<float>(2.0 * std::acos(std::clamp(std::abs(a.w()), 0.0, 1.0)) * 180.0 / M_PI);

  // k: hip heights above the lowest matched joint, along the target's up (the source's: A⁻¹ up).
  const Vec3 up_t = parts != nullptr && parts->humanoid ? Vec3(parts->up.cast<double>()) : Vec3::UnitY();
  const Vec3 up_s = a.inverse() * up_t;
  const double spread_s = Spread(all_s), spread_t = Spread(all_t);
  double k = spread_s > 0.0 ? spread_t / spread_s : 1.0;
  if (root_joint >= 0 && c.node_of[static_cast<size_t>(root_joint)] >= 0) {
    const double h_t = HeightAbove(D(target_rest.position[static_cast<size_t>(root_joint)]), all_t, up_t);
    const double h_s = HeightAbove(
        D(source_rest.position[static_cast<size_t>(c.node_of[static_cast<size_t>(root_joint)])]), all_s, up_s);
    if (h_t > 1e-3 * spread_t && h_s > 1e-3 * spread_s) k = h_t / h_s;
  }
  if (!std::isfinite(k) || !(k > 0.0)) k = 1.0;
  out.hip_scale = static_cast<float>(k);
  report->hip_scale = out.hip_scale;
  RestDifferences(source_rest, target_rest, c, target, parts, a, spread_t, report);
  out.swing = settings.match_directions ? RestSwings(source_rest, target_rest, c, target.skeleton, a, spread_t)
                                        : std::vector<Quatf>(target.skeleton.size(), Quatf::Identity());
  return out;
}

}  // namespace skinspheres::lib::retarget
