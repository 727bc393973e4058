// prism/bxdfs/conductor.hpp — metals: the exact Fresnel reflectance of a
// conductor (complex index eta + i k), a smooth (delta) mirror and a rough
// Torrance–Sparrow lobe on the Trowbridge–Reitz distribution (pbrt-v4 book,
// 9.4–9.6), and ConductorMaterial, whose eta and k come from a measured metal,
// from any measured spectra, from RGB eta and k, or from an RGB reflectance.
//
// BxDF conventions (bxdf.hpp): eval excludes the cosine; both sides of the
// surface reflect (wo.z < 0 mirrors the configuration, like DiffuseBxDF);
// smooth: one specular lobe with f = F / |cos|, pdf 1, eval/pdf 0; rough
// (Torrance–Sparrow): f = D(wm) G(wo, wi) F(wo.wm) / (4 |cos_o| |cos_i|),
// sampled through the visible normals, pdf = D_wo(wm) / (4 |wo.wm|)
// = G1(wo) D(wm) / (4 |cos_o|), so f |cos_i| / pdf = F G / G1(wo) <= F.
// sample() evaluates f and pdf at the half vector recomputed from (wo, wi),
// exactly as eval() and pdf() do, so MIS sees the same numbers either way.
//
// The energy a rough conductor loses (multiple scattering is ignored) is in
// docs/microfacets.md; tests/bxdfs/conductor_test.cpp measures it.
#pragma once
#include <array>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <variant>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/hooks.hpp"
#include "prism/bxdfs/microfacet.hpp"
#include "prism/bxdfs/ms_compensation.hpp"
#include "prism/sampling/warps.hpp"
#include "prism/error.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/spectra/data/metals.hpp"
#include "prism/spectra/spectrum.hpp"
#include "prism/spectra/traits.hpp"

namespace prism {

// Fresnel reflectance of a conductor for unpolarised light: the mean of the
// s and p power reflectances |r|^2 with the complex relative index
// n = eta + i k (eta, k >= 0; light arrives from the dielectric side, air).
// cos_theta_i is clamped to [0, 1]. Snell's law with a complex index gives a
// complex cos_t = sqrt(1 - sin^2_i / n^2) (principal root), and the Fresnel
// amplitudes keep their dielectric form:
//   r_p = (n cos_i - cos_t) / (n cos_i + cos_t),
//   r_s = (cos_i - n cos_t) / (cos_i + n cos_t).
// In double. k = 0 reduces to
// fresnel_dielectric without total internal reflection; eta = 0 with k > 0
// (a lossless plasma) gives exactly 1 at every angle; grazing incidence
// gives 1; eta = k = 0 (not a material: validate rejects it) returns 1.
inline Float fresnel_complex(Float cos_theta_i, Float eta, Float k) {
  // Complex arithmetic written out in real numbers: |a / b|^2 = |a|^2 / |b|^2
  // needs no complex division (std::complex's is a library call).
  double c = std::clamp(double(cos_theta_i), 0.0, 1.0), n_re = eta, n_im = k;
  if (!(c > 0) || (eta == 0 && k == 0)) return 1;  // grazing: the limit 1, not 0 / 0
  double sin2_i = (1 - c) * (1 + c);
  // 1 / n^2 = conj(n^2) / |n^2|^2, n^2 = (eta^2 - k^2) + i 2 eta k.
  double n2_re = n_re * n_re - n_im * n_im, n2_im = 2 * n_re * n_im;
  double inv_n2_norm = 1 / (n2_re * n2_re + n2_im * n2_im);
  // z = 1 - sin2_i / n^2, and its principal square root cos_t = (t_re, t_im).
  double z_re = 1 - sin2_i * n2_re * inv_n2_norm, z_im = sin2_i * n2_im * inv_n2_norm;
  double z_abs = std::sqrt(z_re * z_re + z_im * z_im);
  double t_re, t_im;
  if (z_re >= 0) {
    t_re = std::sqrt((z_abs + z_re) / 2);
    t_im = t_re > 0 ? z_im / (2 * t_re) : 0;
  } else {
    t_im = std::copysign(std::sqrt((z_abs - z_re) / 2), z_im);
    t_re = z_im / (2 * t_im);
  }
  // r_p = (n c - cos_t) / (n c + cos_t), r_s = (c - n cos_t) / (c + n cos_t).
  double a_re = n_re * c, a_im = n_im * c;
  double b_re = n_re * t_re - n_im * t_im, b_im = n_re * t_im + n_im * t_re;  // n cos_t
  double rp = (sqr(a_re - t_re) + sqr(a_im - t_im)) / (sqr(a_re + t_re) + sqr(a_im + t_im));
  double rs = (sqr(c - b_re) + sqr(b_im)) / (sqr(c + b_re) + sqr(b_im));
  return Float((rp + rs) / 2);
}

// fresnel_complex per channel (RGB) or per wavelength (SampledSpectrum).
template <class S>
  requires(S::size > 0)
S fresnel_complex(Float cos_theta_i, const S& eta, const S& k) {
  S r;
  for (int i = 0; i < S::size; ++i) r[i] = fresnel_complex(cos_theta_i, eta[i], k[i]);
  return r;
}

template <class S>
class ConductorBxDF {
 public:
  ConductorBxDF() = default;
  // eta and k per channel/wavelength; distrib smooth for a mirror.
  ConductorBxDF(const TrowbridgeReitz& distrib, const S& eta, const S& k)
      : m_distrib(distrib), m_eta(eta), m_k(k) {}

