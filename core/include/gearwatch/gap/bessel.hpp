#pragma once
// Bessel functions of the first kind at whole orders, all orders at once, for the modulation forms
// (Jacobi–Anger: a phase modulation of index z holds J_k(z)² of a line's power k sidebands away).

#include <vector>

namespace gearwatch::gap {

/// J_0(z) … J_K(z) written into `j` (resized to K + 1; no allocation once it has grown). Up to
/// |z| = 4 by the power series; beyond by Miller's backward recurrence, normalised by
/// J_0 + 2 Σ J_2m = 1. Both are accurate to about 1e-14 of the largest value.
void bessel_j_up_to(int k_max, double z, std::vector<double>& j);

}  // namespace gearwatch::gap
