// The glTF metallic-roughness BxDF (bxdfs/metal_rough.hpp): sampling against
// pdf (chi-squared on hemispheres and on windows fitted to narrow lobes,
// including the lobe probabilities through the mass outside each window),
// the white furnace (<= 1; exactly 1 where the model is lossless), eval
// against an independent transcription of the model, reciprocity of
// reflection and thin transmission, sample/eval/pdf agreement, the exact
// specular path, finiteness at grazing angles, and the material's
// validation (clamps with one warning, throws where no clamp makes sense).
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>
#include <prism/bxdfs/bsdf.hpp>
#include <prism/bxdfs/metal_rough.hpp>
#include <prism/render/scene.hpp>
#include <prism/spectra/traits.hpp>
#include "bxdfs/bxdf_check.hpp"
#include "support/reference_physics.hpp"

namespace metal_rough_test {

using namespace prism;
using namespace bxdf_check;

namespace {
using S4 = SampledSpectrum<4>;
using W4 = SampledWavelengths<4>;
static_assert(BxDFLike<MetalRoughBxDF<RGB>, RGB>);
static_assert(BxDFLike<MetalRoughBxDF<S4>, S4>);

const Float test_roughness[] = {0.001f, 0.05f, 0.3f, 1.0f};
const double test_angles[] = {0.0, 45.0, 80.0, 89.9};
const Float test_metallic[] = {0.f, 0.5f, 1.f};

W4 fixed_wavelengths() { return W4::from({430, 520, 610, 680}, {1 / 470.f, 1 / 470.f, 1 / 470.f, 1 / 470.f}); }

MetalRoughMaterial material(Float roughness, Float metallic, Float transmission = 0,
                            RGB base = RGB(0.9f, 0.6f, 0.3f)) {
  MetalRoughMaterial m;
  m.base_color = base;
  m.metallic = metallic;
  m.roughness = roughness;
  m.transmission = transmission;
  m.name = "test";
  return m;
}

template <class S>
MetalRoughBxDF<S> make_bxdf(const MetalRoughMaterial& m) {
  SurfaceInteraction si;
  if constexpr (std::is_same_v<S, RGB>)
    return bxdf_traits<MetalRoughBxDF<S>>::make(m, si, RGBWavelengths{});
  else
    return bxdf_traits<MetalRoughBxDF<S>>::make(m, si, fixed_wavelengths());
}

// The thin transmission lobe is the reflection lobe mirrored through the surface.
Vector3f flip_z(Vector3f v) { return {v.x, v.y, -v.z}; }

// ---- chi-squared --------------------------------------------------------
struct Chi2Run {
  std::string label;
  prism_test::Chi2Result result;
};
// One lobe's sample count against its probability (binomial: mean n p, sd
// sqrt(n p (1 - p))), checked after the sweep with the chi-squared runs as one
// family (check_lobe_counts). Failed samples (a rough reflection below the
// horizon) only lower a rough lobe's count, so only a smooth BxDF's lobes and
// the diffuse lobe are bounded from below.
struct LobeCount {
  std::string label;
  int lobe;
  double count, mean, sd;
  bool two_sided;
};
void check_lobe_counts(const std::vector<LobeCount>& lobes, double z) {
  for (const auto& c : lobes) {
    INFO(c.label << " lobe " << c.lobe << ": " << c.count << " samples, expected " << c.mean << " +- " << c.sd
                 << ", z " << z);
    CHECK(c.count <= c.mean + z * c.sd + 1);
    if (c.two_sided) CHECK(c.count >= c.mean - z * c.sd - 1);
  }
}

// The windows for one BxDF and wo: for a narrow rough lobe (alpha < 0.2)
// windows fitted to the reflection and (if any) transmission lobes, where a
// whole-hemisphere grid would put the lobe in one cell; otherwise the whole
// front hemisphere and (if it transmits) the back one. Smooth: the front
// hemisphere holds the diffuse lobe, and the delta samples (passed as
// failures) must match the pdf's missing mass. Samples outside a window go
// to the extra cell, whose expected count is n (1 - the pdf's mass in the
// window): that checks the lobe probabilities as well.
template <class S>
void chi2_config(const MetalRoughBxDF<S>& bxdf, const Vector3f& wo, Float alpha, const std::string& label,
                 PCG32& rng, std::vector<Chi2Run>& runs, std::vector<LobeCount>& lobes, Float alpha_x = -1,
                 bool count_lobes = true) {
  if (alpha_x < 0) alpha_x = alpha;  // anisotropic: alpha_x along x, alpha along y
  auto sample = [&]() -> std::optional<Vector3f> {
    auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    if (!bs || bs->is_specular()) return std::nullopt;
    return bs->wi;
  };
  auto pdf = [&](const Vector3f& wi) { return bxdf.pdf(wo, wi, TransportMode::radiance); };
  const int side = wo.z > 0 ? 1 : -1;
  const bool transmits = any(bxdf.flags() & BxDFFlags::transmission);
  const auto p = bxdf.lobe_probabilities(std::abs(wo.z));
  struct W {
    const char* name;
    Window w;
    double share;
  };
  std::vector<W> windows;
  if (bxdf.is_smooth() || std::min(alpha, alpha_x) >= 0.2f) {
    windows.push_back({"front", hemisphere_window(side), 1});
    if (transmits && !bxdf.is_smooth()) windows.push_back({"back", hemisphere_window(-side), 1});
  } else {
    auto reflected = [&](const Vector3f& m) -> std::optional<Vector3f> {
      Vector3f wi = reflect(wo, m);
      return same_hemisphere(wo, wi) ? std::optional<Vector3f>(wi) : std::nullopt;
    };
    auto transmitted = [&](const Vector3f& m) -> std::optional<Vector3f> {
      Vector3f wi = reflect(wo, m);
      return same_hemisphere(wo, wi) ? std::optional<Vector3f>(flip_z(wi)) : std::nullopt;
    };
    windows.push_back(
        {"reflection", lobe_window(reflected, Vector3f(-wo.x, -wo.y, wo.z), alpha_x, alpha), p.reflection});
    if (transmits) windows.push_back({"transmission", lobe_window(transmitted, -wo, alpha_x, alpha), p.transmission});
  }
  // Lobe choice: the frequency of each lobe's samples against its probability
  // (binomial; one comparison per lobe, checked by the caller with the
  // chi-squared runs, check_lobe_counts). chi-squared over hundreds of cells
  // has little power against a few percent of mass moved between lobes; this has.
  if (count_lobes) {  // a coat (clearcoat) adds a lobe lobe_probabilities does not know
    const int n = 20000;
    int count[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i) {
      auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
      if (!bs) continue;  // a rough lobe sent below the surface: counted against its lobe's expectation
      count[any(bs->flags & BxDFFlags::diffuse) ? 1 : (bs->is_transmission() ? 2 : 0)] += 1;
    }
    const double pr[3] = {p.reflection, p.diffuse, p.transmission};
    for (int l = 0; l < 3; ++l) {
      double mean = n * pr[l], sd = std::sqrt(n * pr[l] * (1 - pr[l]));
      lobes.push_back({label, l, double(count[l]), mean, sd, bxdf.is_smooth() || l == 1});
    }
  }
  for (const auto& w : windows) {
    size_t n = size_t(std::min(150000.0, 25000 / std::max(w.share, 0.15)));
    auto r = chi2_window(sample, pdf, w.w, Chi2Config{n, 20, 20});
    runs.push_back({label + " " + w.name, r});
    if (std::getenv("PRISM_CHI2_VERBOSE")) std::printf("%s %s: %s\n", label.c_str(), w.name, r.summary().c_str());
  }
}

template <class S>
void chi2_sweep(PCG32& rng, std::vector<Chi2Run>& runs, std::vector<LobeCount>& lobes) {
  for (Float r : test_roughness)
    for (Float m : test_metallic)
      for (Float t : {0.f, 0.5f})
        for (double side : {1.0, -1.0}) {
          if (side < 0 && r != 0.3f) continue;  // the back side: one roughness suffices (it mirrors the front)
          auto bxdf = make_bxdf<S>(material(r, m, t));
          const Float alpha = r * r;
          for (double theta : test_angles) {
            std::ostringstream label;
            label << (is_spectral_v<S> ? "spectral" : "RGB") << " roughness " << r << " metallic " << m
                  << " transmission " << t << " theta " << theta << " side " << side;
            chi2_config(bxdf, direction_at(theta, 0.7, side), alpha, label.str(), rng, runs, lobes);
          }
        }
  // KHR_materials_anisotropy 0.7 (alpha_x = alpha + (1 - alpha) 0.49): a
  // narrow and a wide lobe, the layer alone, over a base and thin
  // transmission, and the metal.
  for (Float r : {0.05f, 0.3f})
    for (Float m : {0.f, 1.f})
      for (Float t : {0.f, 0.5f}) {
        if (m == 1 && t > 0) continue;
        MetalRoughMaterial mat = material(r, m, t);
        mat.anisotropy = 0.7f;
        auto bxdf = make_bxdf<S>(mat);
        const Float alpha = r * r, alpha_x = alpha + (1 - alpha) * 0.49f;
        for (double theta : test_angles) {
          std::ostringstream label;
          label << (is_spectral_v<S> ? "spectral" : "RGB") << " anisotropy 0.7 roughness " << r << " metallic " << m
                << " transmission " << t << " theta " << theta;
          chi2_config(bxdf, direction_at(theta, 0.7), alpha, label.str(), rng, runs, lobes, alpha_x);
        }
      }
  // KHR_materials_clearcoat: a smooth coat (its delta samples must match
  // the pdf's missing mass) and a rough one (alpha 0.36), weights 1 and 0.5,
  // over rough bases (alpha 0.36: whole hemispheres); and a coat whose
  // normal leans 17 degrees from the base's (a clearcoat normal map).
  for (Float coat_r : {0.f, 0.6f})
    for (Float c : {1.f, 0.5f})
      for (Float m : {0.f, 1.f})
        for (Float t : {0.f, 0.5f})
          for (int tilted = 0; tilted < 2; ++tilted) {
            if ((m == 1 && t > 0) || (tilted && (c < 1 || t > 0))) continue;
            MetalRoughMaterial mat = material(0.6f, m, t);
            mat.clearcoat = c;
            mat.clearcoat_roughness = coat_r;
            auto bxdf = make_bxdf<S>(mat);
            if (tilted)
              bxdf.set_clearcoat(c, TrowbridgeReitz(coat_r * coat_r, coat_r * coat_r),
                                 normalize(Vector3f(0.3f, 0.1f, 1)));
            for (double theta : test_angles) {
              std::ostringstream label;
              label << (is_spectral_v<S> ? "spectral" : "RGB") << " clearcoat " << c << " coat roughness " << coat_r
                    << (tilted ? " tilted" : "") << " metallic " << m << " transmission " << t << " theta " << theta;
              chi2_config(bxdf, direction_at(theta, 0.7), 0.36f, label.str(), rng, runs, lobes, -1, false);
            }
          }
  // KHR_materials_sheen: a sharp (0.05, where the lobe hugs the horizon and
  // its albedo exceeds 1) and a soft sheen over a rough base, a metal and a
  // thin slab, and under a smooth coat; whole hemispheres.
  for (Float sheen_r : {0.05f, 0.7f})
    for (Float m : {0.f, 1.f})
      for (Float t : {0.f, 0.5f})
        for (int coated = 0; coated < 2; ++coated) {
          if ((m == 1 && t > 0) || (coated && (m > 0 || t > 0))) continue;
          MetalRoughMaterial mat = material(0.6f, m, t);
          mat.sheen_color = RGB(0.9f, 0.5f, 0.2f);
          mat.sheen_roughness = sheen_r;
          mat.clearcoat = coated ? 1.f : 0.f;
          auto bxdf = make_bxdf<S>(mat);
          for (double theta : test_angles) {
            std::ostringstream label;
            label << (is_spectral_v<S> ? "spectral" : "RGB") << " sheen roughness " << sheen_r << (coated ? " coated" : "")
                  << " metallic " << m << " transmission " << t << " theta " << theta;
            chi2_config(bxdf, direction_at(theta, 0.7), 0.36f, label.str(), rng, runs, lobes, -1, false);
          }
        }
}

// ---- an independent transcription of the model, in double -----------------
// From the formulas in metal_rough.hpp's header comment, with D, G2, G1 and
// the VNDF pdf from tests/support/reference_physics.hpp (Walter 2007, Heitz
// 2014, 2018): nothing is borrowed from the code under test.
struct Reference {
  MetalRoughMaterial m;
  // glTF: alpha = roughness^2; KHR_materials_anisotropy: along the
  // anisotropy direction (the frame's x here) alpha_t = mix(alpha, 1, s^2).
  double alpha_x() const {
    double a = double(m.roughness) * m.roughness, s = std::clamp(double(m.anisotropy), 0.0, 1.0);
    return a + (1 - a) * s * s;
  }
  double alpha_y() const { return double(m.roughness) * m.roughness; }
  // KHR_materials_clearcoat as metal_rough.hpp states it, the coat's normal
  // the base's: c F_s(wo.h) D G / (4 cos_o cos_i) with Schlick's F_s of F0 =
  // 0.04 (ior 1.5) and alpha_c = clearcoat_roughness^2, over the material
  // weighted by (1 - c F_s(mu_o)) (1 - c F_s(mu_i)).
  double coat_alpha() const { return double(m.clearcoat_roughness) * m.clearcoat_roughness; }
  double coat_through(double mu) const { return 1 - m.clearcoat * reference_physics::fresnel_schlick(0.04, mu); }
  double coat_f(const Vector3f& wo_in, const Vector3f& wi_in) const {
    namespace rp = reference_physics;
    if (coat_alpha() == 0) return 0;  // a smooth coat: a delta, no f between two directions
    double sign = wo_in.z < 0 ? -1 : 1;
    rp::Dir o{wo_in.x, wo_in.y, sign * wo_in.z}, i{wi_in.x, wi_in.y, sign * wi_in.z};
    return m.clearcoat * rp::torrance_sparrow(coat_alpha(), coat_alpha(), o, i,
                                              [](double c) { return rp::fresnel_schlick(0.04, c); });
  }
  double coated_eval(const Vector3f& wo, const Vector3f& wi, int ch) const {
    return coat_through(std::abs(wo.z)) * coat_through(std::abs(wi.z)) * eval(wo, wi, ch) + coat_f(wo, wi);
  }
  double eval(const Vector3f& wo_in, const Vector3f& wi_in, int ch) const {
    Vector3f wo = wo_in, wi = wi_in;
    if (wo.z < 0) {
      wo = flip_z(wo);
      wi = flip_z(wi);
    }
    double base = std::clamp(double(m.base_color[ch]), 0.0, 1.0);
    double f0_ior = m.ior == 0 ? 1.0 : std::pow((m.ior - 1.0) / (m.ior + 1.0), 2);
    double f0 = std::min(f0_ior * m.specular_color[ch], 1.0);
    double f0_max = std::min(f0_ior * double(m.specular_color.max_component()), 1.0);
    double w = m.specular, metal = m.metallic, T = m.transmission;
    auto s = [](double c) { return std::pow(1 - c, 5); };
    auto B = [&](double c) { return 1 - w * (f0_max + (1 - f0_max) * s(c)); };
    const double ax = alpha_x(), ay = alpha_y();
    auto lobe = [&](const Vector3f& a, const Vector3f& b, double& c) {
      namespace rp = reference_physics;
      rp::Dir x{a.x, a.y, a.z}, y{b.x, b.y, b.z};
      rp::Dir h = rp::normalized({x.x + y.x, x.y + y.y, x.z + y.z});
      c = rp::dot(x, h);
      return rp::ggx_D(ax, ay, h) * rp::smith_G2(ax, ay, x, y) / (4.0 * x.z * y.z);
    };
    double f = 0;
    if (wi.z > 0) {
      f += (1 - metal) * (1 - T) * base / pi_d * B(wo.z) * B(wi.z);
      double c;
      double dg = lobe(wo, wi, c);
      f += dg * ((1 - metal) * w * (f0 + (1 - f0) * s(c)) + metal * (base + (1 - base) * s(c)));
    } else {
      double c;
      double dg = lobe(wo, flip_z(wi), c);
      f += (1 - metal) * T * base * B(c) * dg;
    }
    return f;
  }
  // The mixture density for lobe probabilities p (the BxDF's own: any
  // positive estimate is valid, but sample() and pdf() must use the same):
  // cosine-weighted diffuse, and the visible-normal density G1(wo) D / (4 cos_o)
  // for the reflection and the mirrored transmission.
  template <class L>
  double pdf(const Vector3f& wo_in, const Vector3f& wi_in, const L& p) const {
    Vector3f wo = wo_in, wi = wi_in;
    if (wo.z < 0) {
      wo = flip_z(wo);
      wi = flip_z(wi);
    }
    namespace rp = reference_physics;
    const rp::Dir o{wo.x, wo.y, wo.z};
    auto vndf = [&](const Vector3f& b) {
      rp::Dir h = rp::normalized({o.x + b.x, o.y + b.y, o.z + b.z});
      return rp::ggx_vndf(alpha_x(), alpha_y(), o, h) / (4.0 * rp::dot(o, h));
    };
    if (wi.z > 0) return p.diffuse * wi.z / pi_d + p.reflection * vndf(wi);
    return p.transmission * vndf(flip_z(wi));
  }
};

// Directional albedo per channel (f |cos| / pdf over the BxDF's samples).
template <class S>
std::array<Albedo, S::size> albedo_all(const MetalRoughBxDF<S>& b, const Vector3f& wo, size_t n, PCG32& rng) {
  std::array<double, S::size> s{}, s2{};
  for (size_t i = 0; i < n; ++i) {
    auto bs = b.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    if (!bs || !(bs->pdf > 0)) continue;
    for (int c = 0; c < S::size; ++c) {
      double v = double(bs->f[c]) * abs_cos_theta(bs->wi) / bs->pdf;
      s[size_t(c)] += v;
      s2[size_t(c)] += v * v;
    }
  }
  std::array<Albedo, S::size> out;
  for (size_t c = 0; c < size_t(S::size); ++c) {
    double mean = s[c] / double(n), var = std::max(0.0, s2[c] / double(n) - mean * mean) / double(n - 1);
    out[c] = {mean, std::sqrt(var)};
  }
  return out;
}

// Redirects std::cerr while alive.
struct CerrCapture {
  std::ostringstream text;
  std::streambuf* old;
  CerrCapture() : old(std::cerr.rdbuf(text.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old); }
  int lines() const {
    std::string s = text.str();
    return int(std::count(s.begin(), s.end(), '\n'));
  }
};
}  // namespace

TEST_CASE("metal-rough sample matches pdf by chi-squared over roughness, metallic, transmission, RGB and spectral", "[bxdfs][metal_rough][chi2]") {
  PCG32 rng(2024, 5);
  std::vector<Chi2Run> runs;
  std::vector<LobeCount> lobes;
  chi2_sweep<RGB>(rng, runs, lobes);
  chi2_sweep<S4>(rng, runs, lobes);
  // One family at 10^-3: every chi-squared run and every lobe count (720:
  // 3 lobes x 240 configurations), m = runs + lobe counts (Sidak).
  const int m = int(runs.size() + lobes.size());
  const double level = prism_test::sidak_alpha(1e-3, m);
  check_lobe_counts(lobes, reference_physics::sidak_z(1e-3, m));
  double min_p = 1, max_p = 0;
  for (const auto& r : runs) {
    INFO(r.label << ": " << r.result.summary());
    CHECK(r.result.p_value >= level);
    min_p = std::min(min_p, r.result.p_value);
    max_p = std::max(max_p, r.result.p_value);
  }
  CHECK(runs.size() > 300);
  WARN("metal-rough chi2: " << runs.size() << " tests, p in [" << min_p << ", " << max_p << "], level " << level);
}

TEST_CASE("metal-rough white furnace is at most 1, and exactly 1 where the model is lossless", "[bxdfs][metal_rough][furnace]") {
  PCG32 rng(77, 9);
  struct Variant {
    const char* name;
    Float ior, specular;
    RGB specular_color;
  };
  const Variant variants[] = {{"default", 1.5f, 1, RGB(1)},
                              {"ior 1 (F0 = 0)", 1.0f, 1, RGB(1)},
                              {"ior 0 (F0 = 1)", 0.0f, 1, RGB(1)},
                              {"coloured specular", 1.5f, 0.5f, RGB(3, 1, 0.2f)},
                              {"ior 2.4, specular colour 10", 2.4f, 1, RGB(10)}};
  double worst = 0, worst_z = -1e9;
  std::string worst_at;
  int checked = 0;
  // One family at 10^-3 over the test case's m = 1932 comparisons (Sidak,
  // z = sidak_z(1e-3, 1932) = 5.02): 60 white metals against the quadrature
  // (5 variants x 3 roughnesses > 0 x 4 angles; the channels are one
  // estimate), 1680 RGB bounds (5 variants x 4 roughnesses x 7
  // metallic/transmission pairs x 4 angles x 3 channels) and 192 spectral
  // bounds (3 x 2 x 2 x 4 angles x 4 wavelengths).
  const double z_max = reference_physics::sidak_z(1e-3, 60 + 1680 + 192);
  for (const auto& v : variants)
    for (Float r : {0.f, 0.05f, 0.3f, 1.f})
      for (Float m : {0.f, 0.5f, 1.f})
        for (Float t : {0.f, 0.5f, 1.f}) {
          if (m == 1 && t > 0) continue;  // a metal ignores transmission
          MetalRoughMaterial mat = material(r, m, t, RGB(1));
          mat.ior = v.ior;
          mat.specular = v.specular;
          mat.specular_color = v.specular_color;
          auto b = make_bxdf<RGB>(mat);
          for (double theta : test_angles) {
            auto a = albedo_all(b, direction_at(theta), 20000, rng);
            // A white metal is the F = 1 conductor at alpha = roughness^2:
            // two-sided against its quadrature (quadrature error < 5e-5;
            // sigma: reference_physics::bounded_sigma, for samples in [0, 1]),
            // within z_max of the whole test case.
            if (m == 1 && r > 0) {
              double want = reference_physics::conductor_albedo(std::acos(double(direction_at(theta).z)),
                                                                double(r) * r, 128, 16);
              INFO(v.name << " white metal, roughness " << r << " theta " << theta << ": " << a[0].mean << " +- "
                          << a[0].sigma << " vs " << want);
              CHECK(std::abs(a[0].mean - want) <= z_max * reference_physics::bounded_sigma(want, 20000) + 5e-5);
            }
            for (int c = 0; c < 3; ++c) {
              INFO(v.name << " roughness " << r << " metallic " << m << " transmission " << t << " theta " << theta
                          << " channel " << c << ": " << a[size_t(c)].mean << " +- " << a[size_t(c)].sigma);
              // +1e-6: float rounding of weights ≤ 1 (~10 roundings: 6e-7)
              CHECK(a[size_t(c)].mean <= 1 + z_max * a[size_t(c)].sigma + 1e-6);
              ++checked;
              double z = a[size_t(c)].sigma > 0 ? (a[size_t(c)].mean - 1 - 1e-6) / a[size_t(c)].sigma : -1e9;
              if (a[size_t(c)].mean > worst) {
                worst = a[size_t(c)].mean;
                std::ostringstream s;
                s << v.name << " roughness " << r << " metallic " << m << " transmission " << t << " theta " << theta;
                worst_at = s.str();
              }
              worst_z = std::max(worst_z, z);
            }
          }
        }
  // Spectral: the same bound per wavelength, for a coloured base and F0.
  for (Float r : {0.f, 0.3f, 1.f})
    for (Float m : {0.f, 0.5f})
      for (Float t : {0.f, 0.5f}) {
        MetalRoughMaterial mat = material(r, m, t, RGB(1, 0.9f, 0.2f));
        mat.specular_color = RGB(2, 0.5f, 1);
        auto b = make_bxdf<S4>(mat);
        for (double theta : test_angles) {
          auto a = albedo_all(b, direction_at(theta), 20000, rng);
          for (int c = 0; c < 4; ++c) {
            INFO("spectral roughness " << r << " metallic " << m << " transmission " << t << " theta " << theta
                                       << " wavelength " << c << ": " << a[size_t(c)].mean);
            // +1e-6: float rounding of weights ≤ 1, as above
            CHECK(a[size_t(c)].mean <= 1 + z_max * a[size_t(c)].sigma + 1e-6);
          }
        }
      }
  WARN("metal-rough furnace: " << checked << " RGB estimates, largest albedo " << worst << " (" << worst_at
                               << "), largest (albedo - 1) / sigma " << worst_z);
  // Lossless cases, where every sample weighs exactly 1: a white Lambertian
  // base without a layer (specular 0), a white smooth metal (F = 1), and a
  // white smooth thin slab (the layer reflects F, the slab transmits 1 - F).
  for (double theta : test_angles) {
    MetalRoughMaterial lambert = material(0.3f, 0, 0, RGB(1));
    lambert.specular = 0;
    MetalRoughMaterial mirror = material(0, 1, 0, RGB(1));
    MetalRoughMaterial slab = material(0, 0, 1, RGB(1));
    for (const auto& mat : {lambert, mirror, slab}) {
      auto a = albedo_all(make_bxdf<RGB>(mat), direction_at(theta), 2000, rng);
      INFO("lossless: metallic " << mat.metallic << " transmission " << mat.transmission << " theta " << theta);
      for (int c = 0; c < 3; ++c) CHECK(a[size_t(c)].mean == Approx(1).margin(1e-5));  // 1e-5: each weight is 1 up to ~10 float roundings (6e-7)
    }
  }
}

TEST_CASE("metal-rough eval and pdf match an independent transcription of the glTF model with its extensions", "[bxdfs][metal_rough][model]") {
  PCG32 rng(5, 17);
  std::vector<MetalRoughMaterial> mats;
  for (Float r : {0.05f, 0.3f, 1.f})
    for (Float m : {0.f, 0.3f, 1.f})
      for (Float t : {0.f, 0.6f}) {
        MetalRoughMaterial a = material(r, m, t);
        mats.push_back(a);
        a.ior = 1.33f;
        a.specular = 0.7f;
        a.specular_color = RGB(1.5f, 0.4f, 2);
        mats.push_back(a);
        a.ior = 0;
        mats.push_back(a);
      }
  // KHR_materials_anisotropy: the lobe stretched along the frame's x.
  for (Float r : {0.05f, 0.3f, 1.f})
    for (Float aniso : {0.4f, 1.f}) {
      MetalRoughMaterial a = material(r, 0.3f, 0.6f);
      a.anisotropy = aniso;
      mats.push_back(a);
    }
  int compared = 0;
  for (const auto& mat : mats) {
    auto b = make_bxdf<RGB>(mat);
    Reference ref{mat};
    for (int i = 0; i < 200; ++i) {
      Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      if (std::abs(wo.z) < 1e-3f || std::abs(wi.z) < 1e-3f) continue;
      RGB f = b.eval(wo, wi, TransportMode::radiance);
      {
        // 2e-4 relative = tests/reference's bsdf_tol at the smallest α = 0.05²: float_tol + 8u/α = 1.95e-4; 1e-6 absolute where f vanishes
        INFO("pdf: roughness " << mat.roughness << " metallic " << mat.metallic << " transmission "
                               << mat.transmission << " ior " << mat.ior << " anisotropy " << mat.anisotropy
                               << " wo.z " << wo.z << " wi.z " << wi.z);
        CHECK(b.pdf(wo, wi, TransportMode::radiance) ==
              Approx(ref.pdf(wo, wi, b.lobe_probabilities(std::abs(wo.z)))).epsilon(2e-4).margin(1e-6));
      }
      for (int c = 0; c < 3; ++c) {
        double expected = ref.eval(wo, wi, c);
        INFO("roughness " << mat.roughness << " metallic " << mat.metallic << " transmission " << mat.transmission
                          << " ior " << mat.ior << " anisotropy " << mat.anisotropy << " channel " << c << " wo.z "
                          << wo.z << " wi.z " << wi.z);
        CHECK(f[c] == Approx(expected).epsilon(2e-4).margin(1e-6));
        ++compared;
      }
      CHECK(b.eval(wo, wi, TransportMode::importance) == f);  // no eta: thin, and reflection
    }
  }
  CHECK(compared > 10000);
  // Special cases of the spec: metallic 0, specular 0 is Lambert; ior 0 with
  // specular colour 1 is a white mirror layer (F = 1) that leaves nothing to
  // the base.
  MetalRoughMaterial lambert = material(0.5f, 0, 0, RGB(0.2f, 0.5f, 0.8f));
  lambert.specular = 0;
  RGB f = make_bxdf<RGB>(lambert).eval(direction_at(30), direction_at(60, 2.5), TransportMode::radiance);
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, float ρ/π
  CHECK(f.r == Approx(0.2 / pi_d));
  CHECK(f.b == Approx(0.8 / pi_d));
  MetalRoughMaterial full = material(0, 0, 0.5f, RGB(0.5f));
  full.ior = 0;
  auto b = make_bxdf<RGB>(full);
  CHECK(b.base_weight(0.3f) == 0);
  CHECK(b.flags() == BxDFFlags::specular_reflection);
  CHECK(b.specular_fresnel(0.3f) == RGB(1));
}

TEST_CASE("metal-rough reflection and thin transmission are reciprocal, sample agrees with eval and pdf", "[bxdfs][metal_rough][reciprocity]") {
  PCG32 rng(31, 41);
  for (Float r : {0.05f, 0.3f, 1.f})
    for (Float m : {0.f, 0.5f})
      for (Float t : {0.f, 0.5f}) {
        auto b = make_bxdf<S4>(material(r, m, t));
        int transmissions = 0, reflections = 0, diffuse = 0;
        for (int i = 0; i < 300; ++i) {
          Vector3f x = sample_uniform_sphere({rng.next_float(), rng.next_float()});
          Vector3f y = sample_uniform_sphere({rng.next_float(), rng.next_float()});
          INFO("roughness " << r << " metallic " << m << " transmission " << t << " x " << x.x << " " << x.y << " "
                            << x.z << " y " << y.x << " " << y.y << " " << y.z);
          S4 fxy = b.eval(x, y, TransportMode::radiance), fyx = b.eval(y, x, TransportMode::radiance);
          // 1e-4 relative: both orders share the float half vector (x + y = y + x); they differ by a few u in wo·h vs wi·h times Fresnel's conditioning, ≪ 1e-4
          for (int c = 0; c < 4; ++c) CHECK(fxy[c] == Approx(fyx[c]).epsilon(1e-4).margin(1e-30));
          CHECK(b.eval(x, y, TransportMode::importance) == fxy);
          auto bs = b.sample(x, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
          if (!bs) continue;
          CHECK_FALSE(bs->is_specular());
          CHECK(bs->eta == 1);
          CHECK(bs->f == b.eval(x, bs->wi, TransportMode::radiance));
          CHECK(bs->pdf == b.pdf(x, bs->wi, TransportMode::radiance));
          if (bs->is_transmission()) {
            ++transmissions;
            CHECK(bs->wi.z * x.z < 0);
            CHECK(bs->flags == BxDFFlags::glossy_transmission);
          } else {
            CHECK(bs->wi.z * x.z > 0);
            if (bs->flags == BxDFFlags::diffuse_reflection)
              ++diffuse;
            else {
              CHECK(bs->flags == BxDFFlags::glossy_reflection);
              ++reflections;
            }
          }
        }
        CHECK(reflections > 0);
        CHECK((diffuse > 0) == (m < 1));
        CHECK((transmissions > 0) == (t > 0));
      }
}

TEST_CASE("metal-rough takes the exact specular path at roughness 0 and 1e-4, none below the threshold is rough", "[bxdfs][metal_rough][smooth]") {
  PCG32 rng(3, 3);
  for (Float r : {0.f, 1e-4f, 0.001f, 0.01f}) {
    auto b = make_bxdf<RGB>(material(r, 0.5f, 0.5f));
    INFO("roughness " << r);
    CHECK(b.is_smooth());
    CHECK(b.flags() == (BxDFFlags::specular_reflection | BxDFFlags::diffuse_reflection |
                        BxDFFlags::specular_transmission));
    CHECK(bxdf_traits<MetalRoughBxDF<RGB>>::has_specular(material(r, 0.5f, 0.5f)));
    for (double theta : {0.0, 30.0, 60.0, 85.0}) {
      Vector3f wo = direction_at(theta);
      auto p = b.lobe_probabilities(wo.z);
      // A reflection sample (uc in the first lobe), a diffuse one, a transmission.
      auto refl = b.sample(wo, p.reflection / 2, {0.3f, 0.6f}, TransportMode::radiance);
      REQUIRE(refl);
      CHECK(refl->flags == BxDFFlags::specular_reflection);
      CHECK(refl->wi == Vector3f(-wo.x, -wo.y, wo.z));
      CHECK(refl->pdf == p.reflection);
      RGB F = b.specular_fresnel(wo.z);
      for (int c = 0; c < 3; ++c) CHECK(refl->f[c] * wo.z == Approx(F[c]).epsilon(1e-6));  // 1e-6: f = F/cos, times cos: 2 float roundings (1.2e-7)
      auto tr = b.sample(wo, 1 - p.transmission / 2, {0.3f, 0.6f}, TransportMode::radiance);
      REQUIRE(tr);
      CHECK(tr->flags == BxDFFlags::specular_transmission);
      CHECK(tr->wi == -wo);
      CHECK(tr->eta == 1);
      auto di = b.sample(wo, p.reflection + p.diffuse / 2, {0.3f, 0.6f}, TransportMode::radiance);
      REQUIRE(di);
      CHECK(di->flags == BxDFFlags::diffuse_reflection);
      CHECK(di->pdf == Approx(p.diffuse * di->wi.z / pi_d));  // bare Approx: 100·FLT_EPSILON relative
      // eval and pdf: the diffuse lobe only; 0 at the delta directions' opposite side.
      CHECK(b.eval(wo, -wo, TransportMode::radiance).is_black());
      CHECK(b.pdf(wo, -wo, TransportMode::radiance) == 0);
    }
  }
  // alpha = roughness^2 = 2^-12 exactly: the first rough value.
  auto rough = make_bxdf<RGB>(material(0x1p-6f, 0.5f, 0.5f));
  CHECK_FALSE(rough.is_smooth());
  CHECK(rough.flags() == (BxDFFlags::glossy_reflection | BxDFFlags::diffuse_reflection |
                          BxDFFlags::glossy_transmission));
  CHECK_FALSE(bxdf_traits<MetalRoughBxDF<RGB>>::has_specular(material(0x1p-6f, 0.5f, 0.5f)));
  // A smooth pure-diffuse layer (specular 0, not metallic, opaque) has no delta lobe.
  MetalRoughMaterial matte = material(0, 0, 0);
  matte.specular = 0;
  CHECK_FALSE(bxdf_traits<MetalRoughBxDF<RGB>>::has_specular(matte));
  CHECK(make_bxdf<RGB>(matte).flags() == BxDFFlags::diffuse_reflection);
  CHECK(make_bxdf<RGB>(material(0, 0, 0, RGB(0))).flags() == BxDFFlags::specular_reflection);
}

TEST_CASE("metal-rough is finite at grazing angles, roughness 0, 1e-4, the threshold and 1", "[bxdfs][metal_rough][finite]") {
  PCG32 rng(8, 8);
  // The albedo bounds: 6 roughnesses x 3 metallic x 2 transmission x 2
  // cosines x 2 sides x 3 channels = 432 comparisons, one family at 10^-3.
  const double z = reference_physics::sidak_z(1e-3, 432);
  for (Float r : {0.f, 1e-4f, 0x1p-6f, 0.001f, 0.05f, 1.f})
    for (Float m : {0.f, 0.5f, 1.f})
      for (Float t : {0.f, 1.f})
        for (Float cz : {1e-8f, 1e-4f})
          for (Float side : {1.f, -1.f}) {
            MetalRoughMaterial mat = material(r, m, t);
            auto b = make_bxdf<RGB>(mat);
            auto bs = make_bxdf<S4>(mat);
            Vector3f wo(std::sqrt(1 - cz * cz) * 0.6f, std::sqrt(1 - cz * cz) * 0.8f, side * cz);
            INFO("roughness " << r << " metallic " << m << " transmission " << t << " cos " << cz << " side " << side);
            for (const Vector3f& wi : {Vector3f(-wo.x, -wo.y, wo.z), -wo, Vector3f(wo.x, wo.y, -wo.z),
                                       Vector3f(0, 0, side), Vector3f(0, 0, -side), Vector3f(0.6f, -0.8f, 1e-8f),
                                       Vector3f(-0.8f, 0.6f, -1e-4f)}) {
              check_finite<MetalRoughBxDF<RGB>, RGB>(b, wo, wi, rng);
              check_finite<MetalRoughBxDF<S4>, S4>(bs, wo, wi, rng);
            }
            auto a = albedo_all(b, wo, 2000, rng);
            for (int c = 0; c < 3; ++c) {
              CHECK(std::isfinite(a[size_t(c)].mean));
              // +1e-5: float rounding of weights ≤ 1 at these degenerate inputs (a few u, with room for 1/cos near grazing)
              CHECK(a[size_t(c)].mean <= 1 + z * a[size_t(c)].sigma + 1e-5);
            }
          }
}

TEST_CASE("metal-rough material: clamps with one warning per material, throws where no clamp makes sense, traits", "[bxdfs][metal_rough][validate]") {
  using T = bxdf_traits<MetalRoughBxDF<RGB>>;
  MetalRoughMaterial ok = material(0.4f, 0.2f, 0.1f);
  {
    CerrCapture cap;
    CHECK_NOTHROW(T::validate(ok, "scene: material 0"));
    MetalRoughMaterial zero_ior = ok;
    zero_ior.ior = 0;  // KHR_materials_ior: F0 = 1
    CHECK_NOTHROW(T::validate(zero_ior, "scene: material 0"));
    CHECK(cap.text.str().empty());
  }
  {
    CerrCapture cap;
    MetalRoughMaterial bad = ok;
    bad.name = "overdriven";
    bad.base_color = RGB(1.2f, 0.5f, -0.1f);
    bad.metallic = 1.5f;
    bad.roughness = -0.2f;
    bad.specular = 2;
    bad.transmission = 1.1f;
    bad.specular_color = RGB(-1, 2, 1);  // > 1 is allowed (the product with F0 is clamped), < 0 is not
    CHECK_NOTHROW(T::validate(bad, "scene: material 4"));
    std::string msg = cap.text.str();
    CHECK(cap.lines() == 1);
    CHECK_THAT(msg, Catch::Contains("scene: material 4") && Catch::Contains("'overdriven'") &&
                        Catch::Contains("metallic 1.5 -> 1") && Catch::Contains("roughness -0.2 -> 0") &&
                        Catch::Contains("base_color.r 1.2 -> 1") && Catch::Contains("base_color.b -0.1 -> 0") &&
                        Catch::Contains("specular 2 -> 1") && Catch::Contains("transmission 1.1 -> 1") &&
                        Catch::Contains("specular_color.r -1 -> 0"));
    CHECK_THAT(msg, !Catch::Contains("specular_color.g"));
    // make() renders the clamped values.
    auto b = make_bxdf<RGB>(bad);
    CHECK(b.metallic() == 1);
    CHECK(b.specular() == 1);
    CHECK(b.distribution().effectively_smooth());
    CHECK(b.base_color() == RGB(1, 0.5f, 0));
    CHECK(b.dielectric_f0().r == 0);
    // bare Approx: 100·FLT_EPSILON relative, ((η − 1)/(η + 1))² in float
    CHECK(b.dielectric_f0().g == Approx(0.08));
    CHECK(b.dielectric_f0().b == Approx(0.04));
  }
  auto throws = [&](MetalRoughMaterial m, const char* what) {
    m.name = "broken";
    CHECK_THROWS_WITH(T::validate(m, "scene: material 7"),
                      Catch::StartsWith("scene: material 7: ") && Catch::Contains("'broken'") && Catch::Contains(what));
  };
  MetalRoughMaterial m = ok;
  m.roughness = std::nanf("");
  throws(m, "roughness");
  m = ok;
  m.base_color.g = infinity;
  throws(m, "base_color");
  m = ok;
  m.specular_color.b = std::nanf("");
  throws(m, "specular_color");
  m = ok;
  m.metallic = -infinity;
  throws(m, "metallic");
  for (Float ior : {0.5f, -1.5f, std::nanf(""), infinity}) {
    m = ok;
    m.ior = ior;
    throws(m, "ior");
  }
  CHECK_FALSE(T::needs_spectral(ok));
  CHECK(T::name == "metal_rough");
  // bare Approx: 100·FLT_EPSILON relative, ((η − 1)/(η + 1))² in float
  CHECK(MetalRoughMaterial::f0_from_ior(1.5f) == Approx(0.04));
  CHECK(MetalRoughMaterial::f0_from_ior(0) == 1);
  // glTF's defaults: white, metallic 1, roughness 1.
  MetalRoughMaterial d;
  CHECK(d.base_color == RGB(1));
  CHECK(d.metallic == 1);
  CHECK(d.roughness == 1);
  CHECK(d.ior == 1.5f);
  CHECK(d.transmission == 0);
  // Through a scene: one warning per clamped material when the scene is built.
  using Set = default_bxdf_set<RGB>::with<MetalRoughBxDF<RGB>>;
  Scene<RGB, Set> scene;
  MetalRoughMaterial a = ok, c = ok;
  a.metallic = 2;
  a.roughness = 3;
  c.base_color = RGB(2);
  uint32_t ia = scene.add_material(a), ib = scene.add_material(ok), ic = scene.add_material(c);
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, ia);
  scene.add_sphere(Sphere{{3, 0, 0}, 1}, ib);
  scene.add_sphere(Sphere{{6, 0, 0}, 1}, ic);
  {
    CerrCapture cap;
    scene.build();
    CHECK(cap.lines() == 2);
    CHECK_THAT(cap.text.str(), Catch::Contains("scene: material 0") && Catch::Contains("scene: material 2"));
  }
  CHECK_FALSE(scene.needs_spectral());
  CHECK_FALSE(scene.has_specular());
  auto si = scene.intersect(Ray{{3, 0, 5}, {0, 0, -1}});
  REQUIRE(si);
  CHECK(scene.bsdf(*si, RGBWavelengths{}).bxdf().index() == Set::size - 1);
}

// ---- KHR_materials_volume: the refracting glass lobe -----------------------
// The metal-rough BxDF of a volume material (thickness > 0) refracts through
// its transmission instead of passing straight through a thin wall. Checked
// from outside and from inside (wo.z < 0: eta inverted, total internal
// reflection beyond the critical angle): chi-squared of sample() against
// pdf() on the whole front and back hemispheres (roughness 0.5 and 1, where
// a hemisphere grid resolves the lobes), the lobe-choice frequencies, and the
// white furnace in importance transport (no 1/eta^2: a smooth dielectric
// with a white base then scatters exactly 1; a rough one at most 1).
namespace {
MetalRoughMaterial volume_material(Float roughness, Float metallic, Float transmission, RGB base, Float ior = 1.5f) {
  MetalRoughMaterial m = material(roughness, metallic, transmission, base);
  m.ior = ior;
  m.thickness = 1;
  return m;
}
}  // namespace

TEST_CASE("metal-rough volume: sample matches pdf by chi-squared, inside and outside", "[bxdfs][metal_rough][volume][chi2]") {
  PCG32 rng(4242, 3);
  std::vector<Chi2Run> runs;
  for (Float r : {0.5f, 1.0f})
    for (Float m : {0.f, 0.5f})
      for (Float t : {0.5f, 1.f})
        for (double side : {1.0, -1.0}) {
          auto bxdf = make_bxdf<RGB>(volume_material(r, m, t, RGB(0.9f, 0.6f, 0.3f)));
          REQUIRE(bxdf.is_refractive());
          for (double theta : {0.0, 45.0, 80.0}) {
            Vector3f wo = direction_at(theta, 0.7, side);
            auto sample = [&]() -> std::optional<Vector3f> {
              auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
              if (!bs || bs->is_specular()) return std::nullopt;
              return bs->wi;
            };
            auto pdf = [&](const Vector3f& wi) { return bxdf.pdf(wo, wi, TransportMode::radiance); };
            for (int hemi : {1, -1}) {
              std::ostringstream label;
              label << "volume roughness " << r << " metallic " << m << " transmission " << t << " theta " << theta
                    << " side " << side << (hemi > 0 ? " upper" : " lower");
              auto res = chi2_window(sample, pdf, hemisphere_window(hemi), Chi2Config{60000, 20, 20});
              runs.push_back({label.str(), res});
            }
          }
        }
  const double level = prism_test::sidak_alpha(1e-3, int(runs.size()));
  for (const auto& r : runs) {
    INFO(r.label << ": " << r.result.summary());
    CHECK(r.result.p_value >= level);
  }
}

TEST_CASE("metal-rough volume: white furnace, lossless when smooth, TIR from inside, eta on transmission", "[bxdfs][metal_rough][volume][furnace]") {
  PCG32 rng(99, 1);
  // 128 albedo bounds (4 roughnesses x 2 metallic x 2 transmission x 2 sides
  // x 4 angles) and 8 lossless smooth-glass checks: m = 136, one family at 10^-3.
  const double z = reference_physics::sidak_z(1e-3, 128 + 8);
  for (Float r : {0.f, 0.05f, 0.3f, 1.f})
    for (Float m : {0.f, 0.5f})
      for (Float t : {0.5f, 1.f})
        for (double side : {1.0, -1.0})
          for (double theta : test_angles) {
            auto b = make_bxdf<RGB>(volume_material(r, m, t, RGB(1)));
            Vector3f wo = direction_at(theta, 0.7, side);
            auto a = albedo(b, wo, TransportMode::importance, 0, 20000, rng);
            INFO("roughness " << r << " metallic " << m << " transmission " << t << " theta " << theta << " side "
                              << side << ": " << a.mean << " +- " << a.sigma);
            // 1e-6: float rounding of the weights (~10 roundings: 6e-7); 1e-5 where σ is 0 because
            // every weight is 1 up to rounding
            CHECK(a.mean <= 1 + z * a.sigma + 1e-6);
            // Smooth glass with a white base and no metal: R + T = 1 exactly
            // (including total internal reflection from inside).
            if (r == 0 && m == 0 && t == 1) CHECK(a.mean == Approx(1).margin(z * a.sigma + 1e-5));
          }
  // A transmission sample carries the relative eta across the crossing, and
  // the smooth refraction obeys Snell's law.
  auto b = make_bxdf<RGB>(volume_material(0, 0, 1, RGB(1)));
  Vector3f wo = direction_at(45);
  int transmissions = 0;
  for (int i = 0; i < 1000; ++i) {
    auto bs = b.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    REQUIRE(bs);
    if (!bs->is_transmission()) continue;
    ++transmissions;
    // bare Approx (100·FLT_EPSILON relative); 1e-4: float sin = sqrt(1 − z²) has relative error ≈ u(cos/sin)² ≤ 4u at 45° and 28°, ≪ 1e-4
    CHECK(bs->eta == Approx(1.5f));
    Float sin_i = std::sqrt(1 - wo.z * wo.z), sin_t = std::sqrt(1 - bs->wi.z * bs->wi.z);
    CHECK(sin_i == Approx(1.5 * sin_t).epsilon(1e-4));
    CHECK(bs->wi.z < 0);
  }
  CHECK(transmissions > 900);
  // From inside beyond the critical angle (41.8 degrees for 1.5): never out.
  Vector3f inside = direction_at(60, 0.7, -1);
  for (int i = 0; i < 200; ++i) {
    auto bs = b.sample(inside, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    REQUIRE(bs);
    CHECK_FALSE(bs->is_transmission());
  }
  // The thin-walled material (thickness 0) is unchanged: no glass lobe.
  MetalRoughMaterial thin = volume_material(0.3f, 0, 1, RGB(1));
  thin.thickness = 0;
  CHECK_FALSE(make_bxdf<RGB>(thin).is_refractive());
  // ior 0 (F0 = 1) cannot bound a refracting volume: stays thin.
  CHECK_FALSE(make_bxdf<RGB>(volume_material(0.3f, 0, 1, RGB(1), 0)).is_refractive());
}

// ---- Kulla-Conty multiple-scattering compensation (switch, off by default) --
// MetalRoughBxDF::enable_multiple_scattering: the white furnace is 1 up to
// the albedo tables' own error at the test point (measured against fresh
// quadratures: microfacet_reference for the metal and the layer,
// DielectricAlbedoTable::albedo for the glass lobe) for a white metal (F0 =
// 1), a white diffuse base under the default dielectric layer, and a white
// refracting volume, and measurably below 1 without the switch; chi-squared
// of sample() against pdf(); reciprocity; finiteness.
namespace {
MetalRoughMaterial with_ms(MetalRoughMaterial m, bool on = true) {
  m.multiple_scattering = on;
  return m;
}
// The furnace's tolerance from the tables: the compensated albedo of the
// metal with F0 = 1 is 1 + E - E_table; of the white base under a layer
// with F0 and F90 = 1 (specular 1), 1 + F0 (A - A_table) + (E - A) -
// (E_table - A_table).
double layer_table_error(const Vector3f& wo, Float alpha, double f0) {
  MicrofacetReference r = microfacet_reference(wo, alpha);
  const auto& t = MicrofacetAlbedoTable::get();
  double e = t.E(wo.z, alpha), a = t.A(wo.z, alpha);
  return std::abs(f0 * (r.A - a) + (r.E - r.A) - (e - a));
}
double glass_table_error(const Vector3f& wo, Float alpha, double eta) {
  int side = wo.z > 0 ? 0 : 1;
  double mu = std::abs(wo.z);
  return std::abs(DielectricAlbedoTable::albedo(side, mu, alpha, eta, 75025) -
                  DielectricAlbedoTable::get().E(side, Float(mu), alpha, Float(eta)));
}
}  // namespace

TEST_CASE("metal-rough multiple scattering: white metal, white base under the layer and white glass scatter 1", "[bxdfs][metal_rough][furnace][ms]") {
  PCG32 rng(303, 5);
  const double f0 = sqr((1.5 - 1) / (1.5 + 1));
  std::printf("metal-rough furnace with and without compensation (RGB, 100000 samples each)\n");
  std::printf("%-22s %5s %6s %12s %12s %8s %8s\n", "lobe", "alpha", "theta", "single", "compensated", "sigma", "table");
  // One family at 10^-3 over m = 116 comparisons (Sidak): RGB 24 compensated
  // albedos (4 alphas x 3 angles x 2 cases), 6 single-scattering losses at
  // alpha 1 (which must reject 1, at the same z), 36 coloured bounds (4 x 3 x
  // 3 channels); spectral 32 (2 alphas x 2 angles x 4 wavelengths x metal and
  // base); glass 12 compensated albedos (2 alphas x 2 sides x 3 angles) and 6
  // losses at alpha 1.
  const double z = reference_physics::sidak_z(1e-3, 24 + 6 + 36 + 32 + 12 + 6);
  for (Float alpha : {0.05f, 0.3f, 0.6f, 1.0f})
    for (double theta : {0.0, 45.0, 80.0}) {
      const Float r = std::sqrt(alpha);  // glTF: alpha = roughness^2
      Vector3f wo = direction_at(theta);
      struct Case {
        const char* name;
        MetalRoughMaterial m;
        double err;
      };
      const Case cases[] = {
          {"metal, F0 = 1", material(r, 1, 0, RGB(1)), std::abs(microfacet_reference(wo, alpha).E -
                                                                MicrofacetAlbedoTable::get().E(wo.z, alpha))},
          {"dielectric over white", material(r, 0, 0, RGB(1)), layer_table_error(wo, alpha, f0)}};
      for (const auto& c : cases) {
        auto off = make_bxdf<RGB>(c.m), on = make_bxdf<RGB>(with_ms(c.m));
        REQUIRE(on.multiple_scattering());
        REQUIRE_FALSE(off.multiple_scattering());
        Albedo ss = albedo(off, wo, TransportMode::radiance, 1, 100000, rng);
        Albedo ms = albedo(on, wo, TransportMode::radiance, 1, 100000, rng);
        INFO(c.name << " alpha " << alpha << " theta " << theta << ": single " << ss.mean << " +- " << ss.sigma
                    << ", compensated " << ms.mean << " +- " << ms.sigma << ", table error " << c.err);
        CHECK(std::abs(ms.mean - 1) <= z * ms.sigma + c.err);
        if (alpha == 1.0f) CHECK(ss.mean < 1 - z * ss.sigma - c.err);
        std::printf("%-22s %5.2f %6.0f %12.4f %12.4f %8.4f %8.4f\n", c.name, double(alpha), theta, ss.mean, ms.mean,
                    ms.sigma, c.err);
      }
      // Every channel of a coloured metal and a coloured base stays <= 1.
      auto coloured = make_bxdf<RGB>(with_ms(material(r, 0.5f, 0, RGB(0.9f, 0.6f, 0.3f))));
      auto al = albedo_all(coloured, wo, 20000, rng);
      const double tol = cases[0].err + cases[1].err;  // the metal's and the layer's table errors
      for (int ch = 0; ch < 3; ++ch) CHECK(al[size_t(ch)].mean <= 1 + z * al[size_t(ch)].sigma + tol);
    }
  // Spectral: the white metal and the white base per wavelength.
  for (Float alpha : {0.3f, 1.0f})
    for (double theta : {0.0, 80.0}) {
      const Float r = std::sqrt(alpha);
      Vector3f wo = direction_at(theta);
      auto metal = make_bxdf<S4>(with_ms(material(r, 1, 0, RGB(1))));
      auto base = make_bxdf<S4>(with_ms(material(r, 0, 0, RGB(1))));
      double e_metal = std::abs(microfacet_reference(wo, alpha).E - MicrofacetAlbedoTable::get().E(wo.z, alpha));
      double e_base = layer_table_error(wo, alpha, f0);
      auto am = albedo_all(metal, wo, 40000, rng), ab = albedo_all(base, wo, 40000, rng);
      for (int c = 0; c < 4; ++c) {
        INFO("spectral alpha " << alpha << " theta " << theta << " wavelength " << c << ": metal "
                               << am[size_t(c)].mean << ", base " << ab[size_t(c)].mean);
        CHECK(std::abs(am[size_t(c)].mean - 1) <= z * am[size_t(c)].sigma + e_metal);
        // The uplifted white base is 1 only up to the uplift's own error.
        CHECK(ab[size_t(c)].mean <= 1 + z * ab[size_t(c)].sigma + e_base + 1e-3);
      }
    }
  // The glass lobe of a white volume (importance transport, both sides).
  for (Float alpha : {0.3f, 1.0f})
    for (double side : {1.0, -1.0})
      for (double theta : {0.0, 45.0, 80.0}) {
        Vector3f wo = direction_at(theta, 0.7, side);
        MetalRoughMaterial m = volume_material(std::sqrt(alpha), 0, 1, RGB(1));
        auto on = make_bxdf<RGB>(with_ms(m)), off = make_bxdf<RGB>(m);
        REQUIRE(on.multiple_scattering());
        Albedo ss = albedo(off, wo, TransportMode::importance, 0, 60000, rng);
        Albedo ms = albedo(on, wo, TransportMode::importance, 0, 60000, rng);
        double err = glass_table_error(wo, alpha, 1.5);
        INFO("glass alpha " << alpha << " side " << side << " theta " << theta << ": single " << ss.mean
                            << ", compensated " << ms.mean << " +- " << ms.sigma << ", table error " << err);
        CHECK(std::abs(ms.mean - 1) <= z * ms.sigma + err);
        if (alpha == 1.0f) CHECK(ss.mean < 1 - z * ss.sigma - err);
      }
}

TEST_CASE("metal-rough multiple scattering: sample matches pdf, eval is reciprocal, finite, off by default", "[bxdfs][metal_rough][chi2][ms]") {
  PCG32 rng(404, 7);
  std::vector<Chi2Run> runs;
  std::vector<LobeCount> lobes;
  auto sweep = [&](auto tag) {
    using S = decltype(tag);
    for (Float r : {0.3f, 0.7f, 1.0f})
      for (Float m : {0.f, 0.5f, 1.f}) {
        auto bxdf = make_bxdf<S>(with_ms(material(r, m, 0)));
        REQUIRE(bxdf.multiple_scattering());
        for (double theta : {0.0, 45.0, 80.0}) {
          std::ostringstream label;
          label << "ms " << (is_spectral_v<S> ? "spectral" : "RGB") << " roughness " << r << " metallic " << m
                << " theta " << theta;
          chi2_config(bxdf, direction_at(theta), r * r, label.str(), rng, runs, lobes);
          // Reciprocity of the reflection (the diffuse coupling and the
          // added lobes are symmetric products).
          for (int k = 0; k < 50; ++k) {
            Vector3f wo = direction_at(theta), wi = sample_cosine_hemisphere({rng.next_float(), rng.next_float()});
            S a = bxdf.eval(wo, wi, TransportMode::radiance), b = bxdf.eval(wi, wo, TransportMode::radiance);
            // 1e-4 relative: as in the reciprocity test above, shared float half vector, Fresnel's conditioning times a few u
            for (int c = 0; c < S::size; ++c) CHECK(a[c] == Approx(b[c]).epsilon(1e-4).margin(1e-30));
          }
        }
      }
  };
  sweep(RGB{});
  sweep(S4{});
  // A refracting volume: the glass lobe's compensation in the mixture, both
  // sides, both hemispheres.
  for (double side : {1.0, -1.0}) {
    auto bxdf = make_bxdf<RGB>(with_ms(volume_material(0.7f, 0.3f, 0.6f, RGB(0.9f, 0.6f, 0.3f))));
    REQUIRE(bxdf.is_refractive());
    for (double theta : {0.0, 45.0, 80.0}) {
      Vector3f wo = direction_at(theta, 0.7, side);
      auto sample = [&]() -> std::optional<Vector3f> {
        auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
        if (!bs) return std::nullopt;
        return bs->wi;
      };
      auto pdf = [&](const Vector3f& wi) { return bxdf.pdf(wo, wi, TransportMode::radiance); };
      for (int hemi : {1, -1}) {
        std::ostringstream label;
        label << "ms volume theta " << theta << " side " << side << (hemi > 0 ? " upper" : " lower");
        runs.push_back({label.str(), chi2_window(sample, pdf, hemisphere_window(hemi), Chi2Config{60000, 20, 20})});
      }
    }
  }
  // One family at 10^-3: the chi-squared runs and the lobe counts (3 lobes x
  // 54 configurations), m = runs + lobe counts (Sidak).
  const int m_tests = int(runs.size() + lobes.size());
  const double level = prism_test::sidak_alpha(1e-3, m_tests);
  check_lobe_counts(lobes, reference_physics::sidak_z(1e-3, m_tests));
  for (const auto& r : runs) {
    INFO(r.label << ": " << r.result.summary());
    CHECK(r.result.p_value >= level);
  }
  // No NaN or Inf at grazing angles and roughness 1e-4 (smooth: unchanged)
  // and 1, with a glass lobe too.
  for (Float r : {1e-4f, 0.05f, 1.f})
    for (Float cz : {1e-8f, 1e-4f})
      for (bool volume : {false, true}) {
        MetalRoughMaterial m = volume ? volume_material(r, 0.3f, 0.5f, RGB(0.8f)) : material(r, 0.5f, 0.5f);
        auto b = make_bxdf<RGB>(with_ms(m));
        auto bs = make_bxdf<S4>(with_ms(m));
        for (Float side : {1.f, -1.f}) {
          Vector3f wo(std::sqrt(1 - cz * cz) * 0.6f, std::sqrt(1 - cz * cz) * 0.8f, side * cz);
          INFO("roughness " << r << " cos " << cz << " volume " << volume << " side " << side);
          for (const Vector3f& wi : {Vector3f(-wo.x, -wo.y, wo.z), -wo, Vector3f(0, 0, 1), Vector3f(0, 0, -1),
                                     Vector3f(0.6f, -0.8f, 1e-8f)}) {
            check_finite<MetalRoughBxDF<RGB>, RGB>(b, wo, wi, rng);
            check_finite<MetalRoughBxDF<S4>, S4>(bs, wo, wi, rng);
          }
        }
      }
  // Off by default; smooth materials have nothing to compensate.
  MetalRoughMaterial m = material(0.5f, 0.5f, 0);
  CHECK_FALSE(m.multiple_scattering);
  CHECK_FALSE(make_bxdf<RGB>(m).multiple_scattering());
  CHECK_FALSE(make_bxdf<RGB>(with_ms(material(0, 0.5f, 0))).multiple_scattering());
  CHECK_FALSE(make_bxdf<RGB>(with_ms(material(1e-4f, 0.5f, 0))).multiple_scattering());
}

// KHR_materials_anisotropy. A white anisotropic metal is the F = 1 conductor
// with alpha_x = alpha + (1 - alpha) s^2 along the frame's x and alpha
// across: two-sided against reference_physics::conductor_albedo_aniso (its
// quadrature error < 2e-6 here: at most 1.75e-6 from 4x the points and
// panels);
// every channel of the layered cases at most 1. One family at 10^-3 over
// the case's 16 + 36 comparisons (Sidak).
TEST_CASE("metal-rough anisotropy: white metal against quadrature, furnace at most 1, 0 is isotropic", "[bxdfs][metal_rough][anisotropy][furnace]") {
  PCG32 rng(31, 7);
  const double z = reference_physics::sidak_z(1e-3, 16 + 36);
  const int n = 40000;
  for (Float r : {0.05f, 0.3f})
    for (Float s : {0.5f, 1.f})
      for (double theta : {0.0, 45.0, 70.0, 85.0}) {
        MetalRoughMaterial mat = material(r, 1, 0, RGB(1));
        mat.anisotropy = s;
        const double a = double(r) * r, ax = a + (1 - a) * double(s) * s;
        const Vector3f wo = direction_at(theta, 0.7);
        auto e = albedo_all(make_bxdf<RGB>(mat), wo, size_t(n), rng);
        double want = reference_physics::conductor_albedo_aniso(theta * pi_d / 180, 0.7, ax, a);
        INFO("roughness " << r << " anisotropy " << s << " theta " << theta << ": " << e[0].mean << " vs " << want);
        CHECK(std::abs(e[0].mean - want) <= z * reference_physics::bounded_sigma(want, n) + 2e-6);
      }
  for (Float r : {0.05f, 0.3f, 1.f})
    for (Float m : {0.f, 0.5f})
      for (Float t : {0.f, 0.5f})
        for (double theta : {0.0, 60.0, 85.0}) {
          MetalRoughMaterial mat = material(r, m, t, RGB(1));
          mat.anisotropy = 0.8f;
          auto a = albedo_all(make_bxdf<RGB>(mat), direction_at(theta), 20000, rng);
          INFO("roughness " << r << " metallic " << m << " transmission " << t << " theta " << theta << ": "
                            << a[0].mean << " +- " << a[0].sigma);
          // The channels are one estimate for a white material: one comparison.
          CHECK(a[0].mean <= 1 + z * a[0].sigma + 1e-6);
        }
  // Strength 0 is the isotropic material, value for value.
  MetalRoughMaterial iso = material(0.3f, 0.5f, 0.5f);
  MetalRoughMaterial zero = iso;
  zero.anisotropy = 0;
  zero.anisotropy_rotation = 1.2f;
  auto bi = make_bxdf<RGB>(iso), bz = make_bxdf<RGB>(zero);
  for (int i = 0; i < 100; ++i) {
    Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    CHECK(bi.eval(wo, wi, TransportMode::radiance) == bz.eval(wo, wi, TransportMode::radiance));
    CHECK(bi.pdf(wo, wi, TransportMode::radiance) == bz.pdf(wo, wi, TransportMode::radiance));
  }
}

// The anisotropy direction: the mesh's tangent T turned by the rotation
// towards the bitangent B = N x T w (glTF's tangent frame), so at rotation
// pi/6 the shading frame's x is cos(pi/6) T + sin(pi/6) B; strength 0 keeps
// the frame of an isotropic material.
TEST_CASE("metal-rough anisotropy: the shading frame's x follows the rotation in the tangent frame", "[bxdfs][metal_rough][anisotropy]") {
  SurfaceInteraction si;
  si.n = si.ns = Normal3f(0, 0, 1);
  si.dpdu = Vector3f(1, 0, 0);
  si.dpdv = Vector3f(0, 1, 0);
  si.tangent = Vector3f(0, 1, 0);  // the mesh's tangent differs from dpdu
  for (Float w : {1.f, -1.f}) {
    si.tangent_w = w;
    MetalRoughMaterial m = material(0.3f, 1, 0);
    m.anisotropy = 0.5f;
    m.anisotropy_rotation = Float(pi_d / 6);
    Frame f = bxdf_traits<MetalRoughBxDF<RGB>>::shading_frame(m, si);
    // T = (0, 1, 0), B = N x T w = (-w, 0, 0).
    const double c = std::cos(pi_d / 6), s = std::sin(pi_d / 6);
    INFO("handedness " << w << ": x = " << f.x.x << " " << f.x.y << " " << f.x.z);
    CHECK(std::abs(f.x.x - (-w * s)) <= 1e-6);
    CHECK(std::abs(f.x.y - c) <= 1e-6);
    CHECK(std::abs(f.x.z) <= 1e-6);
    CHECK(std::abs(f.z.z - 1) <= 1e-6);
    m.anisotropy = 0;
    Frame g = bxdf_traits<MetalRoughBxDF<RGB>>::shading_frame(m, si);
    Frame h = si.shading_frame();
    CHECK((g.x == h.x && g.y == h.y && g.z == h.z));
  }
}

// KHR_materials_clearcoat against the transcription above (eval; the pdf
// as the mixture of the coat's visible-normal density, chosen with
// probability c F_s(mu_o), and the material's), reciprocity with a tilted
// coat, and strength 0 equal to no coat, value for value and sample for
// sample.
TEST_CASE("metal-rough clearcoat: eval and pdf against the transcription, reciprocal, 0 is no coat", "[bxdfs][metal_rough][clearcoat]") {
  PCG32 rng(8, 88);
  int compared = 0;
  for (Float coat_r : {0.f, 0.2f, 0.7f})
    for (Float c : {0.4f, 1.f})
      for (Float r : {0.05f, 0.5f})
        for (Float m : {0.f, 1.f}) {
          MetalRoughMaterial mat = material(r, m, 0.5f);
          mat.clearcoat = c;
          mat.clearcoat_roughness = coat_r;
          auto b = make_bxdf<RGB>(mat);
          Reference ref{mat};
          for (int i = 0; i < 150; ++i) {
            Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
            Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
            if (std::abs(wo.z) < 1e-3f || std::abs(wi.z) < 1e-3f) continue;
            INFO("clearcoat " << c << " coat roughness " << coat_r << " roughness " << r << " metallic " << m
                              << " wo.z " << wo.z << " wi.z " << wi.z);
            RGB f = b.eval(wo, wi, TransportMode::radiance);
            for (int ch = 0; ch < 3; ++ch) CHECK(f[ch] == Approx(ref.coated_eval(wo, wi, ch)).epsilon(2e-4).margin(1e-6));
            // The pdf: the coat's Torrance-Sparrow density (reflection only)
            // with probability p = c F_s(mu_o), the material's with 1 - p.
            namespace rp = reference_physics;
            double sign = wo.z < 0 ? -1 : 1;
            double coat_pdf = coat_r == 0 ? 0
                                          : rp::torrance_sparrow_pdf(ref.coat_alpha(), ref.coat_alpha(),
                                                                     {wo.x, wo.y, sign * wo.z}, {wi.x, wi.y, sign * wi.z});
            double p = c * rp::fresnel_schlick(0.04, std::abs(wo.z));
            MetalRoughMaterial bare = mat;
            bare.clearcoat = 0;
            double want = p * coat_pdf + (1 - p) * make_bxdf<RGB>(bare).pdf(wo, wi, TransportMode::radiance);
            CHECK(b.pdf(wo, wi, TransportMode::radiance) == Approx(want).epsilon(2e-4).margin(1e-6));
            ++compared;
          }
        }
  CHECK(compared > 3000);
  // Reciprocal, with the coat's normal tilted away from the base's.
  for (Float coat_r : {0.2f, 0.7f}) {
    auto b = make_bxdf<S4>(material(0.4f, 0.5f, 0.5f));
    b.set_clearcoat(0.8f, TrowbridgeReitz(coat_r * coat_r, coat_r * coat_r), normalize(Vector3f(-0.2f, 0.4f, 1)));
    for (int i = 0; i < 300; ++i) {
      Vector3f x = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      Vector3f y = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      S4 fxy = b.eval(x, y, TransportMode::radiance), fyx = b.eval(y, x, TransportMode::radiance);
      for (int ch = 0; ch < 4; ++ch) CHECK(fxy[ch] == Approx(fyx[ch]).epsilon(1e-4).margin(1e-30));
    }
  }
  // Strength 0: the material without a coat, eval, pdf and samples alike.
  MetalRoughMaterial plain = material(0.3f, 0.5f, 0.5f);
  MetalRoughMaterial zero = plain;
  zero.clearcoat = 0;
  zero.clearcoat_roughness = 0.5f;
  auto bp = make_bxdf<RGB>(plain), bz = make_bxdf<RGB>(zero);
  for (int i = 0; i < 200; ++i) {
    Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    CHECK(bp.eval(wo, wi, TransportMode::radiance) == bz.eval(wo, wi, TransportMode::radiance));
    CHECK(bp.pdf(wo, wi, TransportMode::radiance) == bz.pdf(wo, wi, TransportMode::radiance));
    Float uc = rng.next_float();
    Point2f u{rng.next_float(), rng.next_float()};
    auto sp = bp.sample(wo, uc, u, TransportMode::radiance), sz = bz.sample(wo, uc, u, TransportMode::radiance);
    REQUIRE(bool(sp) == bool(sz));
    if (sp) CHECK((sp->wi == sz->wi && sp->f == sz->f && sp->pdf == sz->pdf));
  }
  CHECK(bz.flags() == bp.flags());
}

// The coat over a white Lambertian base (specular 0) and a smooth coat:
// the coat reflects c F(mu_o); the base, under it, gets 1 - c F(mu_o) and
// sends back its cosine-weighted mean of 1 - c F(mu_i): 1 - c F_avg, F_avg
// = 2 int F(mu) mu dmu = 0.04 + 0.96 / 21 (2 int (1 - mu)^5 mu dmu = 1/21).
// Albedo = c F(mu_o) + (1 - c F(mu_o)) (1 - c F_avg), two-sided. Rough
// coats over white bases, metals and thin slabs: at most 1. The coat over a
// black base (base colour 0, specular 0) is the rough dielectric of ior 1.5
// but for Schlick's F in place of the exact one: |f - f_dielectric| <=
// max_c |F_s(c) - F(c)| D G / (4 cos_o cos_i). One family at 10^-3 over
// the 8 + 81 albedo comparisons (Sidak).
TEST_CASE("metal-rough clearcoat: furnace against the closed form, at most 1, a dielectric over black", "[bxdfs][metal_rough][clearcoat][furnace]") {
  PCG32 rng(64, 3);
  const double z = reference_physics::sidak_z(1e-3, 8 + 81);
  const double f_avg = 0.04 + 0.96 / 21;
  for (Float c : {0.5f, 1.f})
    for (double theta : test_angles) {
      MetalRoughMaterial mat = material(0.5f, 0, 0, RGB(1));
      mat.specular = 0;
      mat.clearcoat = c;
      const Vector3f wo = direction_at(theta);
      const double F = reference_physics::fresnel_schlick(0.04, double(wo.z));
      const double want = c * F + (1 - c * F) * (1 - c * f_avg);
      auto a = albedo_all(make_bxdf<RGB>(mat), wo, 40000, rng);
      INFO("white Lambert under a smooth coat " << c << ", theta " << theta << ": " << a[0].mean << " +- "
                                                  << a[0].sigma << " vs " << want);
      CHECK(std::abs(a[0].mean - want) <= z * a[0].sigma + 1e-6);
    }
  for (Float coat_r : {0.f, 0.3f, 1.f})
    for (Float r : {0.f, 0.3f, 1.f})
      for (Float m : {0.f, 1.f})
        for (Float t : {0.f, 1.f}) {
          if (m == 1 && t > 0) continue;
          for (double theta : {0.0, 60.0, 85.0}) {
            MetalRoughMaterial mat = material(r, m, t, RGB(1));
            mat.clearcoat = 1;
            mat.clearcoat_roughness = coat_r;
            auto a = albedo_all(make_bxdf<RGB>(mat), direction_at(theta), 20000, rng);
            INFO("coat roughness " << coat_r << " roughness " << r << " metallic " << m << " transmission " << t
                                   << " theta " << theta << ": " << a[0].mean << " +- " << a[0].sigma);
            CHECK(a[0].mean <= 1 + z * a[0].sigma + 1e-6);
          }
        }
  // Over black: the rough dielectric of ior 1.5 with Schlick's Fresnel.
  double delta = 0;
  for (int k = 0; k <= 1000; ++k) {
    double cth = k / 1000.0;
    delta = std::max(delta, std::abs(reference_physics::fresnel_schlick(0.04, cth) -
                                     reference_physics::fresnel_dielectric(cth, 1.5)));
  }
  for (Float coat_r : {0.2f, 0.6f}) {
    MetalRoughMaterial black = material(0.5f, 0, 0, RGB(0));
    black.specular = 0;
    black.clearcoat = 1;
    black.clearcoat_roughness = coat_r;
    auto b = make_bxdf<RGB>(black);
    const double a = double(coat_r) * coat_r;
    for (int i = 0; i < 500; ++i) {
      Vector3f wo = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
      Vector3f wi = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
      namespace rp = reference_physics;
      rp::Dir o{wo.x, wo.y, wo.z}, in{wi.x, wi.y, wi.z};
      double dielectric = rp::torrance_sparrow(a, a, o, in, [](double c) { return rp::fresnel_dielectric(c, 1.5); });
      double dg = rp::torrance_sparrow(a, a, o, in, [](double) { return 1.0; });
      INFO("coat roughness " << coat_r << " wo.z " << wo.z << " wi.z " << wi.z);
      CHECK(std::abs(b.eval(wo, wi, TransportMode::radiance).g - dielectric) <= delta * dg * (1 + 2e-4) + 1e-6);
    }
  }
  WARN("clearcoat over black: Schlick's F0 = 0.04 differs from the exact Fresnel of ior 1.5 by at most " << delta);
}

// KHR_materials_iridescence. The dielectric layer alone (base colour 0,
// metallic 0), spectral at fixed wavelengths: f = F D G / (4 cos_o cos_i)
// with F = (1 - k) Schlick(0.04, c) + k R_film(c, lambda), R_film by the
// characteristic-matrix method (reference_physics::thin_film_tmm) over the
// layer's ior; factor 0 or thickness 0 is the material without a film;
// white iridescent materials scatter at most 1 in RGB and spectral mode
// (Sidak z over the 84 comparisons: 12 configurations x 3 channels + 4
// wavelengths); rough samples carry eval and pdf.
TEST_CASE("metal-rough iridescence: the film in the Fresnel factor, 0 is no film, furnace at most 1", "[bxdfs][metal_rough][iridescence]") {
  PCG32 rng(12, 21);
  const W4 lambda = fixed_wavelengths();
  for (Float k : {1.f, 0.4f})
    for (Float d : {150.f, 420.f}) {
      MetalRoughMaterial mat = material(0.3f, 0, 0, RGB(0));
      mat.iridescence = k;
      mat.iridescence_ior = 1.8f;
      mat.iridescence_thickness_max = d;
      auto b = make_bxdf<S4>(mat);
      const double a = 0.09;
      for (int i = 0; i < 200; ++i) {
        Vector3f wo = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
        Vector3f wi = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
        S4 f = b.eval(wo, wi, TransportMode::radiance);
        namespace rp = reference_physics;
        rp::Dir o{wo.x, wo.y, wo.z}, in{wi.x, wi.y, wi.z};
        for (int c = 0; c < 4; ++c) {
          double want = rp::torrance_sparrow(a, a, o, in, [&](double cos_h) {
            return (1 - k) * rp::fresnel_schlick(0.04, cos_h) + k * rp::thin_film_tmm(cos_h, 1, 1.8, d, 1.5, lambda[c]);
          });
          INFO("factor " << k << " thickness " << d << " wavelength " << lambda[c] << " wo.z " << wo.z << " wi.z " << wi.z);
          CHECK(f[c] == Approx(want).epsilon(2e-4).margin(1e-6));
        }
      }
    }
  // Factor 0 or thickness 0: no film, value for value.
  for (int none = 0; none < 2; ++none) {
    MetalRoughMaterial plain = material(0.3f, 0.5f, 0.5f);
    MetalRoughMaterial film = plain;
    film.iridescence = none ? 0.f : 1.f;
    film.iridescence_thickness_max = none ? 300.f : 0.f;
    auto bp = make_bxdf<RGB>(plain), bf = make_bxdf<RGB>(film);
    for (int i = 0; i < 100; ++i) {
      Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      CHECK(bp.eval(wo, wi, TransportMode::radiance) == bf.eval(wo, wi, TransportMode::radiance));
      CHECK(bp.pdf(wo, wi, TransportMode::radiance) == bf.pdf(wo, wi, TransportMode::radiance));
    }
  }
  const double z = reference_physics::sidak_z(1e-3, 84);
  for (Float r : {0.f, 0.3f, 1.f})
    for (Float m : {0.f, 1.f})
      for (double theta : {0.0, 75.0}) {
        MetalRoughMaterial mat = material(r, m, 0, RGB(1));
        mat.iridescence = 1;
        mat.iridescence_thickness_max = 380;
        auto a = albedo_all(make_bxdf<RGB>(mat), direction_at(theta), 20000, rng);
        auto as = albedo_all(make_bxdf<S4>(mat), direction_at(theta), 20000, rng);
        INFO("roughness " << r << " metallic " << m << " theta " << theta);
        for (int c = 0; c < 3; ++c) CHECK(a[size_t(c)].mean <= 1 + z * a[size_t(c)].sigma + 1e-6);
        for (int c = 0; c < 4; ++c) CHECK(as[size_t(c)].mean <= 1 + z * as[size_t(c)].sigma + 1e-6);
        auto b = make_bxdf<RGB>(mat);
        auto bs = b.sample(direction_at(theta), 0.3f, {0.4f, 0.6f}, TransportMode::radiance);
        if (bs && !bs->is_specular()) {
          CHECK(bs->f == b.eval(direction_at(theta), bs->wi, TransportMode::radiance));
          CHECK(bs->pdf == b.pdf(direction_at(theta), bs->wi, TransportMode::radiance));
        }
      }
}

// KHR_materials_sheen (sheen.hpp) against reference_physics' transcription
// of Estevez and Kulla 2017. Over a black base (base colour 0, specular 0)
// the material is the sheen alone, f = colour D G / (4 mu_o mu_i), for
// roughness >= 0.3, where the white lobe's albedo E stays below 1 (so the
// division by max(1, E) is inert). Over a base, the base's f is scaled by
// min(1 - c E(mu_o), 1 - c E(mu_i)), c the colour's largest channel, E by
// reference_physics::charlie_albedo; the table's excess over E (checked
// below to 0.05) allows c 0.05 f_base below the reference. Reciprocal; a black colour is the
// material without sheen, value for value and sample for sample.
TEST_CASE("metal-rough sheen: eval against the transcription, reciprocal, black is no sheen", "[bxdfs][metal_rough][sheen]") {
  namespace rp = reference_physics;
  PCG32 rng(31, 7);
  const RGB colour(0.9f, 0.5f, 0.2f);
  int compared = 0;
  for (Float sr : {0.3f, 0.6f, 1.f})
    for (int over_base = 0; over_base < 2; ++over_base) {
      MetalRoughMaterial mat = over_base ? material(0.4f, 0.3f, 0.3f) : material(0.4f, 0, 0, RGB(0));
      if (!over_base) mat.specular = 0;
      MetalRoughMaterial bare = mat;
      mat.sheen_color = colour;
      mat.sheen_roughness = sr;
      auto b = make_bxdf<RGB>(mat), base = make_bxdf<RGB>(bare);
      const double alpha = double(sr) * sr, c = colour.max_component();
      for (int i = 0; i < 120; ++i) {
        Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
        Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
        if (std::abs(wo.z) < 1e-3f || std::abs(wi.z) < 1e-3f) continue;
        const double sign = wo.z < 0 ? -1 : 1;
        const rp::Dir o{wo.x, wo.y, sign * wo.z}, in{wi.x, wi.y, sign * wi.z};
        const double lobe = rp::charlie_sheen(alpha, o, in);
        const double e_o = rp::charlie_albedo(alpha, std::abs(wo.z)), e_i = rp::charlie_albedo(alpha, std::abs(wi.z));
        REQUIRE(std::max(e_o, e_i) < 1);
        const double scale = std::min(1 - c * e_o, 1 - c * e_i);
        RGB f = b.eval(wo, wi, TransportMode::radiance), fb = base.eval(wo, wi, TransportMode::radiance);
        INFO("sheen roughness " << sr << (over_base ? " over a base" : " alone") << " wo.z " << wo.z << " wi.z " << wi.z);
        for (int ch = 0; ch < 3; ++ch) {
          const double want = colour[ch] * lobe + fb[ch] * scale;
          CHECK(f[ch] <= want * (1 + 2e-4) + 1e-6);
          CHECK(f[ch] >= want * (1 - 2e-4) - c * 0.05 * fb[ch] - 1e-6);
        }
        ++compared;
      }
    }
  CHECK(compared > 600);
  // Reciprocal, spectral, over a base and under a coat.
  MetalRoughMaterial rec = material(0.4f, 0.5f, 0.5f);
  rec.sheen_color = colour;
  rec.sheen_roughness = 0.5f;
  rec.clearcoat = 0.7f;
  rec.clearcoat_roughness = 0.3f;
  auto br = make_bxdf<S4>(rec);
  for (int i = 0; i < 300; ++i) {
    Vector3f x = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Vector3f y = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    S4 fxy = br.eval(x, y, TransportMode::radiance), fyx = br.eval(y, x, TransportMode::radiance);
    for (int ch = 0; ch < 4; ++ch) CHECK(fxy[ch] == Approx(fyx[ch]).epsilon(1e-4).margin(1e-30));
  }
  // A black sheen colour: the material without sheen.
  MetalRoughMaterial plain = material(0.3f, 0.5f, 0.5f);
  MetalRoughMaterial black = plain;
  black.sheen_roughness = 0.5f;
  auto bp = make_bxdf<RGB>(plain), bz = make_bxdf<RGB>(black);
  CHECK(bz.sheen() == 0);
  for (int i = 0; i < 200; ++i) {
    Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    CHECK(bp.eval(wo, wi, TransportMode::radiance) == bz.eval(wo, wi, TransportMode::radiance));
    CHECK(bp.pdf(wo, wi, TransportMode::radiance) == bz.pdf(wo, wi, TransportMode::radiance));
    Float uc = rng.next_float();
    Point2f u{rng.next_float(), rng.next_float()};
    auto sp = bp.sample(wo, uc, u, TransportMode::radiance), sz = bz.sample(wo, uc, u, TransportMode::radiance);
    REQUIRE(bool(sp) == bool(sz));
    if (sp) CHECK((sp->wi == sz->wi && sp->f == sz->f && sp->pdf == sz->pdf));
  }
  CHECK(bz.flags() == bp.flags());
}

// The white lobe's albedo table against reference_physics::charlie_albedo
// (Gauss-Legendre, independent of the table's midpoint rule) at 1500
// random (mu, roughness), mu >= 1e-3: the table is an upper envelope, so
// never below the reference by more than the two quadratures' disagreement
// (1.3e-4 at worst over the nodes: 2e-4), and above it by at most 0.05
// where E < 1 and 10% where E >= 1 (the envelope's raise; the eval and
// furnace tests allow c 0.05 for it).
TEST_CASE("metal-rough sheen: the albedo table is an upper envelope of the quadrature", "[bxdfs][metal_rough][sheen]") {
  namespace rp = reference_physics;
  const auto& t = SheenAlbedoTable::get();
  PCG32 rng(3, 33);
  double under = 0, over = 0, over_rel = 0;
  for (int i = 0; i < 1500; ++i) {
    const double u = rng.next_float();
    const double mu = std::max(1e-3, u * u), r = sheen_min_roughness + (1 - sheen_min_roughness) * rng.next_float();
    const double want = rp::charlie_albedo(r * r, mu), got = t.E(Float(mu), Float(r));
    INFO("mu " << mu << " roughness " << r << ": table " << got << " reference " << want);
    CHECK(got >= want - 2e-4);
    if (want < 1) CHECK(got <= want + 0.05);
    else CHECK(got <= want * 1.1);
    under = std::min(under, got - want);
    (want < 1 ? over : over_rel) = std::max(want < 1 ? over : over_rel, want < 1 ? got - want : got / want - 1);
  }
  WARN("sheen albedo table: " << under << " below, " << over << " above where E < 1, " << over_rel * 100
                              << "% above where E >= 1");
}

// The furnace. The sheen alone (over black) reflects colour E(mu_o), E by
// the reference quadrature; a white sheen over a white Lambertian base
// (specular 0) reflects E(mu_o) + 2 int_0^1 min(1 - E(mu_o), 1 - E(mu)) mu
// dmu (Gauss-Legendre), less up to 0.05 for the table's excess over E
// (checked above); and
// every white material with a sheen, of roughness 0.05 (albedo up to 3
// before the division by max(1, E)) to 1, over metals, bases and slabs,
// with and without a coat, RGB and spectral, scatters at most 1. One family
// at 10^-3 (Sidak) over the 24 + 12 + 1008 comparisons.
TEST_CASE("metal-rough sheen: furnace against quadrature, at most 1 in RGB and spectral", "[bxdfs][metal_rough][sheen][furnace]") {
  namespace rp = reference_physics;
  PCG32 rng(5, 55);
  const double z = rp::sidak_z(1e-3, 24 + 12 + 1008);
  const RGB colour(0.9f, 0.5f, 0.2f);
  for (Float sr : {0.3f, 1.f})
    for (double theta : {0.0, 45.0, 75.0, 89.0}) {
      MetalRoughMaterial mat = material(0.5f, 0, 0, RGB(0));
      mat.specular = 0;
      mat.sheen_color = colour;
      mat.sheen_roughness = sr;
      const Vector3f wo = direction_at(theta);
      const double e = rp::charlie_albedo(double(sr) * sr, wo.z);
      auto a = albedo_all(make_bxdf<RGB>(mat), wo, 20000, rng);
      for (int c = 0; c < 3; ++c) {
        INFO("sheen alone, roughness " << sr << " theta " << theta << " channel " << c << ": " << a[size_t(c)].mean
                                       << " +- " << a[size_t(c)].sigma << " vs " << colour[c] * e);
        CHECK(std::abs(a[size_t(c)].mean - colour[c] * e) <= z * a[size_t(c)].sigma + 1e-6);
      }
    }
  for (Float sr : {0.3f, 0.6f, 1.f})
    for (double theta : {0.0, 60.0, 80.0, 89.0}) {
      MetalRoughMaterial mat = material(0.5f, 0, 0, RGB(1));
      mat.specular = 0;
      mat.sheen_color = RGB(1);
      mat.sheen_roughness = sr;
      const Vector3f wo = direction_at(theta);
      const double alpha = double(sr) * sr, e_o = rp::charlie_albedo(alpha, wo.z);
      const double base = 2 * rp::integrate(
                                  [&](double mu) { return std::min(1 - e_o, 1 - rp::charlie_albedo(alpha, mu, 4, 2)) * mu; },
                                  0, 1, 16);
      const double want = e_o + base;
      auto a = albedo_all(make_bxdf<RGB>(mat), wo, 40000, rng);
      INFO("white sheen over white Lambert, roughness " << sr << " theta " << theta << ": " << a[0].mean << " +- "
                                                       << a[0].sigma << " vs " << want);
      CHECK(a[0].mean <= want + z * a[0].sigma + 1e-6);
      CHECK(a[0].mean >= want - 0.05 - z * a[0].sigma);
    }
  int bounded = 0;
  for (Float sr : {0.05f, 0.3f, 1.f})
    for (Float r : {0.f, 0.5f})
      for (Float m : {0.f, 1.f})
        for (Float t : {0.f, 1.f})
          for (int coated = 0; coated < 2; ++coated) {
            if (m == 1 && t > 0) continue;
            MetalRoughMaterial mat = material(r, m, t, RGB(1));
            mat.sheen_color = RGB(1);
            mat.sheen_roughness = sr;
            mat.clearcoat = coated ? 1.f : 0.f;
            for (double theta : {0.0, 70.0, 88.0, 89.9}) {
              auto a = albedo_all(make_bxdf<RGB>(mat), direction_at(theta), 10000, rng);
              auto as = albedo_all(make_bxdf<S4>(mat), direction_at(theta), 10000, rng);
              INFO("sheen roughness " << sr << " roughness " << r << " metallic " << m << " transmission " << t
                                      << (coated ? " coated" : "") << " theta " << theta << ": " << a[0].mean << " +- "
                                      << a[0].sigma);
              // +1e-6: float rounding of weights <= 1 (~10 roundings: 6e-7)
              for (int c = 0; c < 3; ++c) CHECK(a[size_t(c)].mean <= 1 + z * a[size_t(c)].sigma + 1e-6);
              for (int c = 0; c < 4; ++c) CHECK(as[size_t(c)].mean <= 1 + z * as[size_t(c)].sigma + 1e-6);
              bounded += 7;
            }
          }
  CHECK(bounded == 1008);
}

}  // namespace metal_rough_test
