// The fixed-size math types of the public API, with one layout whatever the compiler flags.
//
// Eigen aligns its vectorisable fixed-size types to the widest SIMD register the translation unit
// is compiled for: Mat4f is 16-byte aligned under SSE2, 32 under -mavx2 and 64 under
// -mavx512f. A struct or buffer holding one then has a different size and layout in a program
// built with -march=x86-64-v3 than in this library, and the program crashes. Every Eigen matrix
// or quaternion that crosses the API (struct members, spans, vectors) is therefore one of the
// types below, declared Eigen::DontAlign: alignof == alignof(float), sizeof == the floats it holds,
// column-major, in any program, whatever its -m flags or EIGEN_MAX_ALIGN_BYTES. They convert to
// and from the aligned Eigen types by assignment; arithmetic is Eigen's (unaligned loads, which
// cost nothing measurable on x86-64). Eigen::Vector3f and Eigen::Matrix3f are not vectorisable
// (12 and 36 bytes) and are used as they are.
//
// The skinning and runtime sources follow the same rule for every Eigen type of 32 bytes or more
// (Matrix4f, Matrix4d, Vector4d): a non-inlined Eigen function is emitted in every object that
// uses it, the linker keeps one copy, and a copy compiled for 32-byte alignment must never meet a
// 16-byte aligned object. (The offline fitter keeps one aligned Matrix2d, inside an Eigen solver
// that cannot take DontAlign types; no public type holds one.)
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace skinspheres {

using Mat4f = Eigen::Matrix<float, 4, 4, Eigen::ColMajor | Eigen::DontAlign>;
using Vec4f = Eigen::Matrix<float, 4, 1, Eigen::ColMajor | Eigen::DontAlign>;
using Quatf = Eigen::Quaternion<float, Eigen::DontAlign>;

static_assert(sizeof(Mat4f) == 16 * sizeof(float) && alignof(Mat4f) == alignof(float));
static_assert(sizeof(Vec4f) == 4 * sizeof(float) && alignof(Vec4f) == alignof(float));
static_assert(sizeof(Quatf) == 4 * sizeof(float) && alignof(Quatf) == alignof(float));

}  // namespace skinspheres