  // Adds Kulla and Conty's multiple-scattering lobe (ms_compensation.hpp):
  // a rough conductor then reflects the energy a single bounce loses.
  void enable_multiple_scattering() {
    m_ms = MultipleScattering<S>::make(m_distrib, [&](Float mu) { return fresnel_complex(mu, m_eta, m_k); });
  }
  bool multiple_scattering() const { return m_ms.active; }

  S eval(Vector3f wo, Vector3f wi, TransportMode) const {
    if (m_distrib.effectively_smooth()) return S{};
    S f;
    Float pdf;
    if (!rough(wo, wi, &f, &pdf)) f = S{};
    if (m_ms.active && same_hemisphere(wo, wi) && wo.z != 0 && wi.z != 0)
      f = f + m_ms.scale * m_ms.white(abs_cos_theta(wo), abs_cos_theta(wi));
    return f;
  }
  Float pdf(Vector3f wo, Vector3f wi, TransportMode) const {
    if (m_distrib.effectively_smooth()) return 0;
    Float pdf;
    if (!rough(wo, wi, nullptr, &pdf)) pdf = 0;
    if (!m_ms.active) return pdf;
    if (!same_hemisphere(wo, wi) || wo.z == 0) return 0;
    Float p = ms_probability(wo);
    return (1 - p) * pdf + p * abs_cos_theta(wi) * inv_pi;
  }

  // Smooth: the mirror direction (uc and u unused). Rough: a visible normal
  // from u, and its mirror reflection (uc unused).
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float uc, Point2f u, TransportMode) const {
    if (wo.z == 0) return std::nullopt;
    if (m_distrib.effectively_smooth()) {
      Vector3f wi(-wo.x, -wo.y, wo.z);
      Float c = abs_cos_theta(wi);
      return BSDFSample<S>{fresnel_complex(c, m_eta, m_k) / c, wi, 1, BxDFFlags::specular_reflection};
    }
    if (m_ms.active) {
      // The lobes by their share of the energy, chosen with uc.
      Vector3f wi;
      if (uc < ms_probability(wo)) {
        wi = sample_cosine_hemisphere(u);
        if (wo.z < 0) wi.z = -wi.z;
      } else {
        wi = reflect(wo, m_distrib.sample_wm(wo, u));
      }
      if (!same_hemisphere(wo, wi) || wi.z == 0) return std::nullopt;
      Float pdf_mix = pdf(wo, wi, TransportMode::radiance);
      if (!(pdf_mix > 0)) return std::nullopt;
      return BSDFSample<S>{eval(wo, wi, TransportMode::radiance), wi, pdf_mix, BxDFFlags::glossy_reflection};
    }
    Vector3f wm = m_distrib.sample_wm(wo, u);
    Vector3f wi = reflect(wo, wm);
    if (!same_hemisphere(wo, wi)) return std::nullopt;
    S f;
    Float pdf;
    if (!rough(wo, wi, &f, &pdf) || !(pdf > 0)) return std::nullopt;
    return BSDFSample<S>{f, wi, pdf, BxDFFlags::glossy_reflection};
  }

