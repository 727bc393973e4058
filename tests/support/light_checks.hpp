// tests/support/light_checks.hpp — helpers shared by the light tests.
#pragma once
#include <algorithm>
#include <cmath>
#include "prism/spectra/traits.hpp"

namespace prism_test {

// Fixed wavelengths for spectral instantiations (u picks them); nothing in RGB.
template <class S>
prism::wavelengths_t<S> test_lambda(prism::Float u = 0.5f) {
  if constexpr (prism::is_spectral_v<S>)
    return prism::spectrum_traits<S>::sample_wavelengths(u);
  else
    return {};
}

// Largest relative difference between two colours, per component.
template <class S>
double max_rel_diff(const S& a, const S& b) {
  double m = 0;
  for (int i = 0; i < S::size; ++i)
    m = std::max(m, std::abs(double(a[i]) - double(b[i])) / std::max(1e-30, std::abs(double(b[i]))));
  return m;
}

}  // namespace prism_test
