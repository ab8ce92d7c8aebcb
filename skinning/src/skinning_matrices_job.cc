
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::skinning {

bool SkinningMatricesJob::Validate() const {
  if (output.size() < binds.size()) return false;
  for (const BindEntry& b : binds) {
    if (b.joint < 0 || static_cast<size_t>(b.joint) >= joint_model.size()) return false;
  }
  return true;
}

bool SkinningMatricesJob::Run() const {
  if (!Validate()) return false;
  for (size_t b = 0; b < binds.size(); ++b) {
    // M_b = G_joint(b) · IBM_b
    output[b] = joint_model[static_cast<size_t>(binds[b].joint)] * binds[b].inverse_bind;
  }
  return true;
}

}  // namespace skinspheres::skinning
