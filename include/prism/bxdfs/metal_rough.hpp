// prism/bxdfs/metal_rough.hpp — the glTF 2.0 metallic-roughness material
// (glTF 2.0 specification, Appendix B) with KHR_materials_ior,
// KHR_materials_specular, KHR_materials_anisotropy (an anisotropic
// Trowbridge–Reitz lobe, alpha_t = mix(alpha, 1, strength^2) along the
// material's direction: MetalRoughMaterial::anisotropy, shading_frame()),
// KHR_materials_transmission (thin-walled) and, for
// KHR_materials_volume and _dispersion, a refracting "glass" lobe in place
// of the thin transmission (make_refractive(); docs/gltf.md, Volumes).
//
// The model, per channel (RGB) or wavelength (spectral), in the local shading
// frame; wm is the half vector of wo and wi (of wo and the mirror image of wi
// for a transmission), c = |wo.wm|, s(c) = (1 - c)^5 (Schlick's weight):
//
//   material   = mix(dielectric, metal, metallic)
//   metal      = specular_brdf * (base + (1 - base) s(c))          (conductor_fresnel)
//   dielectric = w F(c) specular_brdf                               (the Fresnel layer)
//              + (1 - T) base / pi * B(|cos_o|) B(|cos_i|)          (diffuse base)
//              + T base (1 - w Fmax(c)) specular_btdf               (thin transmission)
//   F(c)       = F0 + (1 - F0) s(c),  F0 = min(((ior - 1)/(ior + 1))^2 specular_color, 1)
//   Fmax(c)    = the same with F0max = max over channels of F0 (the spec's max_value)
//   B(mu)      = 1 - w Fmax(mu)
//
// with w = specular (KHR_materials_specular's factor: F90 = w), T =
// transmission, alpha = roughness^2, specular_brdf = D G / (4 |cos_o cos_i|)
// the Trowbridge–Reitz lobe with the height-correlated Smith G (microfacet.hpp,
// as the spec's Appendix B writes it), and specular_btdf the same lobe
// mirrored through the surface: KHR_materials_transmission without
// KHR_materials_volume describes a thin-walled surface, two back-to-back
// interfaces, so transmitted light is not bent on average and only the
// microfacets blur it: specular_btdf(wo, wi) = specular_brdf(wo, wi') with
// wi' = (wi.x, wi.y, -wi.z) (the transmission half vector of the extension's
// notes, normalize(V - 2 (N.L) N + L)). No 1/eta^2 factor: the light ends in
// the medium it came from (BSDFSample::eta = 1).
//
// Where this departs from the spec's sample code, and why (docs/metal_rough.md):
// - Appendix B's fresnel_mix weighs the diffuse base by 1 - F(wo.wm). That
//   is not energy conserving (the spec says so, "Coupling Diffuse and
//   Specular Reflection"): at grazing incidence a smooth surface reflects
//   F ~ 1 specularly and still ~ base diffusely, an albedo near 2. A path
//   tracer must conserve energy (Appendix B: the BRDF MUST be positive,
//   reciprocal and energy conserving), so the diffuse base is coupled by the
//   reciprocal product B(|cos_o|) B(|cos_i|) the spec cites (Burley 2012).
//   The base then scatters at most B(mu_o) (1 - w Fbar), Fbar the
//   cosine-weighted mean of Fmax over wi, so the albedo is <= 1 when the
//   layer's albedo E(mu_o) <= w Fmax(mu_o) + B(mu_o) w Fbar: with equality
//   short of the slack for a smooth layer (E = w F(mu_o)); for a rough one
//   the microfacets' spread of wo.wm raises F but masking lowers E, and the
//   furnace tests check the bound over roughness, angle, ior and colours.
// - The transmission lobe keeps the half-vector coupling 1 - w Fmax(wo.wm):
//   it and the Fresnel layer are two fates of light meeting one microfacet, so
//   together they scatter at most what the microfacet lobe does (<= 1).
// - The specular weight w scales F90 as well as F0, as KHR_materials_specular
//   specifies; ior = 0 gives F0 = 1 (KHR_materials_ior's special case).
//
// BxDF conventions (bxdf.hpp): eval excludes the cosine; pdf per solid angle;
// both sides of the surface behave alike (wo.z < 0 mirrors the
// configuration, like the diffuse BxDF and the conductor). Roughness 0 (any
// alpha = roughness^2 below TrowbridgeReitz::smooth_alpha, i.e. roughness
// below 1/64) takes the exact specular path: the Fresnel layer and the metal
// become one delta reflection (f = F(|cos_o|) / |cos_o|) and the transmission
// a delta straight through (wi = -wo); the diffuse lobe stays, so the
// BxDF's flags hold both specular and diffuse lobes. eval and pdf sum the
// non-specular lobes only; sample() picks a lobe with probability
// proportional to an estimate of its albedo at wo (lobe_weights()), and
// returns, for a non-specular lobe, the f and pdf eval() and pdf() give at
// the sampled direction (the one-sample mixture over all non-specular lobes),
// so MIS sees one density.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/hooks.hpp"
#include "prism/bxdfs/dielectric.hpp"
#include "prism/bxdfs/microfacet.hpp"
#include "prism/bxdfs/ms_compensation.hpp"
#include "prism/bxdfs/sheen.hpp"
#include "prism/bxdfs/thin_film.hpp"
#include "prism/bxdfs/volume.hpp"
#include "prism/error.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/sampling/warps.hpp"
#include "prism/textures/normal_map.hpp"
#include "prism/textures/texture.hpp"
#include "prism/spectra/rgb.hpp"
#include "prism/spectra/traits.hpp"

namespace prism {

namespace detail {
// Schlick's weight s(c) = (1 - c)^5 and its complement 1 - s(c), the latter
// as c (5 - 10 c + 10 c^2 - 5 c^3 + c^4): no cancellation for small c, so
// 1 - F is positive (never rounded to 0) whenever c > 0 and F0 < 1.
// c is clamped to [0, 1].
inline Float schlick_weight(Float c) {
  Float x = 1 - std::clamp(c, Float(0), Float(1));
  Float x2 = x * x;
  return x2 * x2 * x;
}
inline Float schlick_complement(Float c) {
  c = std::clamp(c, Float(0), Float(1));
  // The polynomial rounds a few ulps above 1 for c just below 1, which would
  // make F = 1 - (1 - F0)(1 - s) of a channel with F0 = 0 slightly negative
  // (a yellow specular colour's blue): at most 1.
  return std::min(Float(1), c * (5 + c * (-10 + c * (10 + c * (-5 + c)))));
}
}  // namespace detail

template <class S>
class MetalRoughBxDF {
 public:
  MetalRoughBxDF() = default;
  // Parameters already in their domain (bxdf_traits::make clamps them):
  // base colour and dielectric F0 per channel in [0, 1], f0_max >= every
  // channel of dielectric_f0, specular, metallic and transmission in [0, 1].
  MetalRoughBxDF(const TrowbridgeReitz& distrib, const S& base, const S& dielectric_f0, Float f0_max, Float specular,
                 Float metallic, Float transmission)
      : m_distrib(distrib),
        m_base(base),
        m_f0(dielectric_f0),
        m_f0_max(f0_max),
        m_w(specular),
        m_metallic(metallic),
        m_diffuse_k((1 - metallic) * (1 - transmission)),
        m_trans_k((1 - metallic) * transmission),
        m_layer_k(1 - metallic),
        m_base_avg(base.average()) {}

  // KHR_materials_volume (thicknessFactor > 0): the surface bounds a
  // refracting volume of relative index eta (wo.z > 0 outside). The thin
  // transmission lobe becomes the "glass" lobe: the rough (or smooth)
  // dielectric interface of dielectric.hpp with the exact Fresnel
  // reflectance, weighted by (1 - metallic) T, its transmission tinted by the
  // base colour at every crossing (the extension: base colour acts at the
  // boundary, absorption inside). The Fresnel layer's reflection keeps only
  // the remaining (1 - metallic)(1 - T) over the diffuse base, so
  //   material = metallic metal + (1 - metallic)(1 - T)(layer + diffuse)
  //            + (1 - metallic) T [R brdf + (1 - R) base btdf]
  // with the glass lobe's R and btdf those of Walter et al. 2007, which the
  // extension's Layering section names. Unlike the rest of the model the
  // glass lobe is not mirrored for wo.z < 0: from inside the interface sees
  // 1 / eta (and total internal reflection). KHR_materials_specular does not
  // act on the glass lobe (its F0 is the ior's).
  void make_refractive(Float eta) {
    m_glass = DielectricBxDF<S>(eta, m_distrib);
    m_glass_k = m_trans_k;
    m_trans_k = 0;
    m_layer_k = (1 - m_metallic) - m_glass_k;
  }
  bool is_refractive() const { return m_glass_k > 0; }

