// prism/lights/light_sampler.hpp — chooses one light for next-event estimation.
// UniformLightSampler picks each of n lights with probability 1/n.
#pragma once
#include <cstdint>
#include <optional>
#include "prism/math/float.hpp"

namespace prism {

struct SampledLight {
  uint32_t index;
  Float pmf;
};

class UniformLightSampler {
 public:
  UniformLightSampler() = default;
  explicit UniformLightSampler(size_t count) : m_count(uint32_t(count)) {}
  std::optional<SampledLight> sample(Float u) const {
    if (m_count == 0) return std::nullopt;
    uint32_t i = std::min(uint32_t(u * Float(m_count)), m_count - 1);
    return SampledLight{i, 1 / Float(m_count)};
  }
  Float pmf(uint32_t) const { return m_count ? 1 / Float(m_count) : 0; }

 private:
  uint32_t m_count = 0;
};

}  // namespace prism