  BxDFFlags flags() const {
    return m_distrib.effectively_smooth() ? BxDFFlags::specular_reflection : BxDFFlags::glossy_reflection;
  }
  const TrowbridgeReitz& distribution() const { return m_distrib; }
  const S& eta() const { return m_eta; }
  const S& k() const { return m_k; }

 private:
  // Torrance–Sparrow value (when f is not null) and pdf at (wo, wi); false
  // where both are 0.
  bool rough(const Vector3f& wo, const Vector3f& wi, S* f, Float* pdf) const {
    if (!same_hemisphere(wo, wi)) return false;
    Float co = abs_cos_theta(wo), ci = abs_cos_theta(wi);
    Vector3f wm = wo + wi;
    Float l2 = length_squared(wm);
    if (co == 0 || ci == 0 || !(l2 > 0)) return false;
    wm = wm / std::sqrt(l2);
    if (wm.z < 0) wm = -wm;
    Float d = m_distrib.D(wm);
    if (!(d > 0)) return false;
    if (f) *f = fresnel_complex(abs_dot(wo, wm), m_eta, m_k) * (d * m_distrib.G(wo, wi) / (4 * co * ci));
    *pdf = m_distrib.G1(wo) * d / (4 * co);
    return true;
  }

  // The probability of sampling the compensation lobe: a function of wo only,
  // so that pdf() recomputes the sampler's mixture.
  Float ms_probability(const Vector3f& wo) const {
    Float mu = abs_cos_theta(wo);
    return m_ms.probability(mu, fresnel_complex(mu, m_eta, m_k));
  }

  TrowbridgeReitz m_distrib;
  S m_eta{}, m_k{};
  MultipleScattering<S> m_ms;
};

// A conductor's parameters: where eta and k come from, the roughness (alpha,
// see MicrofacetRoughness) and a name for error messages. Build it with one of
// the factories; call bxdf_traits<ConductorBxDF<S>>::validate when the scene
// is built.
struct ConductorMaterial {
  // An RGB normal-incidence reflectance F0 in [0, 1] (the "metal colour"). It
  // becomes eta = 1 and k = 2 sqrt(F0 / (1 - F0)) per channel, or per
  // wavelength of the bounded uplift of F0 in spectral mode: the conductor
  // with that F0 and the least-dispersive angular behaviour (pbrt-v4's
  // "reflectance" conductor). F0 = 1 is taken as 1 - 1e-4 (k = 200).
  struct Reflectance {
    RGB f0{0.9f};
  };
  // eta and k given as RGB (>= 0, not both 0): used as they are in RGB mode,
  // uplifted as unbounded spectra in spectral mode.
  struct EtaK {
    RGB eta{1}, k{3};
  };
  // Measured eta(lambda), k(lambda) (named metals, or a user's tables).
  // rgb_eta and rgb_k are what RGB mode uses; from_spectra() computes them
  // (eta at the Rec.709 primaries' dominant wavelengths, k refitted so that
  // F0 per channel is the metal's reflectance colour under D65).
  struct Spectra {
    PiecewiseLinearSpectrum eta, k;
    RGB rgb_eta, rgb_k;
  };

  std::variant<Reflectance, EtaK, Spectra> source{Reflectance{}};
  MicrofacetRoughness roughness{};
  std::string name = "conductor";
  // Kulla-Conty energy compensation for rough lobes (ms_compensation.hpp).
  bool multiple_scattering = false;

  // Dominant wavelengths (nm) of the Rec.709 / sRGB red, green and blue
  // primaries, where RGB mode evaluates a measured eta.
  static constexpr std::array<Float, 3> rgb_lambda_nm{611.3f, 549.1f, 464.3f};