  // Kulla and Conty's energy compensation of the rough lobes (off unless
  // called; MetalRoughMaterial::multiple_scattering). Call after
  // make_refractive(). With E(mu), E_avg the single-scattering albedo of the
  // microfacet lobe for F = 1 (MicrofacetAlbedoTable, as the conductor) and
  // white(mu_o, mu_i) = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)):
  // - the metal gains metallic F_ms(F_avg) white, F_avg = F0 + (1 - F0) / 21
  //   per channel (Schlick's F with F0 = base colour: 2 int F mu dmu);
  // - the dielectric layer gains layer_k F_ms(w (F0 + (1 - F0) / 21)) white;
  // - the diffuse base is weighted by what the compensated layer (of F0max)
  //   does not reflect, (1 - E_l(mu_o)) (1 - E_l(mu_i)) / (1 - E_l,avg) in
  //   place of B(mu_o) B(mu_i), with E_l(mu) = w (F0max A(mu) + E(mu) -
  //   A(mu)) + F_ms,max (1 - E(mu)) (A: MicrofacetAlbedoTable's Schlick part),
  //   so a white base under a white layer has albedo 1;
  // - a glass lobe gets DielectricBxDF's compensation.
  // Left off where 1 - E_avg < ms_min_average_loss (alpha below ~0.007, a
  // mean loss under 0.1%). The thin transmission lobe is not compensated.
  // The added lobes are sampled with the diffuse lobe's cosine-weighted
  // directions, their albedo added to its selection weight. Smooth surfaces
  // are unchanged.
  // The compensation's constants, made from the tables where they are
  // needed (only a flag is kept, so the BxDF stays as small as without it).
  struct MS {
    S lobe{};  // metallic F_ms(metal) + layer_k F_ms(layer), per channel
    Float alpha = 0, inv_norm = 0;  // inv_norm = 1 / (pi (1 - E_avg))
    Float fms_max = 0;              // F_ms of the F0max layer
    Float base_norm = 0;            // 1 / (1 - E_l,avg); 0 when the layer reflects everything
    bool active = false;
  };
  MS ms_state() const {
    MS ms;
    if (is_smooth()) return ms;
    const auto& t = MicrofacetAlbedoTable::get();
    ms.alpha = std::min(Float(1), std::sqrt(m_distrib.alpha_x() * m_distrib.alpha_y()));
    const Float e_avg = t.E_avg(ms.alpha);
    if (!(1 - e_avg >= ms_min_average_loss)) return ms;  // alpha below ~0.007 (dielectric.hpp)
    ms.inv_norm = inv_pi / (1 - e_avg);
    using MSS = MultipleScattering<S>;
    for (int c = 0; c < S::size; ++c) {
      Float k = 0;
      if (m_metallic > 0) k += m_metallic * MSS::fms(m_base[c] + (1 - m_base[c]) / 21, e_avg);
      if (m_w > 0 && m_layer_k > 0) k += m_layer_k * MSS::fms(m_w * (m_f0[c] + (1 - m_f0[c]) / 21), e_avg);
      ms.lobe[c] = k;
    }
    ms.fms_max = m_w > 0 ? MSS::fms(m_w * (m_f0_max + (1 - m_f0_max) / 21), e_avg) : 0;
    Float a_avg = t.A_avg(ms.alpha);
    Float layer_avg = m_w * (m_f0_max * a_avg + (e_avg - a_avg)) + ms.fms_max * (1 - e_avg);
    ms.base_norm = 1 - layer_avg > Float(1e-6) ? 1 / (1 - layer_avg) : 0;
    ms.active = true;
    return ms;
  }
  void enable_multiple_scattering() {
    if (m_glass_k > 0) m_glass.enable_multiple_scattering();
    m_ms = ms_state().active;
  }
  bool multiple_scattering() const { return m_ms || m_glass.multiple_scattering(); }
  const DielectricBxDF<S>& glass() const { return m_glass; }

  bool is_smooth() const { return m_distrib.effectively_smooth(); }

  // KHR_materials_clearcoat: a dielectric coat (ior 1.5: Schlick's F with
  // F0 = 0.04) of weight c in [0, 1] over the whole material, with its own
  // Trowbridge–Reitz lobe and normal (unit, in this BxDF's local frame):
  //   coated(wo, wi) = c F(wo.wm) D G / (4 |cos_o cos_i|)             (coat, reflection only)
  //                  + T(mu_o) T(mu_i) material(wo, wi),   T(mu) = 1 - c F(mu)
  // with mu the cosines to the coat's normal. The base is weighted by what
  // the coat lets through on the way in and on the way out (reciprocal;
  // the extension's sample code weighs it once, by the view direction's
  // 1 - c F). The coat reflects at most c F(mu_o) (its microfacets' Fresnel
  // spread is outweighed by masking), so the albedo stays <= 1 when the
  // base's does. Roughness below TrowbridgeReitz::smooth_alpha is a delta
  // reflection about the coat's normal. c = 0 leaves the material as it was.
  void set_clearcoat(Float weight, const TrowbridgeReitz& distrib, const Vector3f& normal = Vector3f(0, 0, 1)) {
    m_coat = std::clamp(weight, Float(0), Float(1));
    m_coat_distrib = distrib;
    m_coat_tilted = !(normal.x == 0 && normal.y == 0 && normal.z == 1);
    m_coat_frame = m_coat_tilted ? Frame::from_z(normal) : Frame{};
  }
  Float clearcoat() const { return m_coat; }
  const TrowbridgeReitz& clearcoat_distribution() const { return m_coat_distrib; }

  // KHR_materials_sheen (sheen.hpp): the Charlie lobe of this colour (per
  // channel or wavelength, in [0, 1]) and roughness over the material, under
  // the clear coat:
  //   sheen_layer(wo, wi) = colour D V / max(1, E(mu_o), E(mu_i))
  //                       + material(wo, wi) min(1 - c E1(mu_o), 1 - c E1(mu_i))
  // with c the colour's largest channel, E the white lobe's albedo
  // (SheenAlbedoTable) and E1 = min(E, 1). The extension's sheen is D V; the
  // division, which leaves it unchanged wherever E <= 1, keeps the lobe from
  // reflecting more than it receives at grazing angles for small roughness,
  // where the fitted shadowing lets E reach 4. The sheen is sampled
  // uniformly over wo's hemisphere with probability s / (s + 1 - c E1(mu_o)),
  // s = mean(colour) E1(mu_o). A black colour leaves the material as it was.
  void set_sheen(const S& colour, Float roughness) {
    m_sheen_max = colour.max_component();
    if (!(m_sheen_max > 0)) {
      m_sheen_max = 0;
      return;
    }
    m_sheen = colour;
    m_sheen_r = std::clamp(roughness, sheen_min_roughness, Float(1));
  }
  Float sheen() const { return m_sheen_max; }

  S eval(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (!(m_coat > 0)) return inner_eval(wo, wi, mode);
    if (wo.z == 0 || wi.z == 0) return S{};
    const Coat c = coat(wo, wi);
    return inner_eval(wo, wi, mode) * (c.t_o * c.t_i) + S(c.f);
  }
  Float pdf(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (!(m_coat > 0)) return inner_pdf(wo, wi, mode);
    if (wo.z == 0 || wi.z == 0) return 0;
    const Coat c = coat(wo, wi);
    return c.p * c.pdf + (1 - c.p) * inner_pdf(wo, wi, mode);
  }
  // With a coat, uc first picks the coat with probability c F(mu_o), then
  // (rescaled) the material's lobe.
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float uc, Point2f u, TransportMode mode) const {
    if (!(m_coat > 0)) return inner_sample(wo, uc, u, mode);
    if (wo.z == 0) return std::nullopt;
    Vector3f lo = coat_local(wo);
    const bool flip = lo.z < 0;
    if (flip) lo.z = -lo.z;
    const Float p = m_coat * coat_fresnel(lo.z);
    if (uc < p) {
      Vector3f li;
      if (m_coat_distrib.effectively_smooth()) {
        li = Vector3f(-lo.x, -lo.y, lo.z);
      } else {
        li = reflect(lo, m_coat_distrib.sample_wm(lo, u));
        if (!(li.z > 0)) return std::nullopt;
      }
      if (flip) li.z = -li.z;
      const Vector3f wi = coat_world(li);
      if (wi.z == 0) return std::nullopt;
      if (m_coat_distrib.effectively_smooth())
        return BSDFSample<S>{S(m_coat * coat_fresnel(lo.z) / std::abs(wi.z)), wi, p, BxDFFlags::specular_reflection};
      const Float pdf_wi = pdf(wo, wi, mode);
      if (!(pdf_wi > 0)) return std::nullopt;
      return BSDFSample<S>{eval(wo, wi, mode), wi, pdf_wi, BxDFFlags::glossy_reflection};
    }
    auto bs = inner_sample(wo, std::min((uc - p) / (1 - p), one_minus_epsilon), u, mode);
    if (!bs) return std::nullopt;
    if (bs->is_specular()) {
      Vector3f li = coat_local(bs->wi);
      bs->f = bs->f * ((1 - m_coat * coat_fresnel(lo.z)) * (1 - m_coat * coat_fresnel(std::abs(li.z))));
      bs->pdf *= 1 - p;
      return bs;
    }
    bs->f = eval(wo, bs->wi, mode);
    bs->pdf = pdf(wo, bs->wi, mode);
    if (!(bs->pdf > 0)) return std::nullopt;
    return bs;
  }

