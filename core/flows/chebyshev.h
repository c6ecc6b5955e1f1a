// Internal to core/flows: N iterations of a linear flow in fewer applications of its step.
//
// A linear flow's step is a matrix S (bilaplacian: S = I - lambda Z U0^2, Z zeroing the fixed
// vertices' rows), and N iterations are S^N x. When S's eigenvalues are real and lie in
// [s_min, 1], s^N on that interval is, in the variable t = (s - a) / b with a = (1 + s_min) / 2
// and b = (1 - s_min) / 2, a sum of Chebyshev polynomials sum_k c_k T_k(t) whose coefficients
// are all >= 0, sum to 1 and fall off fast beyond degree ~sqrt(N): 501 iterations of
// bilaplacian (s_min = 0.2) are within 1e-15 of a sum of degree 113. Since |T_k| <= 1 on
// [-1, 1], cutting the sum where the coefficients left sum to `tail` changes the result by at
// most `tail` times its size (on a non-symmetric S, times the condition of its eigenvectors).
// The sum is then evaluated with the three-term recurrence v_{k+1} = 2 M v_k - v_{k-1},
// M = (S - a) / b: one application of S per term (driver.cc, FlowRun::ChebyshevTerm).
// docs/decisions.md ("A long bilaplacian run as one polynomial") has the figures.
#pragma once

#include <vector>

namespace meshsmooth::flows {

struct ChebyshevSeries {
  double a = 1.0, b = 0.0;  // t = (s - a) / b
  std::vector<double> c;    // c_0 .. c_d
};

// The series of s^n on [s_min, 1] (-1 <= s_min < 1, n >= 0), cut where the coefficients left
// sum to at most `tail`, c_0 then set so that they sum to 1 (the sum is 1 at s = 1, as s^n is).
// Computed by n multiplications by s = a + b t in the Chebyshev basis
// (t T_k = (T_{k+1} + T_{|k-1|}) / 2): additions and products of non-negative numbers only, so
// the same bits on every machine.
ChebyshevSeries ChebyshevOfPower(int n, double s_min, double tail);

}  // namespace meshsmooth::flows