  static ConductorMaterial from_reflectance(const RGB& f0, MicrofacetRoughness r = {}, std::string name = "conductor") {
    return {Reflectance{f0}, r, std::move(name)};
  }
  static ConductorMaterial from_eta_k(const RGB& eta, const RGB& k, MicrofacetRoughness r = {},
                                      std::string name = "conductor") {
    return {EtaK{eta, k}, r, std::move(name)};
  }
  static ConductorMaterial from_spectra(PiecewiseLinearSpectrum eta, PiecewiseLinearSpectrum k,
                                        MicrofacetRoughness r = {}, std::string name = "conductor") {
    Spectra s{std::move(eta), std::move(k), {}, {}};
    rgb_from_spectra(s);
    return {std::move(s), r, std::move(name)};
  }
  // A measured metal of prism::data by chemical symbol: "Au", "Ag", "Cu",
  // "Al" (pbrt-v4's tables, 299-886 nm, held constant beyond). Throws
  // prism::Error listing the known symbols otherwise. The material's name
  // defaults to the symbol.
  static ConductorMaterial metal(std::string_view symbol, MicrofacetRoughness r = {}, std::string name = "") {
    if (name.empty()) name = std::string(symbol);
    auto make = [&](const float* l, const float* eta, const float* k, int n) {
      auto ls = std::span<const float>(l, size_t(n));
      return from_spectra(PiecewiseLinearSpectrum(ls, std::span<const float>(eta, size_t(n)), "metal-" + std::string(symbol) + "-eta"),
                          PiecewiseLinearSpectrum(ls, std::span<const float>(k, size_t(n)), "metal-" + std::string(symbol) + "-k"),
                          r, std::move(name));
    };
    if (symbol == "Au") return make(data::metal_Au_lambda, data::metal_Au_eta, data::metal_Au_k, data::metal_Au_samples);
    if (symbol == "Ag") return make(data::metal_Ag_lambda, data::metal_Ag_eta, data::metal_Ag_k, data::metal_Ag_samples);
    if (symbol == "Cu") return make(data::metal_Cu_lambda, data::metal_Cu_eta, data::metal_Cu_k, data::metal_Cu_samples);
    if (symbol == "Al") return make(data::metal_Al_lambda, data::metal_Al_eta, data::metal_Al_k, data::metal_Al_samples);
    throw Error("unknown metal '" + std::string(symbol) + "'; known metals: " + known_metals());
  }
  static std::string known_metals() { return "Au, Ag, Cu, Al"; }

  bool is_measured() const { return std::holds_alternative<Spectra>(source); }

  // The colour (linear sRGB) of a conductor's normal-incidence reflectance
  // under D65, the sRGB white: XYZ of F0(lambda) D65(lambda) (1 nm steps,
  // 360-830 nm) with D65 normalised to Y = 1, then the XYZ -> sRGB matrix.
  static RGB f0_colour(const PiecewiseLinearSpectrum& eta, const PiecewiseLinearSpectrum& k) {
    const auto& d65 = illuminant_d65();
    auto reflected = [&](Float l) { return fresnel_complex(1, eta(l), k(l)) * d65(l); };
    return xyz_to_linear_srgb(spectrum_to_xyz(reflected));
  }

  // The RGB-mode eta and k of measured spectra (Spectra::rgb_eta, rgb_k):
  // per channel c, eta_c = eta(lambda_c) at the primary's dominant
  // wavelength, and k_c solves F0(eta_c, k_c) = the channel of f0_colour()
  // (clamped to [0, 1 - 1e-4]), from F0 = ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2):
  //   k^2 = (F0 (eta + 1)^2 - (eta - 1)^2) / (1 - F0).
  // So an RGB render of a measured metal has exactly the colour a spectral
  // render shows at normal incidence under a white (D65) light, and a physical
  // Fresnel curve towards grazing. Where no k >= 0 reaches F0 (F0 below the
  // dielectric value of eta_c), k = 0 and eta_c = (1 + sqrt F0) / (1 - sqrt F0).
  static void rgb_from_spectra(Spectra& s) {
    RGB c = f0_colour(s.eta, s.k);
    for (int i = 0; i < 3; ++i) {
      double f0 = std::clamp(double(c[i]), 0.0, 1 - 1e-4);
      double eta = s.eta(rgb_lambda_nm[size_t(i)]);
      double k2 = (f0 * sqr(eta + 1) - sqr(eta - 1)) / (1 - f0);
      if (k2 >= 0) {
        s.rgb_eta[i] = Float(eta);
        s.rgb_k[i] = Float(std::sqrt(k2));
      } else {
        double r = std::sqrt(f0);
        s.rgb_eta[i] = Float((1 + r) / (1 - r));
        s.rgb_k[i] = 0;
      }
    }
  }
};

template <class S>
struct bxdf_traits<ConductorBxDF<S>> {
  static constexpr std::string_view name = "conductor";
  static constexpr BxDFFlags flags = BxDFFlags::specular_reflection | BxDFFlags::glossy_reflection;
  static constexpr BxDFHook hooks = BxDFHook::validate | BxDFHook::needs_spectral | BxDFHook::has_specular;
  using material_type = ConductorMaterial;