  BxDFFlags flags() const {
    BxDFFlags f = base_flags();
    if (m_sheen_max > 0) f = f | BxDFFlags::glossy_reflection;
    if (m_coat > 0)
      f = f | (m_coat_distrib.effectively_smooth() ? BxDFFlags::specular_reflection : BxDFFlags::glossy_reflection);
    return f;
  }

 private:
  // The coat at (wo, wi): its f, its sampling density, the probability of
  // sampling it at wo, and what it lets through at wo and wi.
  struct Coat {
    Float f = 0, pdf = 0, p = 0, t_o = 1, t_i = 1;
  };
  static Float coat_fresnel(Float mu) { return Float(0.04) + Float(0.96) * detail::schlick_weight(mu); }
  Vector3f coat_local(const Vector3f& w) const { return m_coat_tilted ? m_coat_frame.to_local(w) : w; }
  Vector3f coat_world(const Vector3f& w) const { return m_coat_tilted ? m_coat_frame.from_local(w) : w; }
  Coat coat(const Vector3f& wo, const Vector3f& wi) const {
    Vector3f lo = coat_local(wo), li = coat_local(wi);
    if (lo.z < 0) {
      lo.z = -lo.z;
      li.z = -li.z;
    }
    Coat c;
    c.p = m_coat * coat_fresnel(lo.z);
    c.t_o = 1 - c.p;
    c.t_i = 1 - m_coat * coat_fresnel(std::abs(li.z));
    if (!(li.z > 0) || !(lo.z > 0) || m_coat_distrib.effectively_smooth()) return c;
    Vector3f wm = lo + li;
    Float l2 = length_squared(wm);
    if (!(l2 > 0)) return c;
    wm = wm / std::sqrt(l2);
    Float d = m_coat_distrib.D(wm);
    if (!(d > 0)) return c;
    c.f = m_coat * coat_fresnel(dot(lo, wm)) * d * m_coat_distrib.G(lo, li) / (4 * lo.z * li.z);
    c.pdf = m_coat_distrib.G1(lo) * d / (4 * lo.z);
    return c;
  }

  // The material under the coat: the sheen over the base (set_sheen).
  Float sheen_albedo(Float mu) const { return SheenAlbedoTable::get().E(mu, m_sheen_r); }
  Float sheen_probability(Float e_o) const {
    const Float s = m_sheen.average() * std::min(e_o, Float(1));
    return s / (s + (1 - m_sheen_max * std::min(e_o, Float(1))));
  }
  // What the sheen leaves to the base: min(1 - c E1(mu_o), 1 - c E1(mu_i)).
  Float sheen_scale(Float e_o, Float e_i) const {
    return std::max(Float(0), 1 - m_sheen_max * std::min(std::max(e_o, e_i), Float(1)));
  }
  // The sheen lobe (reflection on wo's side only), mirrored like the base.
  S sheen_f(Vector3f wo, Vector3f wi, Float e_o, Float e_i) const {
    if (!(wo.z * wi.z > 0)) return S{};
    if (wo.z < 0) {
      wo.z = -wo.z;
      wi.z = -wi.z;
    }
    const Float v = charlie_sheen(m_sheen_r * m_sheen_r, wo, wi) / std::max({Float(1), e_o, e_i});
    return m_sheen * v;
  }
  // The sheen layer's f and pdf at (wo, wi) (either may be null), given
  // the white lobe's albedo e_o at mu_o and the sheen's sampling
  // probability p there; wo.z and wi.z are not 0.
  void inner_eval_pdf(const Vector3f& wo, const Vector3f& wi, TransportMode mode, Float e_o, Float p, S* f,
                      Float* pdf) const {
    if (f) {
      const Float e_i = sheen_albedo(std::abs(wi.z));
      *f = base_eval(wo, wi, mode) * sheen_scale(e_o, e_i) + sheen_f(wo, wi, e_o, e_i);
    }
    if (pdf) *pdf = (wo.z * wi.z > 0 ? p * inv_2pi : 0) + (1 - p) * base_pdf(wo, wi, mode);
  }
  S inner_eval(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (!(m_sheen_max > 0)) return base_eval(wo, wi, mode);
    if (wo.z == 0 || wi.z == 0) return S{};
    S f;
    inner_eval_pdf(wo, wi, mode, sheen_albedo(std::abs(wo.z)), 0, &f, nullptr);
    return f;
  }
  Float inner_pdf(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (!(m_sheen_max > 0)) return base_pdf(wo, wi, mode);
    if (wo.z == 0 || wi.z == 0) return 0;
    Float pdf;
    inner_eval_pdf(wo, wi, mode, 0, sheen_probability(sheen_albedo(std::abs(wo.z))), nullptr, &pdf);
    return pdf;
  }
  std::optional<BSDFSample<S>> inner_sample(Vector3f wo, Float uc, Point2f u, TransportMode mode) const {
    if (!(m_sheen_max > 0)) return base_sample(wo, uc, u, mode);
    if (wo.z == 0) return std::nullopt;
    const Float e_o = sheen_albedo(std::abs(wo.z));
    const Float p = sheen_probability(e_o);
    if (uc < p) {
      Vector3f wi = sample_uniform_hemisphere(u);
      if (wo.z < 0) wi.z = -wi.z;
      if (wi.z == 0) return std::nullopt;
      S f;
      Float pdf;
      inner_eval_pdf(wo, wi, mode, e_o, p, &f, &pdf);
      if (!(pdf > 0)) return std::nullopt;
      return BSDFSample<S>{f, wi, pdf, BxDFFlags::glossy_reflection};
    }
    auto bs = base_sample(wo, std::min((uc - p) / (1 - p), one_minus_epsilon), u, mode);
    if (!bs) return std::nullopt;
    if (bs->is_specular()) {
      bs->f = bs->f * sheen_scale(e_o, sheen_albedo(std::abs(bs->wi.z)));
      bs->pdf *= 1 - p;
      return bs;
    }
    if (bs->wi.z == 0) return std::nullopt;
    inner_eval_pdf(wo, bs->wi, mode, e_o, p, &bs->f, &bs->pdf);
    if (!(bs->pdf > 0)) return std::nullopt;
    return bs;
  }

 public:
  S base_eval(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (wo.z == 0 || wi.z == 0) return S{};
    S g = glass_eval(wo, wi, mode);
    if (wo.z < 0) {
      wo.z = -wo.z;
      wi.z = -wi.z;
    }
    return eval_up(wo, wi) + g;
  }
  Float base_pdf(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (wo.z == 0 || wi.z == 0) return 0;
    const Lobes p = lobe_probabilities(wo.z);
    Float g = m_glass_k > 0 && p.glass > 0 ? p.glass * m_glass.pdf(wo, wi, mode) : 0;
    if (wo.z < 0) {
      wo.z = -wo.z;
      wi.z = -wi.z;
    }
    return pdf_up(wo, wi, p) + g;
  }

  // uc chooses the lobe (lobe_weights); u samples within it: a visible
  // normal for the reflection and the transmission, the cosine-weighted
  // hemisphere for the diffuse lobe (smooth lobes ignore u).
  std::optional<BSDFSample<S>> base_sample(Vector3f wo, Float uc, Point2f u, TransportMode mode) const {
    if (wo.z == 0) return std::nullopt;
    const Lobes p = lobe_probabilities(wo.z);
    int lobe = choose_lobe(p, uc);
    if (lobe < 0) return std::nullopt;
    if (lobe == 3) return sample_glass(wo, uc, u, mode, p);
    const Vector3f wo_world = wo;
    const bool flip = wo.z < 0;
    if (flip) wo.z = -wo.z;
    auto out = [&](BSDFSample<S> bs) -> std::optional<BSDFSample<S>> {
      if (flip) bs.wi.z = -bs.wi.z;
      if (m_glass_k > 0 && !bs.is_specular()) {  // the one-sample mixture includes the glass lobe
        bs.f += glass_eval(wo_world, bs.wi, mode);
        if (p.glass > 0) bs.pdf += p.glass * m_glass.pdf(wo_world, bs.wi, mode);
      }
      return bs;
    };
    const Float co = wo.z;
    if (is_smooth() && lobe != 1) {
      if (lobe == 0)
        return out({specular_fresnel(co) / co, Vector3f(-wo.x, -wo.y, wo.z), p.reflection,
                    BxDFFlags::specular_reflection});
      return out({m_base * (m_trans_k * base_weight(co) / co), -wo, p.transmission,
                  BxDFFlags::specular_transmission, 1});
    }
    Vector3f wi;
    BxDFFlags flags;
    if (lobe == 1) {
      wi = sample_cosine_hemisphere(u);
      flags = BxDFFlags::diffuse_reflection;
    } else {
      wi = reflect(wo, m_distrib.sample_wm(wo, u));
      if (!(wi.z > 0)) return std::nullopt;  // the microfacet sends it below the surface
      if (lobe == 0) {
        flags = BxDFFlags::glossy_reflection;
      } else {
        wi.z = -wi.z;  // through the thin surface
        flags = BxDFFlags::glossy_transmission;
      }
    }
    if (wi.z == 0) return std::nullopt;
    S f;
    Float pdf;
    eval_pdf_up(wo, wi, p, &f, &pdf);
    if (!(pdf > 0)) return std::nullopt;
    return out({f, wi, pdf, flags, 1});
  }

