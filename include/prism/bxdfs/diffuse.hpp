// prism/bxdfs/diffuse.hpp — the Lambertian BxDF: f = R / pi in the hemisphere of
// wo (both sides of a surface reflect), sampled by the cosine-weighted
// hemisphere. DiffuseMaterial is its parameter set: an RGB reflectance in
// [0, 1], uplifted to S by spectrum_traits<S>::albedo.
#pragma once
#include "prism/bxdfs/bxdf.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/sampling/warps.hpp"

namespace prism {

template <class S>
class DiffuseBxDF {
 public:
  DiffuseBxDF() = default;
  explicit DiffuseBxDF(const S& r) : m_r(r) {}

  S eval(Vector3f wo, Vector3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi)) return S{};
    return m_r * inv_pi;
  }
  // Cosine-weighted about the side wo lies on; pdf cos/pi per solid angle.
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float, Point2f u, TransportMode) const {
    if (m_r.is_black()) return std::nullopt;
    Vector3f wi = sample_cosine_hemisphere(u);
    if (wo.z < 0) wi.z = -wi.z;
    Float pdf = pdf_cosine_hemisphere(abs_cos_theta(wi));
    if (pdf == 0) return std::nullopt;
    return BSDFSample<S>{m_r * inv_pi, wi, pdf, BxDFFlags::diffuse_reflection};
  }
  Float pdf(Vector3f wo, Vector3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi)) return 0;
    return pdf_cosine_hemisphere(abs_cos_theta(wi));
  }
  BxDFFlags flags() const { return m_r.is_black() ? BxDFFlags::none : BxDFFlags::diffuse_reflection; }
  const S& reflectance() const { return m_r; }

 private:
  S m_r{};
};

struct DiffuseMaterial {
  RGB reflectance{0.5f};
};

template <class S>
struct bxdf_traits<DiffuseBxDF<S>> {
  static constexpr std::string_view name = "diffuse";
  static constexpr BxDFFlags flags = BxDFFlags::diffuse_reflection;
  using material_type = DiffuseMaterial;
  template <class W>
  static DiffuseBxDF<S> make(const DiffuseMaterial& m, const SurfaceInteraction&, const W& lambda) {
    return DiffuseBxDF<S>(spectrum_traits<S>::albedo(m.reflectance, lambda));
  }
};

}  // namespace prism
