// examples/oren_nayar.hpp — a BxDF that prism does not ship, defined in user
// code: Oren–Nayar rough diffuse reflection, in the improved qualitative form
// of Y. Fujii ("A tiny improvement of Oren–Nayar reflectance model"), which
// conserves energy. It joins a renderer without any change to prism:
//   1. a type modelling prism::BxDFLike (eval, pdf, sample, flags; the
//      conventions of prism/bxdfs/bxdf.hpp),
//   2. a material (parameter set) type, unique within the BxDF set,
//   3. a specialisation of prism::bxdf_traits for the BxDF,
//   4. a set that includes it: prism::default_bxdf_set<S>::with<OrenNayarBxDF<S>>.
// examples/custom_bxdf.cpp renders it; tests/bxdfs/oren_nayar_test.cpp tests it.
//
// The model. With wo and wi in the local shading frame (+z the normal),
//   s = wo.wi - cos_o cos_i           (= sin_o sin_i cos(phi_i - phi_o)),
//   t = max(cos_o, cos_i) if s > 0, else 1,
//   f = rho (A + B s / t),  A = 1 / (pi + (pi/2 - 2/3) sigma),  B = sigma A,
// for wo and wi on the same side (both sides of a surface reflect, like
// prism's DiffuseBxDF). sigma in [0, 1] is the roughness (Fujii's sigma': the
// ratio of the non-Lambertian term to the Lambertian one); sigma = 0 is
// Lambert, rho / pi; above 1, A + B s would go negative where s -> -1.
// The normalisation makes the directional albedo exactly rho at grazing
// incidence and less elsewhere: the s < 0 half of the hemisphere contributes
// -2/3 sin_o B and the s > 0 half at most (pi/2) sin_o B, so
// albedo <= rho (A pi + B (pi/2 - 2/3)) = rho. f is symmetric in wo and wi
// (reciprocal). It is sampled by the cosine-weighted hemisphere (pdf
// cos_i / pi per solid angle), exact for sigma = 0; otherwise a sample weighs
// f cos_i / pdf = pi rho (A + B s / t), and s / t <= tan(theta_o), so the
// weights are bounded for any wo short of grazing.
#pragma once
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <prism/bxdfs/bxdf.hpp>
#include <prism/error.hpp>
#include <prism/geometry/interaction.hpp>
#include <prism/sampling/warps.hpp>
#include <prism/spectra/traits.hpp>

namespace example {

template <class S>
class OrenNayarBxDF {
 public:
  OrenNayarBxDF() = default;
  OrenNayarBxDF(const S& reflectance, prism::Float sigma)
      : m_rho(reflectance),
        m_a(1 / (prism::pi + (prism::pi / 2 - prism::Float(2) / 3) * sigma)),
        m_b(sigma * m_a) {}

  S eval(prism::Vector3f wo, prism::Vector3f wi, prism::TransportMode) const {
    if (!prism::same_hemisphere(wo, wi)) return S{};
    return m_rho * shape(wo, wi);
  }
  prism::Float pdf(prism::Vector3f wo, prism::Vector3f wi, prism::TransportMode) const {
    if (!prism::same_hemisphere(wo, wi)) return 0;
    return prism::pdf_cosine_hemisphere(prism::abs_cos_theta(wi));
  }
  // Cosine-weighted about the side wo lies on (uc unused).
  std::optional<prism::BSDFSample<S>> sample(prism::Vector3f wo, prism::Float, prism::Point2f u,
                                             prism::TransportMode) const {
    if (wo.z == 0 || m_rho.is_black()) return std::nullopt;
    prism::Vector3f wi = prism::sample_cosine_hemisphere(u);
    if (wo.z < 0) wi.z = -wi.z;
    prism::Float pdf = prism::pdf_cosine_hemisphere(prism::abs_cos_theta(wi));
    if (!(pdf > 0)) return std::nullopt;
    return prism::BSDFSample<S>{m_rho * shape(wo, wi), wi, pdf, prism::BxDFFlags::diffuse_reflection};
  }
  prism::BxDFFlags flags() const {
    return m_rho.is_black() ? prism::BxDFFlags::none : prism::BxDFFlags::diffuse_reflection;
  }

  const S& reflectance() const { return m_rho; }
  prism::Float a() const { return m_a; }
  prism::Float b() const { return m_b; }

 private:
  // A + B s / t for wo and wi on the same side (cosines taken as |cos|).
  prism::Float shape(const prism::Vector3f& wo, const prism::Vector3f& wi) const {
    prism::Float co = prism::abs_cos_theta(wo), ci = prism::abs_cos_theta(wi);
    // wo.wi - cos_o cos_i with wo, wi on one side: the tangential parts' dot product.
    prism::Float s = wo.x * wi.x + wo.y * wi.y;
    if (s <= 0) return m_a + m_b * s;
    prism::Float t = std::max(co, ci);  // > 0 whenever wo and wi are on one side
    return t > 0 ? m_a + m_b * (s / t) : m_a;
  }

  S m_rho{};
  prism::Float m_a = prism::inv_pi, m_b = 0;
};

// The material: a reflectance colour and the roughness sigma, both in [0, 1].
struct OrenNayarMaterial {
  prism::RGB reflectance{0.5f};
  prism::Float sigma = 0.5f;
  std::string name = "oren_nayar";
};

}  // namespace example

// The extension point, specialised in user code.
template <class S>
struct prism::bxdf_traits<example::OrenNayarBxDF<S>> {
  static constexpr std::string_view name = "oren_nayar";
  static constexpr BxDFFlags flags = BxDFFlags::diffuse_reflection;
  // The optional hooks it provides (bxdfs/hooks.hpp): a declared hook that is
  // missing or misspelt below is a compile error naming it.
  static constexpr BxDFHook hooks = BxDFHook::validate;
  using material_type = example::OrenNayarMaterial;

  // The reflectance is uplifted as a bounded spectrum in spectral mode.
  template <class W>
  static example::OrenNayarBxDF<S> make(const example::OrenNayarMaterial& m, const SurfaceInteraction&,
                                        const W& lambda) {
    return example::OrenNayarBxDF<S>(spectrum_traits<S>::albedo(m.reflectance, lambda), m.sigma);
  }
  // Called by Scene::build: throws prism::Error naming the material.
  static void validate(const example::OrenNayarMaterial& m, std::string_view where) {
    const RGB& c = m.reflectance;
    std::ostringstream s;
    if (!c.is_finite() || c.r < 0 || c.g < 0 || c.b < 0 || c.r > 1 || c.g > 1 || c.b > 1)
      s << "reflectance (" << c.r << ", " << c.g << ", " << c.b << ") must be in [0, 1]";
    else if (!(m.sigma >= 0 && m.sigma <= 1))
      s << "sigma = " << m.sigma << " must be in [0, 1]";
    else
      return;
    throw Error(std::string(where) + ": material '" + m.name + "': " + s.str());
  }
};