  BxDFFlags base_flags() const {
    BxDFFlags f = BxDFFlags::none;
    const bool smooth = is_smooth();
    if (m_metallic > 0 || (m_w > 0 && m_layer_k > 0))
      f = f | (smooth ? BxDFFlags::specular_reflection : BxDFFlags::glossy_reflection);
    if (m_glass_k > 0) f = f | m_glass.flags();
    if (m_ms) f = f | BxDFFlags::diffuse_reflection;  // the compensation's cosine-weighted samples
    // The base receives nothing when the layer reflects everything (F0 = 1, w = 1).
    const bool base_lit = m_base_avg > 0 && (m_w < 1 || m_f0_max < 1);
    if (base_lit && m_diffuse_k > 0) f = f | BxDFFlags::diffuse_reflection;
    if (base_lit && m_trans_k > 0) f = f | (smooth ? BxDFFlags::specular_transmission : BxDFFlags::glossy_transmission);
    return f;
  }

  // The lobe-selection weights at |cos theta_o| = mu (not normalised): the
  // albedo each lobe would have if the microfacets lost nothing and every
  // Fresnel factor took one typical value c:
  //   reflection:   (1 - metallic) w mean(F(c)) + metallic mean(F_metal(c)),
  //   diffuse:      (1 - metallic)(1 - T) mean(base) B(mu),
  //   transmission: (1 - metallic) T mean(base) (1 - w Fmax(c)),
  // means over the channels. Smooth: c = mu exactly (the delta lobes' own
  // factor). Rough: the microfacets wo sees lean towards it, by about the
  // distribution's characteristic slope alpha, so c is the cosine between wo
  // and a normal tilted towards wo by atan(alpha):
  //   c = (mu + alpha sqrt(1 - mu^2)) / sqrt(1 + alpha^2),
  // which is mu for alpha = 0, and alpha / sqrt(1 + alpha^2), not 0, at
  // grazing incidence (with c = mu the transmission of a rough slab seen at
  // grazing incidence would be picked ~100 times too rarely). The Schlick
  // weight s(c) is then at least its cosine-weighted mean over the
  // hemisphere, 2 * integral of (1 - c)^5 c dc = 1/21, so that the reflection
  // weight is not 0 at normal incidence for F0 = 0 (ior = 1), where its f is
  // not. Each weight is 0 only where its lobe's f is 0 everywhere.
  // The glass lobe (refractive volumes only): (1 - metallic) T (R + (1 - R)
  // mean(base)), R the exact Fresnel reflectance at cos_o (signed: from
  // inside, 1 under total internal reflection).
  struct Lobes {
    Float reflection = 0, diffuse = 0, transmission = 0, glass = 0;
  };
  // cos_o may be signed (the glass lobe needs the side); the other lobes use |cos_o|.
  Lobes lobe_weights(Float cos_o) const {
    Lobes w;
    const Float mu = std::abs(cos_o);
    if (m_glass_k > 0) {
      Float R = fresnel_dielectric(cos_o, m_glass.eta());
      w.glass = m_glass_k * (R + (1 - R) * m_base_avg);
    }
    Float c = mu;
    if (!is_smooth()) {
      Float a = std::max(m_distrib.alpha_x(), m_distrib.alpha_y());
      c = std::min(Float(1), (mu + a * safe_sqrt(1 - mu * mu)) / std::sqrt(1 + a * a));
    }
    Float s = detail::schlick_weight(c);
    Float sc = detail::schlick_complement(c);  // 1 - s, without cancellation
    if (!is_smooth() && s < Float(1) / 21) {
      s = Float(1) / 21;
      sc = Float(20) / 21;
    }
    if (m_w > 0 || m_metallic > 0) {
      // F = 1 - (1 - F0)(1 - s), per channel.
      Float d = m_w > 0 ? m_w * (1 - (1 - m_f0.average()) * sc) : 0;
      Float m = m_metallic > 0 ? 1 - (1 - m_base_avg) * sc : 0;
      w.reflection = m_layer_k * d + m_metallic * m;
    }
    if (m_ms) {
      const MS ms = ms_state();
      Float loss = 1 - MicrofacetAlbedoTable::get().E(mu, ms.alpha);
      w.diffuse = m_diffuse_k * m_base_avg * (1 - layer_albedo(ms, mu)) + ms.lobe.average() * loss;
    } else {
      w.diffuse = m_diffuse_k * m_base_avg * base_weight(mu);
    }
    w.transmission = m_trans_k * m_base_avg * ((1 - m_w) + m_w * (1 - m_f0_max) * sc);
    return w;
  }
  // lobe_weights normalised to sum to 1 (all 0 if they are).
  Lobes lobe_probabilities(Float cos_o) const {
    Lobes w = lobe_weights(cos_o);
    Float total = w.reflection + w.diffuse + w.transmission + w.glass;
    if (!(total > 0)) return {};
    return {w.reflection / total, w.diffuse / total, w.transmission / total, w.glass / total};
  }

  // The Fresnel factors (c = |wo.wm|, or |cos theta| for the base coupling).
  // Reflection: (1 - metallic) w F(c) + metallic F_metal(c), per channel.
  // With iridescence each Fresnel factor is mix(F, film(c), factor), the
  // film's reflectance over the layer's ior or the metal's (set_iridescence).
  S specular_fresnel(Float c) const {
    Float sc = detail::schlick_complement(c);
    S out{};
    const Float f = m_irid.factor;
    if (m_w > 0 && m_layer_k > 0) {
      S layer = S(1) - (S(1) - m_f0) * sc;
      if (f > 0) layer = layer * (1 - f) + film(c, S(m_irid.n_layer)) * f;
      out += layer * (m_layer_k * m_w);
    }
    if (m_metallic > 0) {
      S metal = S(1) - (S(1) - m_base) * sc;
      if (f > 0) metal = metal * (1 - f) + film(c, m_irid.n_metal) * f;
      out += metal * m_metallic;
    }
    return out;
  }
  // What the Fresnel layer leaves to the base: 1 - w Fmax(c)
  // = (1 - w) + w (1 - F0max)(1 - s(c)), without cancellation. With
  // iridescence Fmax is (1 - factor) Fmax(c) + factor max(film(c)), at
  // least the largest channel of the mixed F: the base never gets more than
  // the layer leaves.
  Float base_weight(Float c) const {
    const Float plain = (1 - m_w) + m_w * (1 - m_f0_max) * detail::schlick_complement(c);
    if (!(m_irid.factor > 0) || !(m_w > 0)) return plain;
    const Float f = m_irid.factor;
    const Float schlick_max = 1 - (1 - m_f0_max) * detail::schlick_complement(c);
    return std::max(Float(0), 1 - m_w * ((1 - f) * schlick_max + f * film(c, S(m_irid.n_layer)).max_component()));
  }

  // KHR_materials_iridescence: a thin film (index n_film, thickness d_nm
  // nanometres) over the dielectric layer (index n_layer, its ior) and over
  // the metal (per channel or wavelength the index whose F0 is the base
  // colour, ior_from_f0), seen in the Fresnel factors as mix(F, R_film,
  // factor), R_film from thin_film.hpp at the half vector's cosine: per
  // wavelength in spectral mode (`lambda`, the path's wavelengths), its
  // colour under D65 in RGB mode. factor 0 or d_nm 0 leaves the material as
  // it was. The glass lobe of a refracting volume keeps its own Fresnel.
  void set_iridescence(Float factor, Float n_film, Float d_nm, Float n_layer, const S& n_metal, const S& lambda) {
    if (!(factor > 0) || !(d_nm > 0)) {
      m_irid = {};
      return;
    }
    m_irid.factor = std::min(factor, Float(1));
    m_irid.n_film = n_film;
    m_irid.d = d_nm;
    m_irid.n_layer = n_layer;
    m_irid.n_metal = n_metal;
    m_irid.lambda = lambda;
  }
  Float iridescence() const { return m_irid.factor; }
  // With the compensation: the directional albedo E_l(mu) of the compensated
  // layer of F0max (enable_multiple_scattering), at most 1.
  Float layer_albedo(const MS& ms, Float mu) const {
    const auto& t = MicrofacetAlbedoTable::get();
    Float e = t.E(mu, ms.alpha), a = t.A(mu, ms.alpha);
    return std::min(Float(1), m_w * (m_f0_max * a + (e - a)) + ms.fms_max * (1 - e));
  }

