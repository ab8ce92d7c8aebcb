// Stage 8 of the fitter: the contact rules, stated on the mesh's triangles. See fit_stages.h.
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

#include "fit_stages.h"

namespace skinspheres::lib {

std::optional<Error> WriteContactRules(const FitSettings& settings, runtime::SphereSet* set) {
  return runtime::WriteContactRules(set, static_cast<uint32_t>(settings.contact_hops), settings.rest_gap);
}

}  // namespace skinspheres::lib
