// Exact signs of the orientation determinants (exact_predicates.h) by floating-point expansions:
// a value is held as a sum of doubles that do not overlap, sorted by increasing magnitude, and
// sums and products are formed without rounding (Shewchuk 1997: Two-Sum, Two-Product through
// fma, grow-expansion, scale-expansion, each with zero elimination). The sign of an expansion is
// the sign of its largest component. This file is built with -ffp-contract=off (runtime/CMakeLists
// .txt): a fused multiply-add where the code has a separate product and sum would break Two-Sum.
#include "narrow_phase/exact_predicates.h"

#include <cmath>

namespace skinspheres::runtime::exact {
namespace {

// x + y == a + b exactly, x = fl(a + b).
inline void TwoSum(double a, double b, double& x, double& y) {
  x = a + b;
  const double bv = x - a;
  const double av = x - bv;
  y = (a - av) + (b - bv);
}

// x + y == a - b exactly.
inline void TwoDiff(double a, double b, double& x, double& y) {
  x = a - b;
  const double bv = a - x;
  const double av = x + bv;
  y = (a - av) + (bv - b);
}

// x + y == a * b exactly (fma rounds once, so it returns the product's rounding error).
inline void TwoProduct(double a, double b, double& x, double& y) {
  x = a * b;
  y = std::fma(a, b, -x);
}

// h = e + b; e has elen components; h has room for elen + 1. Returns h's length.
int Grow(int elen, const double* e, double b, double* h) {
  double q = b;
  int n = 0;
  for (int k = 0; k < elen; ++k) {
    double sum, err;
    TwoSum(q, e[k], sum, err);
    q = sum;
    if (err != 0.0) h[n++] = err;
  }
  if (q != 0.0 || n == 0) h[n++] = q;
  return n;
}

// h = e * b; h has room for 2 * elen. Returns h's length.
int Scale(int elen, const double* e, double b, double* h) {
  double q, err;
  TwoProduct(e[0], b, q, err);
  int n = 0;
  if (err != 0.0) h[n++] = err;
  for (int k = 1; k < elen; ++k) {
    double p1, p0, sum;
    TwoProduct(e[k], b, p1, p0);
    TwoSum(q, p0, sum, err);
    if (err != 0.0) h[n++] = err;
    // Fast-Two-Sum: |p1| >= |sum| here (Shewchuk's scale-expansion).
    q = p1 + sum;
    err = sum - (q - p1);
    if (err != 0.0) h[n++] = err;
  }
  if (q != 0.0 || n == 0) h[n++] = q;
  return n;
}

// Fixed-capacity expansion of at most N components (sized per use so that the exact path needs
// only a few KB of stack: engines run jobs on small fibre stacks).
template <int N>
struct Expansion {
  double c[N];
  int n = 0;
  int sign() const { return n == 0 ? 0 : (c[n - 1] > 0.0) - (c[n - 1] < 0.0); }
};

Expansion<2> Difference(double a, double b) {
  Expansion<2> e;
  double x, y;
  TwoDiff(a, b, x, y);
  if (y != 0.0) e.c[e.n++] = y;
  e.c[e.n++] = x;
  return e;
}

// a + b (or a - b with negate_b).
template <int N, int A, int B>
Expansion<N> Add(const Expansion<A>& a, const Expansion<B>& b, bool negate_b = false) {
  static_assert(N >= A + B);
  Expansion<N> out, tmp;
  for (int k = 0; k < a.n; ++k) out.c[k] = a.c[k];
  out.n = a.n;
  for (int k = 0; k < b.n; ++k) {
    tmp.n = Grow(out.n, out.c, negate_b ? -b.c[k] : b.c[k], tmp.c);
    for (int m = 0; m < tmp.n; ++m) out.c[m] = tmp.c[m];
    out.n = tmp.n;
  }
  return out;
}

template <int A, int B>
Expansion<2 * A * B> Multiply(const Expansion<A>& a, const Expansion<B>& b) {
  constexpr int kN = 2 * A * B;
  Expansion<kN> out, tmp;
  Expansion<2 * A> term;
  out.c[0] = 0.0;
  out.n = 1;
  for (int k = 0; k < b.n; ++k) {
    term.n = Scale(a.n, a.c, b.c[k], term.c);
    for (int m = 0; m < term.n; ++m) {
      tmp.n = Grow(out.n, out.c, term.c[m], tmp.c);
      for (int q = 0; q < tmp.n; ++q) out.c[q] = tmp.c[q];
      out.n = tmp.n;
    }
  }
  return out;
}

// a*d - b*c, exactly, for two-component inputs.
Expansion<16> Cross2(const Expansion<2>& a, const Expansion<2>& b, const Expansion<2>& c, const Expansion<2>& d) {
  return Add<16>(Multiply(a, d), Multiply(b, c), /*negate_b=*/true);
}

}  // namespace

int Orient3dExact(const P3& a, const P3& b, const P3& c, const P3& d) {
  const Expansion<2> ux = Difference(b.x, a.x), uy = Difference(b.y, a.y), uz = Difference(b.z, a.z);
  const Expansion<2> vx = Difference(c.x, a.x), vy = Difference(c.y, a.y), vz = Difference(c.z, a.z);
  const Expansion<2> wx = Difference(d.x, a.x), wy = Difference(d.y, a.y), wz = Difference(d.z, a.z);
  // (u x v) . w
  const Expansion<16> nx = Cross2(uy, uz, vy, vz);  // uy*vz - uz*vy
  const Expansion<16> ny = Cross2(uz, ux, vz, vx);  // uz*vx - ux*vz
  const Expansion<16> nz = Cross2(ux, uy, vx, vy);  // ux*vy - uy*vx
  const Expansion<128> xy = Add<128>(Multiply(nx, wx), Multiply(ny, wy));
  return Add<192>(xy, Multiply(nz, wz)).sign();
}

int Orient2dExact(double ax, double ay, double bx, double by, double cx, double cy) {
  const Expansion<2> ux = Difference(bx, ax), uy = Difference(by, ay);
  const Expansion<2> vx = Difference(cx, ax), vy = Difference(cy, ay);
  return Cross2(ux, uy, vx, vy).sign();
}

}  // namespace skinspheres::runtime::exact