  const TrowbridgeReitz& distribution() const { return m_distrib; }
  const S& base_color() const { return m_base; }
  const S& dielectric_f0() const { return m_f0; }
  Float f0_max() const { return m_f0_max; }
  Float specular() const { return m_w; }
  Float metallic() const { return m_metallic; }
  Float transmission() const { return (1 - m_metallic) > 0 ? (m_trans_k + m_glass_k) / (1 - m_metallic) : 0; }

 private:
  // The film's reflectance at cos c over substrates of index n (per channel
  // or wavelength).
  S film(Float c, const S& n) const {
    if constexpr (spectrum_traits<S>::is_spectral) {
      S out{};
      for (int i = 0; i < S::size; ++i)
        out[i] = thin_film_reflectance(c, m_irid.n_film, m_irid.d, n[i], m_irid.lambda[i]);
      return out;
    } else {
      return thin_film_reflectance_rgb(c, m_irid.n_film, m_irid.d, n);
    }
  }

  // The microfacet lobe at (wo, wi), both in the upper hemisphere:
  // D G / (4 cos_o cos_i), its sampling density G1(wo) D / (4 cos_o), and
  // c = wo.wm. False where both are 0 (a degenerate half vector, D = 0).
  struct Microfacet {
    Float dg = 0, pdf = 0, c = 0;
  };
  bool microfacet(const Vector3f& wo, const Vector3f& wi, Microfacet& out) const {
    Vector3f wm = wo + wi;
    Float l2 = length_squared(wm);
    if (!(l2 > 0)) return false;
    wm = wm / std::sqrt(l2);
    Float d = m_distrib.D(wm);
    if (!(d > 0)) return false;
    out.dg = d * m_distrib.G(wo, wi) / (4 * wo.z * wi.z);
    out.pdf = m_distrib.G1(wo) * d / (4 * wo.z);
    out.c = dot(wo, wm);
    return true;
  }

  // f (if f is not null) and the pdf (if pdf is not null; with the lobe
  // probabilities p at wo) for wo.z > 0, wi.z != 0: one microfacet
  // evaluation serves both.
  // Rounding in the Fresnel and coupling terms can leave f a few ulps below
  // zero where it should be exactly 0: clamp, so no sample is negative.
  void eval_pdf_up(const Vector3f& wo, const Vector3f& wi, const Lobes& p, S* f, Float* pdf) const {
    eval_pdf_up_unclamped(wo, wi, p, f, pdf);
    if (f) *f = clamp_zero(*f);
  }
  void eval_pdf_up_unclamped(const Vector3f& wo, const Vector3f& wi, const Lobes& p, S* f, Float* pdf) const {
    if (f) *f = S{};
    if (pdf) *pdf = 0;
    Microfacet mf;
    if (wi.z > 0) {
      if (f && m_ms) {
        const MS ms = ms_state();
        const auto& t = MicrofacetAlbedoTable::get();
        if (m_diffuse_k > 0)
          *f = m_base * (m_diffuse_k * inv_pi * (1 - layer_albedo(ms, wo.z)) * (1 - layer_albedo(ms, wi.z)) *
                         ms.base_norm);
        Float lo = 1 - t.E(wo.z, ms.alpha), li = 1 - t.E(wi.z, ms.alpha);
        *f += ms.lobe * (std::max(Float(0), lo) * std::max(Float(0), li) * ms.inv_norm);
      } else if (f && m_diffuse_k > 0) {
        *f = m_base * (m_diffuse_k * inv_pi * base_weight(wo.z) * base_weight(wi.z));
      }
      if (pdf) *pdf = p.diffuse * pdf_cosine_hemisphere(wi.z);
      if (is_smooth() || !((m_w > 0 && m_layer_k > 0) || m_metallic > 0) || !microfacet(wo, wi, mf)) return;
      if (f) *f += specular_fresnel(mf.c) * mf.dg;
      if (pdf) *pdf += p.reflection * mf.pdf;
    } else {
      if (is_smooth() || !(m_trans_k > 0) || !microfacet(wo, Vector3f(wi.x, wi.y, -wi.z), mf)) return;
      if (f) *f = m_base * (m_trans_k * base_weight(mf.c) * mf.dg);
      if (pdf) *pdf = p.transmission * mf.pdf;
    }
  }
  S eval_up(const Vector3f& wo, const Vector3f& wi) const {
    S f;
    eval_pdf_up(wo, wi, Lobes{}, &f, nullptr);
    return f;
  }
  Float pdf_up(const Vector3f& wo, const Vector3f& wi, const Lobes& p) const {
    Float pdf;
    eval_pdf_up(wo, wi, p, nullptr, &pdf);
    return pdf;
  }
  // 0 reflection, 1 diffuse, 2 transmission, 3 glass, -1 none. Never a lobe
  // of probability 0 (uc near 1 with probabilities that round short of 1).
  static int choose_lobe(const Lobes& p, Float uc) {
    const Float pr[4] = {p.reflection, p.diffuse, p.transmission, p.glass};
    int lobe = 0;
    Float acc = pr[0];
    while (lobe < 3 && !(uc < acc)) acc += pr[++lobe];
    if (pr[lobe] > 0) return lobe;
    for (int i = 3; i >= 0; --i)
      if (pr[i] > 0) return i;
    return -1;
  }

  // The glass lobe at (wo, wi), both as given (not mirrored): (1 - metallic) T
  // times the dielectric's f, times the base colour for a transmission.
  S glass_eval(const Vector3f& wo, const Vector3f& wi, TransportMode mode) const {
    if (!(m_glass_k > 0)) return S{};
    S f = m_glass.eval(wo, wi, mode);
    if (wo.z * wi.z < 0) f = f * m_base;
    return f * m_glass_k;
  }
  // The glass lobe was chosen: uc is re-used (rescaled into the lobe's
  // interval) to pick the dielectric's reflection or refraction. A specular
  // sample carries the lobe's own f and probability; a rough one the
  // mixture's f and pdf over every non-specular lobe.
  std::optional<BSDFSample<S>> sample_glass(const Vector3f& wo, Float uc, Point2f u, TransportMode mode,
                                            const Lobes& p) const {
    Float start = p.reflection + p.diffuse + p.transmission;
    Float uc2 = std::clamp((uc - start) / p.glass, Float(0), one_minus_epsilon);
    auto bs = m_glass.sample(wo, uc2, u, mode);
    if (!bs) return std::nullopt;
    const bool through = bs->is_transmission();
    if (bs->is_specular()) {
      bs->f = (through ? bs->f * m_base : bs->f) * m_glass_k;
      bs->pdf *= p.glass;
      if (bs->f.is_black()) return std::nullopt;
      return bs;
    }
    bs->f = base_eval(wo, bs->wi, mode);
    bs->pdf = base_pdf(wo, bs->wi, mode);
    if (!(bs->pdf > 0)) return std::nullopt;
    return bs;
  }

  TrowbridgeReitz m_distrib;
  S m_base{}, m_f0{};
  Float m_f0_max = 0, m_w = 0, m_metallic = 0, m_diffuse_k = 0, m_trans_k = 0, m_layer_k = 1, m_base_avg = 0;
  DielectricBxDF<S> m_glass;
  Float m_glass_k = 0;  // (1 - metallic) T for a refractive volume, else 0
  bool m_ms = false;  // enable_multiple_scattering()
  struct Iridescence {
    Float factor = 0, n_film = 1, d = 0, n_layer = 1;
    S n_metal{}, lambda{};
  };
  Iridescence m_irid;  // set_iridescence()
  Float m_coat = 0;   // set_clearcoat()
  TrowbridgeReitz m_coat_distrib;
  Frame m_coat_frame;
  bool m_coat_tilted = false;
  S m_sheen{};            // set_sheen()
  Float m_sheen_max = 0;  // its largest channel; 0: no sheen
  Float m_sheen_r = 1;    // its roughness (alpha = r^2)
};

