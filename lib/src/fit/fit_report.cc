// The fit report's per-part figures and the paper's F over the whole character. See fit_stages.h.
#include <algorithm>

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
  for (size_t s = 0; s < set.size(); ++s) ++report->parts[set.sphere_part[s]].spheres;
  report->f_mean = f_n ? static_cast<float>(f_sum / f_n) : 0.0f;
}

}  // namespace skinspheres::lib