  // eta + i k at the path's wavelengths (or per RGB channel). Never
  // terminates wavelengths: a conductor reflects every wavelength the same way.
  template <class W>
  static ConductorBxDF<S> make(const ConductorMaterial& m, const SurfaceInteraction&, const W& lambda) {
    TrowbridgeReitz distrib(m.roughness);
    S eta, k;
    if (const auto* r = std::get_if<ConductorMaterial::Reflectance>(&m.source)) {
      S f0 = spectrum_traits<S>::albedo(r->f0, lambda);
      eta = S(1);
      for (int i = 0; i < S::size; ++i) {
        Float f = std::clamp(f0[i], Float(0), Float(1 - 1e-4));
        k[i] = 2 * std::sqrt(f / (1 - f));
      }
    } else if (const auto* ek = std::get_if<ConductorMaterial::EtaK>(&m.source)) {
      eta = spectrum_traits<S>::unbounded(ek->eta, lambda);
      k = spectrum_traits<S>::unbounded(ek->k, lambda);
    } else {
      const auto& s = std::get<ConductorMaterial::Spectra>(m.source);
      if constexpr (spectrum_traits<S>::is_spectral) {
        eta = prism::sample(s.eta, lambda);
        k = prism::sample(s.k, lambda);
      } else {
        eta = s.rgb_eta;
        k = s.rgb_k;
      }
    }
    ConductorBxDF<S> bxdf(distrib, eta, k);
    if (m.multiple_scattering) bxdf.enable_multiple_scattering();
    return bxdf;
  }

  // Throws prism::Error, prefixed by `where` and naming the material, on a
  // NaN, infinite or negative roughness, eta or k; on eta = k = 0; on an RGB
  // reflectance outside [0, 1]. Measured spectra are checked at every nm of
  // 360-830.
  static void validate(const ConductorMaterial& m, std::string_view where) {
    auto fail = [&](const std::string& what) {
      throw Error(std::string(where) + ": material '" + m.name + "': " + what);
    };
    auto str = [](auto... v) {
      std::ostringstream s;
      (s << ... << v);
      return s.str();
    };
    if (!m.roughness.is_finite_non_negative())
      fail(str("roughness (alpha_u, alpha_v) = (", m.roughness.alpha_u, ", ", m.roughness.alpha_v,
               ") must be finite and >= 0"));
    auto check_eta_k = [&](double eta, double k, const std::string& at) {
      if (!std::isfinite(eta) || !std::isfinite(k) || eta < 0 || k < 0)
        fail(str("eta = ", eta, ", k = ", k, at, ": both must be finite and >= 0"));
      if (eta == 0 && k == 0) fail(str("eta = k = 0", at, " is not a conductor"));
    };
    if (const auto* r = std::get_if<ConductorMaterial::Reflectance>(&m.source)) {
      const RGB& c = r->f0;
      if (!c.is_finite() || c.r < 0 || c.g < 0 || c.b < 0 || c.r > 1 || c.g > 1 || c.b > 1)
        fail(str("reflectance (", c.r, ", ", c.g, ", ", c.b, ") must be finite and in [0, 1]"));
    } else if (const auto* ek = std::get_if<ConductorMaterial::EtaK>(&m.source)) {
      for (int i = 0; i < 3; ++i) check_eta_k(ek->eta[i], ek->k[i], str(" in RGB channel ", i));
    } else {
      const auto& s = std::get<ConductorMaterial::Spectra>(m.source);
      for (int l = int(lambda_min); l <= int(lambda_max); ++l)
        check_eta_k(s.eta(Float(l)), s.k(Float(l)), str(" at ", l, " nm"));
      for (int i = 0; i < 3; ++i) check_eta_k(s.rgb_eta[i], s.rgb_k[i], str(" in RGB channel ", i));
    }
  }
  // Measured spectra render exactly only in spectral mode (RGB mode uses the
  // fitted rgb_eta, rgb_k).
  static bool needs_spectral(const ConductorMaterial& m) { return m.is_measured(); }
  static bool has_specular(const ConductorMaterial& m) { return TrowbridgeReitz(m.roughness).effectively_smooth(); }
};

}  // namespace prism