// The glTF metallic-roughness material with KHR_materials_ior,
// KHR_materials_specular and KHR_materials_transmission. Defaults are glTF's
// (a white, fully metallic, fully rough surface; ior 1.5, specular 1,
// specular colour 1, no transmission). Emission is not a material
// property in prism: give the instance an AreaEmission.
//
// Domains (bxdf_traits<MetalRoughBxDF<S>>::validate, called by Scene::build):
// base_color, metallic, roughness, specular, transmission in [0, 1] and
// specular_color >= 0 are clamped into their domain, with one warning per
// material on std::cerr; NaN or infinite values, and an ior below 1 other
// than exactly 0, throw prism::Error (no value is a sensible stand-in).
// The glTF textures of a metallic-roughness material, each optional; held by
// shared pointer so that materials stay cheap to copy and images are shared.
// Each texture's factor multiplies the material's own value.
struct MetalRoughTextures {
  std::optional<ImageTexture> base_color;          // sRGB rgb x base_color, alpha x alpha
  std::optional<ImageTexture> metallic_roughness;  // linear: B x metallic, G x roughness
  std::optional<ImageTexture> normal;              // tangent-space normal map
  Float normal_scale = 1;                          // normalTexture.scale
  std::optional<ImageTexture> transmission;        // KHR_materials_transmission: R x transmission
  std::optional<ImageTexture> specular;            // KHR_materials_specular: A x specular
  std::optional<ImageTexture> specular_color;      // KHR_materials_specular: sRGB rgb x specular_color
  // KHR_materials_anisotropy, linear: RG the direction in [-1, 1] (x 2 - 1)
  // in the tangent-bitangent plane, B x anisotropy (the strength).
  std::optional<ImageTexture> anisotropy;
  // KHR_materials_clearcoat, linear: R x clearcoat, G x clearcoat_roughness,
  // and the coat's own tangent-space normal map (none: the mesh's normal).
  std::optional<ImageTexture> clearcoat;
  std::optional<ImageTexture> clearcoat_roughness;
  std::optional<ImageTexture> clearcoat_normal;
  Float clearcoat_normal_scale = 1;
  // KHR_materials_iridescence, linear: R x iridescence; G picks the film's
  // thickness between iridescence_thickness_min and _max.
  std::optional<ImageTexture> iridescence;
  std::optional<ImageTexture> iridescence_thickness;
  // KHR_materials_sheen: sRGB rgb x sheen_color; linear A x sheen_roughness.
  std::optional<ImageTexture> sheen_color;
  std::optional<ImageTexture> sheen_roughness;
};

// glTF alphaMode: opaque ignores alpha; mask keeps a surface where alpha >=
// the cutoff and removes it elsewhere; blend keeps it with probability alpha
// (stochastic opacity: a path tracer's unbiased reading of blending).
enum class AlphaMode : uint8_t { opaque, mask, blend };

struct MetalRoughMaterial {
  RGB base_color{1};
  Float metallic = 1, roughness = 1;
  Float ior = 1.5f;               // KHR_materials_ior: >= 1, or 0 for F0 = 1
  Float specular = 1;             // KHR_materials_specular: specularFactor
  RGB specular_color{1};          // KHR_materials_specular: specularColorFactor (may exceed 1)
  Float transmission = 0;         // KHR_materials_transmission: transmissionFactor
  // KHR_materials_volume: thickness > 0 (the thicknessFactor; only its sign
  // matters to a path tracer, which traces the real geometry) makes the
  // surface the boundary of a refracting volume, absorbing by Beer–Lambert
  // (attenuation); 0 keeps the transmission thin-walled. See is_volume().
  Float thickness = 0;
  VolumeAbsorption attenuation{};  // attenuationColor, attenuationDistance (default: none)
  Float dispersion = 0;            // KHR_materials_dispersion: 20 / V_d (Abbe number), 0 = none
  // KHR_materials_anisotropy: the strength s in [0, 1] stretches the
  // Trowbridge–Reitz lobe along a direction of the tangent plane, alpha_t =
  // alpha + (1 - alpha) s^2 along it and alpha across it; the direction is
  // the mesh's tangent turned by anisotropy_rotation radians towards the
  // bitangent (then by the texture's, if any). 0: isotropic, as before.
  Float anisotropy = 0;
  Float anisotropy_rotation = 0;
  // KHR_materials_clearcoat: a dielectric coat (ior 1.5) of this weight in
  // [0, 1] over the material, with its own roughness (alpha = roughness^2)
  // and normal (MetalRoughBxDF::set_clearcoat). 0: no coat, as before.
  Float clearcoat = 0;
  Float clearcoat_roughness = 0;
  // KHR_materials_iridescence: a thin film of index iridescence_ior and a
  // thickness in nanometres (iridescence_thickness_max, or between min and
  // max by the thickness texture) over the material, mixed into its Fresnel
  // factors by this weight in [0, 1] (MetalRoughBxDF::set_iridescence). 0:
  // none, as before.
  Float iridescence = 0;
  Float iridescence_ior = 1.3f;
  Float iridescence_thickness_min = 100, iridescence_thickness_max = 400;
  // KHR_materials_sheen: the Charlie sheen of this colour (each channel in
  // [0, 1]) and roughness (alpha = roughness^2, at least
  // sheen_min_roughness) over the material, under the clear coat
  // (MetalRoughBxDF::set_sheen). Black: no sheen, as before.
  RGB sheen_color{0};
  Float sheen_roughness = 0;
  Float alpha = 1;                // baseColorFactor's alpha
  AlphaMode alpha_mode = AlphaMode::opaque;
  Float alpha_cutoff = 0.5f;
  // Vertex colours (glTF COLOR_0) multiply the base colour and alpha; the
  // hit's colour is white where a mesh has none.
  std::shared_ptr<const MetalRoughTextures> textures;
  std::string name = "metal_rough";
  // Kulla-Conty energy compensation of the rough lobes
  // (MetalRoughBxDF::enable_multiple_scattering); off by default.
  bool multiple_scattering = false;

  // A refracting volume: thickness > 0 with some transmission, and an ior
  // >= 1 (ior = 0, "F0 = 1", reflects everything and stays thin).
  bool is_volume() const { return thickness > 0 && transmission > 0 && ior >= 1; }
  // The volume's index of refraction: the Abbe law of KHR_materials_dispersion
  // (eta at the d line = ior) when dispersion > 0, else the constant ior.
  IOR volume_ior() const { return dispersion > 0 ? IOR(AbbeIOR{ior, dispersion}) : IOR(ior); }

  // The dielectric F0 from ior alone: ((ior - 1) / (ior + 1))^2; 1 for ior = 0.
  static Float f0_from_ior(Float ior) {
    if (ior == 0) return 1;
    if (!(ior > 0) || !std::isfinite(ior)) return Float(0.04);  // rejected by validate
    return sqr((ior - 1) / (ior + 1));
  }
};

