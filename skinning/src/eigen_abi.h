// Included first by every skinning source. With SKINSPHERES_AVX2 this target is compiled with
// -mavx2 while its users are not; Eigen would then align fixed-size types (Matrix4f, hence
// BindEntry, std::vector<Matrix4f>) to 32 bytes here and 16 bytes there, an ABI break. Eigen's
// documented fix: cap the alignment at 16 bytes in the AVX translation units.
#pragma once
#if defined(__AVX__) && !defined(EIGEN_MAX_ALIGN_BYTES)
#define EIGEN_MAX_ALIGN_BYTES 16
#endif
