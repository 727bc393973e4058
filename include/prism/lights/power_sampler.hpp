// prism/lights/power_sampler.hpp — chooses a light with probability
// proportional to its emitted power (pbrt-v4 book, section 12.6.2), the
// luminance of light.power(lambda). Same interface as UniformLightSampler.
// Lights of zero power are never chosen; if every light has zero power the
// choice is uniform. Infinite and distant lights' power depends on the scene
// radius: build the sampler after set_scene_radius.
#pragma once
#include <algorithm>
#include <span>
#include <string>
#include <variant>
#include <vector>
#include "prism/error.hpp"
#include "prism/lights/light_sampler.hpp"
#include "prism/spectra/traits.hpp"

namespace prism {

class PowerLightSampler {
 public:
  PowerLightSampler() = default;
  // power[i]: a non-negative measure of light i's power (e.g. its luminance).
  // Throws prism::Error naming the light whose power is negative or not finite.
  explicit PowerLightSampler(std::span<const Float> power) : m_pmf(power.size()), m_cdf(power.size() + 1) {
    double total = 0;
    for (size_t i = 0; i < power.size(); ++i) {
      if (!std::isfinite(power[i]) || power[i] < 0)
        throw Error("power light sampler: light " + std::to_string(i) + " has power " + std::to_string(power[i]) +
                    " (must be finite and non-negative)");
      total += double(power[i]);
    }
    const size_t n = power.size();
    m_cdf[0] = 0;
    for (size_t i = 0; i < n; ++i) {
      double p = total > 0 ? double(power[i]) / total : 1.0 / double(n);
      m_pmf[i] = Float(p);
      m_cdf[i + 1] = m_cdf[i] + p;
    }
    if (n > 0) {
      // Exactly 1 at the end, and every light after the last one with power
      // ends there too, so that u < 1 never selects a zero-power light.
      size_t last = n;
      while (last > 0 && m_pmf[last - 1] == 0) --last;
      for (size_t i = last; i <= n; ++i) m_cdf[i] = 1;
    }
  }

  size_t size() const { return m_pmf.size(); }

  // A light for u in [0, 1), with its probability.
  std::optional<SampledLight> sample(Float u) const {
    if (m_pmf.empty()) return std::nullopt;
    // The light i with cdf[i] <= u < cdf[i + 1] (never one of zero probability).
    auto it = std::upper_bound(m_cdf.begin(), m_cdf.end(), double(u));
    size_t i = size_t(std::clamp<std::ptrdiff_t>(it - m_cdf.begin() - 1, 0, std::ptrdiff_t(m_pmf.size()) - 1));
    while (m_pmf[i] == 0 && i > 0) --i;  // u >= 1 or rounding: fall back to a light that can be chosen
    return SampledLight{uint32_t(i), m_pmf[i]};
  }
  Float pmf(uint32_t i) const { return i < m_pmf.size() ? m_pmf[i] : 0; }

 private:
  std::vector<Float> m_pmf;
  std::vector<double> m_cdf;
};

// Luminance of a light's power. In RGB mode, the luminance of power(); in
// spectral mode, the Monte Carlo estimate of its CIE Y over 32 fixed,
// stratified sets of wavelengths (128 wavelengths with N = 4), which agrees
// with the RGB figure to well under 1% for grey lights. Accepts a light or a
// std::variant of lights.
template <class S, class L>
Float light_power_luminance(const L& light) {
  using traits = spectrum_traits<S>;
  if constexpr (is_spectral_v<S>) {
    constexpr int sets = 32;
    double y = 0;
    for (int k = 0; k < sets; ++k) {
      auto lambda = traits::sample_wavelengths((Float(k) + Float(0.5)) / Float(sets));
      y += double(luminance(light.power(lambda), lambda));
    }
    return Float(y / sets);
  } else {
    return light.power(wavelengths_t<S>{}).luminance();
  }
}
template <class S, class... Ls>
Float light_power_luminance(const std::variant<Ls...>& light) {
  return std::visit([](const auto& l) { return light_power_luminance<S>(l); }, light);
}

// A PowerLightSampler for a range of lights (or of light variants) of colour type S.
template <class S, class Range>
PowerLightSampler make_power_light_sampler(const Range& lights) {
  std::vector<Float> power;
  for (const auto& l : lights) power.push_back(light_power_luminance<S>(l));
  return PowerLightSampler(power);
}

}  // namespace prism