namespace detail {
// A MetalRoughMaterial's numbers clamped into their domain (what make()
// renders); `clamped` lists what changed, for validate's warning.
struct MetalRoughParams {
  RGB base{0}, dielectric_f0{0};
  Float metallic = 0, roughness = 0, specular = 0, transmission = 0;
  Float anisotropy = 0, clearcoat = 0, clearcoat_roughness = 0, iridescence = 0, iridescence_thickness = 0;
  RGB sheen_color{0};
  Float sheen_roughness = 0;
};
inline Float unit_or_zero(Float v) { return v > 0 ? std::min(v, Float(1)) : Float(0); }  // NaN -> 0
// A texture's value at a hit: over the pixel's footprint (the texture's
// filtering) for TEXCOORD_0, at the point for TEXCOORD_1 (the footprint is
// TEXCOORD_0's).
inline RGBA lookup(const ImageTexture& t, const SurfaceInteraction& si) {
  if (t.texcoord == 1) return t.evaluate(si.uv1);
  return t.evaluate(si.uv, TextureFootprint{si.dudx, si.dvdx, si.dudy, si.dvdy});
}
// The numbers of a MetalRoughMaterial at a hit, before clamping.
struct MetalRoughFactors {
  RGB base_color;
  Float metallic, roughness, ior, specular;
  RGB specular_color;
  Float transmission;
  Float anisotropy;
  Float clearcoat, clearcoat_roughness;
  Float iridescence, iridescence_thickness;  // the film's thickness in nm
  RGB sheen_color;
  Float sheen_roughness;
};
// The film's thickness: a material's maximum (no texture), a hit's textured value.
inline Float film_thickness(const MetalRoughMaterial& m) { return m.iridescence_thickness_max; }
inline Float film_thickness(const MetalRoughFactors& f) { return f.iridescence_thickness; }
// The material's values at a hit: factors times textures times vertex colour.
inline MetalRoughFactors textured(const MetalRoughMaterial& m, const SurfaceInteraction& si) {
  MetalRoughFactors v{m.base_color * si.color, m.metallic,       m.roughness,    m.ior,
                      m.specular,              m.specular_color, m.transmission, m.anisotropy,
                      m.clearcoat,             m.clearcoat_roughness, m.iridescence, m.iridescence_thickness_max,
                      m.sheen_color,           m.sheen_roughness};
  if (const MetalRoughTextures* t = m.textures.get()) {
    if (t->base_color) v.base_color = v.base_color * lookup(*t->base_color, si).rgb;
    if (t->metallic_roughness) {
      RGB mr = lookup(*t->metallic_roughness, si).rgb;
      v.metallic *= mr.b;
      v.roughness *= mr.g;
    }
    if (t->transmission) v.transmission *= lookup(*t->transmission, si).rgb.r;
    if (t->specular) v.specular *= lookup(*t->specular, si).a;
    if (t->specular_color)
      v.specular_color = v.specular_color * lookup(*t->specular_color, si).rgb;
    if (t->anisotropy && v.anisotropy != 0) v.anisotropy *= lookup(*t->anisotropy, si).rgb.b;
    if (t->clearcoat && v.clearcoat != 0) v.clearcoat *= lookup(*t->clearcoat, si).rgb.r;
    if (t->clearcoat_roughness && v.clearcoat != 0)
      v.clearcoat_roughness *= lookup(*t->clearcoat_roughness, si).rgb.g;
    if (t->iridescence && v.iridescence != 0) v.iridescence *= lookup(*t->iridescence, si).rgb.r;
    if (t->iridescence_thickness && v.iridescence != 0) {
      Float g = lookup(*t->iridescence_thickness, si).rgb.g;
      v.iridescence_thickness = m.iridescence_thickness_min + (m.iridescence_thickness_max - m.iridescence_thickness_min) * g;
    }
    const bool sheen = v.sheen_color != RGB(0);
    if (t->sheen_color && sheen) v.sheen_color = v.sheen_color * lookup(*t->sheen_color, si).rgb;
    if (t->sheen_roughness && sheen)
      v.sheen_roughness *= lookup(*t->sheen_roughness, si).a;
  }
  return v;
}
// KHR_materials_anisotropy's direction at a hit, in the tangent-bitangent
// plane: (1, 0) or the texture's RG x 2 - 1, turned counter-clockwise by
// the rotation.
inline std::array<Float, 2> anisotropy_direction(const MetalRoughMaterial& m, const SurfaceInteraction& si) {
  Float dx = 1, dy = 0;
  if (m.textures && m.textures->anisotropy) {
    RGB t = lookup(*m.textures->anisotropy, si).rgb;
    dx = 2 * t.r - 1;
    dy = 2 * t.g - 1;
  }
  Float c = std::cos(m.anisotropy_rotation), s = std::sin(m.anisotropy_rotation);
  return {c * dx - s * dy, s * dx + c * dy};
}
// Coverage in [0, 1] at a hit (alphaMode): 1 when opaque, 0 or 1 for mask.
inline Float metal_rough_opacity(const MetalRoughMaterial& m, const SurfaceInteraction& si) {
  if (m.alpha_mode == AlphaMode::opaque) return 1;
  Float a = m.alpha * si.alpha;
  if (m.textures && m.textures->base_color) a *= lookup(*m.textures->base_color, si).a;
  if (m.alpha_mode == AlphaMode::mask) return a >= m.alpha_cutoff ? Float(1) : Float(0);
  return std::clamp(a, Float(0), Float(1));
}
// M: MetalRoughMaterial or MetalRoughFactors (the same field names).
template <class M>
MetalRoughParams clamp_metal_rough(const M& m, std::string* clamped = nullptr) {
  MetalRoughParams p;
  auto note = [&](const char* what, Float from, Float to) {
    if (!clamped || from == to || std::isnan(from)) return;
    std::ostringstream s;
    s << (clamped->empty() ? "" : ", ") << what << " " << from << " -> " << to;
    *clamped += s.str();
  };
  static const char* channel_names[3] = {"base_color.r", "base_color.g", "base_color.b"};
  static const char* spec_names[3] = {"specular_color.r", "specular_color.g", "specular_color.b"};
  static const char* sheen_names[3] = {"sheen_color.r", "sheen_color.g", "sheen_color.b"};
  for (int i = 0; i < 3; ++i) {
    p.base[i] = unit_or_zero(m.base_color[i]);
    note(channel_names[i], m.base_color[i], p.base[i]);
    p.sheen_color[i] = unit_or_zero(m.sheen_color[i]);
    note(sheen_names[i], m.sheen_color[i], p.sheen_color[i]);
  }
  // A parameter of [0, 1], clamped (NaN to 0) and noted.
  auto unit = [&](const char* what, Float from, Float& to) {
    to = unit_or_zero(from);
    note(what, from, to);
  };
  unit("metallic", m.metallic, p.metallic);
  unit("roughness", m.roughness, p.roughness);
  unit("specular", m.specular, p.specular);
  unit("transmission", m.transmission, p.transmission);
  unit("anisotropy", m.anisotropy, p.anisotropy);
  unit("clearcoat", m.clearcoat, p.clearcoat);
  unit("clearcoat_roughness", m.clearcoat_roughness, p.clearcoat_roughness);
  unit("iridescence", m.iridescence, p.iridescence);
  unit("sheen_roughness", m.sheen_roughness, p.sheen_roughness);
  p.iridescence_thickness = std::max(film_thickness(m), Float(0));
  Float f0 = MetalRoughMaterial::f0_from_ior(m.ior);
  for (int i = 0; i < 3; ++i) {
    Float sc = m.specular_color[i] > 0 && std::isfinite(m.specular_color[i]) ? m.specular_color[i] : Float(0);
    note(spec_names[i], m.specular_color[i], sc);
    p.dielectric_f0[i] = std::min(f0 * sc, Float(1));  // KHR_materials_specular clamps the product
  }
  return p;
}
}  // namespace detail

template <class S>
struct bxdf_traits<MetalRoughBxDF<S>> {
  static constexpr std::string_view name = "metal_rough";
  static constexpr BxDFFlags flags = BxDFFlags::specular_reflection | BxDFFlags::glossy_reflection |
                                     BxDFFlags::diffuse_reflection | BxDFFlags::specular_transmission |
                                     BxDFFlags::glossy_transmission;
  static constexpr BxDFHook hooks = BxDFHook::validate | BxDFHook::needs_spectral | BxDFHook::dispersive |
                                    BxDFHook::textured | BxDFHook::has_specular | BxDFHook::may_be_transparent |
                                    BxDFHook::opacity | BxDFHook::volume | BxDFHook::shading_frame;
  using material_type = MetalRoughMaterial;

  // Clamps (silently: validate warned when the scene was built), uplifts the
  // base colour and the dielectric F0 colour as reflectances, alpha =
  // roughness^2. F0max is the largest channel of the RGB F0, or of its
  // uplift at the path's wavelengths if larger (a smooth spectrum may peak
  // above its RGB channels): energy is conserved at every wavelength.
  // A refracting volume (is_volume()) gets the glass lobe with eta from
  // path_eta(volume_ior(), lambda): a dispersive one terminates the
  // secondary wavelengths when lambda is non-const, as DielectricMaterial does.
  template <class W>
  static MetalRoughBxDF<S> make(const MetalRoughMaterial& m, const SurfaceInteraction& si, W&& lambda) {
    // Untextured materials are clamped in place (no copy per hit).
    detail::MetalRoughParams p = (m.textures || si.color != RGB(1)) ? detail::clamp_metal_rough(detail::textured(m, si))
                                                                    : detail::clamp_metal_rough(m);
    S base = spectrum_traits<S>::albedo(p.base, lambda);
    S f0 = spectrum_traits<S>::albedo(p.dielectric_f0, lambda);
    Float f0_max = std::min(std::max(p.dielectric_f0.max_component(), f0.max_component()), Float(1));
    // KHR_materials_anisotropy: alpha_t = mix(alpha, 1, s^2) along the
    // shading frame's x (shading_frame() turns it to the direction).
    const Float alpha = sqr(p.roughness);
    TrowbridgeReitz distrib = p.anisotropy > 0 ? TrowbridgeReitz(alpha + (1 - alpha) * sqr(p.anisotropy), alpha)
                                               : TrowbridgeReitz(MicrofacetRoughness::from_perceptual(p.roughness));
    MetalRoughBxDF<S> b(distrib, base, f0, f0_max, p.specular, p.metallic, p.transmission);
    if (m.is_volume() && p.transmission > 0 && p.metallic < 1) b.make_refractive(path_eta(m.volume_ior(), lambda));
    if (m.multiple_scattering) b.enable_multiple_scattering();
    if (p.iridescence > 0 && p.iridescence_thickness > 0) {
      S n_metal{}, lam{};
      for (int i = 0; i < S::size; ++i) n_metal[i] = ior_from_f0(base[i]);
      if constexpr (spectrum_traits<S>::is_spectral)
        for (int i = 0; i < S::size; ++i) lam[i] = lambda[i];
      // ior 0 (F0 = 1): the film over a perfect mirror.
      b.set_iridescence(p.iridescence, m.iridescence_ior, p.iridescence_thickness, m.ior == 0 ? Float(1e4) : m.ior,
                        n_metal, lam);
    }
    if (p.sheen_color != RGB(0))
      b.set_sheen(spectrum_traits<S>::albedo(p.sheen_color, lambda), p.sheen_roughness);
    if (p.clearcoat > 0) b.set_clearcoat(p.clearcoat, TrowbridgeReitz(sqr(p.clearcoat_roughness), sqr(p.clearcoat_roughness)),
                                         clearcoat_normal(m, si));
    return b;
  }
  // The coat's normal in the local frame shading_frame() gives the BxDF:
  // (0, 0, 1) unless a normal map (the material's or the coat's) tells them
  // apart; the coat's own map, else the mesh's interpolated normal.
  static Vector3f clearcoat_normal(const MetalRoughMaterial& m, const SurfaceInteraction& si) {
    const bool base_mapped = m.textures && m.textures->normal;
    const bool coat_mapped = m.textures && m.textures->clearcoat_normal;
    if (!base_mapped && !coat_mapped) return Vector3f(0, 0, 1);
    Vector3f n(si.ns);
    if (coat_mapped) {
      const ImageTexture& nt = *m.textures->clearcoat_normal;
      bool has_tangent = length_squared(si.tangent) > 0;
      Vector3f t = has_tangent ? si.tangent : si.dpdu;
      Vector3f b = has_tangent ? cross(Vector3f(si.ns), si.tangent) * si.tangent_w : -si.dpdv;
      n = Vector3f(apply_normal_map(detail::lookup(nt, si).rgb, m.textures->clearcoat_normal_scale, t,
                                    b, si.ns));
    }
    Vector3f local = shading_frame(m, si).to_local(n);
    Float l = length(local);
    return l > 0 && std::isfinite(l) ? local / l : Vector3f(0, 0, 1);
  }

