#include "core/flows/chebyshev.h"

#include <algorithm>

namespace meshsmooth::flows {

ChebyshevSeries ChebyshevOfPower(int n, double s_min, double tail) {
  ChebyshevSeries series;
  series.a = 0.5 * (1.0 + s_min);
  series.b = 0.5 * (1.0 - s_min);
  n = std::max(n, 0);
  std::vector<double> c(static_cast<size_t>(n) + 2, 0.0), t(c.size(), 0.0);
  c[0] = 1.0;
  for (int m = 0; m < n; ++m) {  // c holds s^m: degree m
    std::fill(t.begin(), t.begin() + m + 2, 0.0);
    t[1] += c[0];
    for (int k = 1; k <= m; ++k) {
      t[k + 1] += 0.5 * c[k];
      t[k - 1] += 0.5 * c[k];
    }
    for (int k = 0; k <= m + 1; ++k) c[k] = series.a * c[k] + series.b * t[k];
  }
  // The smallest degree d whose left-over coefficients sum to at most `tail`.
  int d = n;
  double left = 0.0;
  while (d > 0 && left + c[d] <= tail) left += c[d--];
  series.c.assign(c.begin(), c.begin() + d + 1);
  // The constant term takes what the others leave of 1 (what was cut, and the recurrence's
  // rounding): the sum then maps 1 to 1, so a translated mesh comes out translated by as much,
  // and stays within 2 `tail` of s^n on [s_min, 1].
  double others = 0.0;
  for (int k = d; k >= 1; --k) others += series.c[k];
  series.c[0] = 1.0 - others;
  return series;
}

}  // namespace meshsmooth::flows
