
#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::skinning {

bool LocalToModelJob::Validate() const {
  if (skeleton == nullptr || !skeleton->Validate()) return false;
  return input.size() >= skeleton->size() && output.size() >= skeleton->size();
}

bool LocalToModelJob::Run() const {
  if (!Validate()) return false;
  const size_t n = skeleton->size();
  for (size_t i = 0; i < n; ++i) {
    const Mat4f local = input[i].ToMatrix();
    const int32_t parent = skeleton->parents[i];
    // G_i = G_parent · L_i; parents[i] < i, so G_parent is already final.
    output[i] = (parent < 0 ? root : output[static_cast<size_t>(parent)]) * local;
  }
  return true;
}

}  // namespace skinspheres::skinning
