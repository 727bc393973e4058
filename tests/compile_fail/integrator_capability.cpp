// Compiled by ctest with one PRISM_CASE_* macro; the UNDECLARED and MISSING
// cases must FAIL with a message naming the capability, the OK case must
// compile (tests/CMakeLists.txt).
#include <prism/prism.hpp>

namespace user {
using namespace prism;
struct Constant {
#if defined(PRISM_CASE_OK)
  static constexpr IntegratorCapability capabilities = IntegratorCapability::aovs;
  template <class Sc, class W, class U>
  AovSample aovs(const Sc&, Ray, const W&, U&&) const { return {}; }
#elif defined(PRISM_CASE_UNDECLARED)
  // A caustic pass the driver would never run: not declared.
  template <class Sc>
  bool caustics_active(const Sc&) const { return true; }
#elif defined(PRISM_CASE_MISSING)
  // Declared, but the member is not there.
  static constexpr IntegratorCapability capabilities = IntegratorCapability::aovs;
#else
#error "define one PRISM_CASE_*"
#endif
  template <class Sc, class W, class Sampler>
  typename Sc::spectrum_type Li(const Sc&, Ray, W&, Sampler&, RayCounter&) const {
    return typename Sc::spectrum_type(1);
  }
};
}  // namespace user

int main() {
  using namespace prism;
  Scene<RGB> scene;
  scene.build();
  Film film(2, 2);
  RenderOptions opt;
  opt.spp = 1;
  render(scene, PerspectiveCamera{}, user::Constant{}, film, opt);
}
