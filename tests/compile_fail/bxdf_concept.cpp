// Must FAIL to compile: a BxDF without flags() cannot join a bxdf_set
// (tests/CMakeLists.txt matches the concept's name in the message).
#include <prism/bxdfs/bsdf.hpp>

namespace user {
using namespace prism;
struct NoFlags {
  RGB eval(Vector3f, Vector3f, TransportMode) const { return RGB(0); }
  Float pdf(Vector3f, Vector3f, TransportMode) const { return 0; }
  std::optional<BSDFSample<RGB>> sample(Vector3f, Float, Point2f, TransportMode) const { return std::nullopt; }
};
struct NoFlagsMaterial {};
}  // namespace user

template <>
struct prism::bxdf_traits<user::NoFlags> {
  static constexpr std::string_view name = "no-flags";
  static constexpr BxDFFlags flags = BxDFFlags::diffuse_reflection;
  using material_type = user::NoFlagsMaterial;
  template <class W>
  static user::NoFlags make(const user::NoFlagsMaterial&, const SurfaceInteraction&, const W&) { return {}; }
};

int main() { return int(prism::bxdf_set<user::NoFlags>::size); }
