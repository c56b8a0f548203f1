#include "tools/benchmark/power_law_fit.h"

#include <cmath>
#include <cstddef>

namespace graphslam::tools::benchmark {

PowerLaw FitPowerLaw(const std::vector<double>& x, const std::vector<double>& y) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size() && i < y.size(); ++i) {
    if (!(x[i] > 0) || !(y[i] > 0) || !std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    const double lx = std::log(x[i]);
    const double ly = std::log(y[i]);
    n += 1;
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
  }
  PowerLaw fit;
  fit.points = static_cast<int>(n);
  // Centred sums: the determinant n·Sxx − Sx² without cancellation.
  if (n < 2) return fit;
  const double mx = sx / n;
  const double my = sy / n;
  const double varx = sxx / n - mx * mx;
  if (!(varx > 1e-12)) return fit;
  fit.exponent = (sxy / n - mx * my) / varx;
  fit.coefficient = std::exp(my - fit.exponent * mx);
  fit.valid = std::isfinite(fit.exponent) && std::isfinite(fit.coefficient);
  return fit;
}

}  // namespace graphslam::tools::benchmark
