// The fit report's per-part figures and the paper's F over the whole character. See fit_stages.h.
#include <algorithm>
#include <vector>

#include "fit_stages.h"

namespace skinspheres::lib {

void SummarisePartReports(std::span<const PartSpheres> paper, const runtime::SphereSet& set, FitReport* report) {
  double f_sum = 0.0;
  int f_n = 0;
  for (const auto& f : paper) {
    report->f_max = std::max(report->f_max, f.report.f_max);
    f_sum += static_cast<double>(f.report.f_mean) * f.report.rays_hit;
    f_n += f.report.rays_hit;
    report->parts.push_back(f.report);
    report->parts.back().spheres = 0;
  }
  // Triangles per part, counted from the set: the paper stage counted the fitted mesh, whose cut
  // triangles are there once per piece (docs/TRIANGLE_PIECES.md). A cut triangle counts once, in the
  // part of its pieces' owners (one part: Validate()).
  for (auto& part : report->parts) part.triangles = 0;
  std::vector<char> counted(set.source_triangle_count, 0);
  for (size_t s = 0; s < set.size(); ++s) {
    PartFitReport& part = report->parts[set.sphere_part[s]];
    ++part.spheres;
    part.triangles += static_cast<int>(set.triangle_offsets[s + 1] - set.triangle_offsets[s]);
    for (const runtime::TrianglePiece& p : set.PiecesOf(s)) {
      if (!counted[p.triangle]) ++part.triangles;
      counted[p.triangle] = 1;
    }
  }
  report->f_mean = f_n ? static_cast<float>(f_sum / f_n) : 0.0f;
}

}  // namespace skinspheres::lib