  // Throws prism::Error, prefixed by `where` and naming the material, on a
  // NaN or infinite parameter and on an ior below 1 other than 0. Prints one
  // warning line to std::cerr listing every parameter clamped into its
  // domain (base_color, metallic, roughness, specular, transmission outside
  // [0, 1], a negative specular_color channel).
  static void validate(const MetalRoughMaterial& m, std::string_view where) {
    auto fail = [&](const std::string& what) {
      throw Error(std::string(where) + ": material '" + m.name + "': " + what);
    };
    auto check_finite = [&](const char* what, Float v) {
      if (!std::isfinite(v)) {
        std::ostringstream s;
        s << what << " = " << v << " must be finite";
        fail(s.str());
      }
    };
    for (int i = 0; i < 3; ++i) check_finite("base_color", m.base_color[i]);
    check_finite("metallic", m.metallic);
    check_finite("roughness", m.roughness);
    check_finite("ior", m.ior);
    check_finite("specular", m.specular);
    for (int i = 0; i < 3; ++i) check_finite("specular_color", m.specular_color[i]);
    check_finite("transmission", m.transmission);
    check_finite("anisotropy", m.anisotropy);
    check_finite("anisotropy_rotation", m.anisotropy_rotation);
    check_finite("clearcoat", m.clearcoat);
    check_finite("clearcoat_roughness", m.clearcoat_roughness);
    check_finite("iridescence", m.iridescence);
    for (int i = 0; i < 3; ++i) check_finite("sheen_color", m.sheen_color[i]);
    check_finite("sheen_roughness", m.sheen_roughness);
    if (!(m.iridescence_ior >= 1) || !(m.iridescence_ior < infinity)) {
      std::ostringstream s;
      s << "iridescence_ior = " << m.iridescence_ior << " must be finite and >= 1";
      fail(s.str());
    }
    if (!(m.iridescence_thickness_min >= 0) || !(m.iridescence_thickness_max >= 0) ||
        !(m.iridescence_thickness_min < infinity) || !(m.iridescence_thickness_max < infinity)) {
      std::ostringstream s;
      s << "iridescence thickness [" << m.iridescence_thickness_min << ", " << m.iridescence_thickness_max
        << "] nm must be finite and >= 0";
      fail(s.str());
    }
    if (m.ior != 0 && !(m.ior >= 1)) {
      std::ostringstream s;
      s << "ior = " << m.ior << " must be >= 1 (or exactly 0 for F0 = 1, as in KHR_materials_ior)";
      fail(s.str());
    }
    if (!(m.thickness >= 0) || !(m.thickness < infinity)) {
      std::ostringstream s;
      s << "thickness = " << m.thickness << " must be finite and >= 0";
      fail(s.str());
    }
    if (!(m.dispersion >= 0) || !(m.dispersion < infinity)) {
      std::ostringstream s;
      s << "dispersion = " << m.dispersion << " must be finite and >= 0";
      fail(s.str());
    }
    if (m.is_volume()) {
      try {
        m.attenuation.validate(m.name);
        if (m.ior > 1) m.volume_ior().validate(m.name);
      } catch (const Error& e) {
        throw Error(std::string(where) + ": " + e.what());
      }
    }
    std::string clamped;
    detail::clamp_metal_rough(m, &clamped);
    if (!clamped.empty())
      std::cerr << "prism: warning: " << where << ": material '" << m.name << "': clamped " << clamped << "\n";
  }
  // Dispersion (a refracting volume with dispersion > 0) cannot be rendered in RGB.
  static bool needs_spectral(const MetalRoughMaterial& m) { return m.is_volume() && m.volume_ior().is_dispersive() && m.ior > 1; }
  // A refracting volume whose ior varies with the wavelength (KHR_materials_dispersion).
  static bool dispersive(const MetalRoughMaterial& m) { return m.is_volume() && m.volume_ior().is_dispersive(); }
  // Texture maps read at every hit.
  static bool textured(const MetalRoughMaterial& m) { return m.textures != nullptr; }
  // The absorbing interior of a refracting volume, if it absorbs.
  static const VolumeAbsorption* volume(const MetalRoughMaterial& m) {
    return m.is_volume() && m.attenuation.active() ? &m.attenuation : nullptr;
  }

  // Normal mapping: the shading normal from normalTexture, in the tangent
  // frame of the mesh's TANGENT (with its handedness) or, without one, of the
  // uv derivatives (bitangent towards decreasing v: glTF's +Y is up in the
  // image, and v runs down). An anisotropic material (anisotropy > 0) gets
  // the frame's x along its direction in that same tangent frame.
  static Frame shading_frame(const MetalRoughMaterial& m, const SurfaceInteraction& si) {
    const bool mapped_normal = m.textures && m.textures->normal;
    if (!mapped_normal && !(m.anisotropy > 0)) return si.shading_frame();
    bool has_tangent = length_squared(si.tangent) > 0;
    Vector3f t = has_tangent ? si.tangent : si.dpdu;
    Vector3f b = has_tangent ? cross(Vector3f(si.ns), si.tangent) * si.tangent_w : -si.dpdv;
    SurfaceInteraction mapped = si;
    if (mapped_normal) {
      const ImageTexture& nt = *m.textures->normal;
      RGB texel = detail::lookup(nt, si).rgb;
      mapped.ns = apply_normal_map(texel, m.textures->normal_scale, t, b, si.ns);
    }
    mapped.dpdu = t;
    if (m.anisotropy > 0) {
      // dpdu is only a direction for shading_frame(), which projects it
      // onto the tangent plane of ns and falls back if it degenerates.
      auto d = detail::anisotropy_direction(m, si);
      Float lt = length(t), lb = length(b);
      if (lt > 0 && lb > 0 && std::isfinite(lt) && std::isfinite(lb)) mapped.dpdu = t * (d[0] / lt) + b * (d[1] / lb);
    }
    return mapped.shading_frame();
  }
  // alphaMode coverage at a hit; Scene::intersect passes through surfaces
  // that are not there (see may_be_transparent).
  static Float opacity(const MetalRoughMaterial& m, const SurfaceInteraction& si) {
    return detail::metal_rough_opacity(m, si);
  }
  static bool may_be_transparent(const MetalRoughMaterial& m) { return m.alpha_mode != AlphaMode::opaque; }
  // Delta lobes: a smooth surface (roughness^2 below the threshold) that
  // reflects or transmits anything specularly.
  static bool has_specular(const MetalRoughMaterial& m) {
    // A roughness texture may make texels smooth: conservatively yes.
    if (m.textures && m.textures->metallic_roughness && m.roughness > 0) return true;
    detail::MetalRoughParams p = detail::clamp_metal_rough(m);
    // A smooth clear coat (KHR_materials_clearcoat's default roughness 0).
    if (p.clearcoat > 0 && ((m.textures && m.textures->clearcoat_roughness) ||
                            TrowbridgeReitz(sqr(p.clearcoat_roughness), sqr(p.clearcoat_roughness)).effectively_smooth()))
      return true;
    // A volume of ior 1 passes light straight through, whatever the roughness.
    if (m.is_volume() && m.ior == 1 && p.transmission > 0 && p.metallic < 1) return true;
    if (!TrowbridgeReitz(MicrofacetRoughness::from_perceptual(p.roughness)).effectively_smooth()) return false;
    return p.metallic > 0 || p.specular > 0 || p.transmission > 0;
  }
};

}  // namespace prism
