// Compiled by ctest with one of the PRISM_CASE_* macros defined; each case
// must FAIL to compile with a message naming the hook (tests/CMakeLists.txt
// matches it). PRISM_CASE_OK must compile: the control that shows the
// failures come from the hook, not from the rest of the file.
#include <prism/bxdfs/bsdf.hpp>
#include <prism/bxdfs/diffuse.hpp>

namespace user {
using namespace prism;
template <class S>
struct Matte {
  S albedo;
  S eval(Vector3f, Vector3f, TransportMode) const { return albedo * inv_pi; }
  Float pdf(Vector3f, Vector3f, TransportMode) const { return inv_2pi; }
  std::optional<BSDFSample<S>> sample(Vector3f, Float, Point2f, TransportMode) const { return std::nullopt; }
  BxDFFlags flags() const { return BxDFFlags::diffuse_reflection; }
};
struct MatteMaterial {
  RGB albedo;
};
}  // namespace user

template <class S>
struct prism::bxdf_traits<user::Matte<S>> {
  static constexpr std::string_view name = "matte";
  static constexpr BxDFFlags flags = BxDFFlags::diffuse_reflection;
  using material_type = user::MatteMaterial;
  template <class W>
  static user::Matte<S> make(const user::MatteMaterial& m, const SurfaceInteraction&, const W& l) {
    return {spectrum_traits<S>::albedo(m.albedo, l)};
  }
#if defined(PRISM_CASE_OK)
  static constexpr BxDFHook hooks = BxDFHook::has_specular;
  static bool has_specular(const user::MatteMaterial&) { return false; }
#elif defined(PRISM_CASE_MISSPELT)
  // Declared, but the member's name has a typo.
  static constexpr BxDFHook hooks = BxDFHook::has_specular;
  static bool has_speculr(const user::MatteMaterial&) { return false; }
#elif defined(PRISM_CASE_WRONG_SIGNATURE)
  // Declared, with the right name but the wrong parameter.
  static constexpr BxDFHook hooks = BxDFHook::opacity;
  static prism::Float opacity(const user::MatteMaterial&) { return 1; }
#elif defined(PRISM_CASE_UNDECLARED)
  // The right name, but not listed in `hooks`: it would be ignored.
  static bool may_be_transparent(const user::MatteMaterial&) { return true; }
#else
#error "define one PRISM_CASE_*"
#endif
};

using Set = prism::bxdf_set<prism::DiffuseBxDF<prism::RGB>, user::Matte<prism::RGB>>;
int main() { return int(Set::size) - 2; }
