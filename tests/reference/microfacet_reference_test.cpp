// The Trowbridge-Reitz distribution and the microfacet BSDFs built on it
// against independent references (support/reference_physics.hpp): D (Walter
// 2007), Lambda, G1 and the height-correlated G2 (Heitz 2014), the visible
// normals' density (Heitz 2018), the rough conductor's value and pdf, the
// rough dielectric's reflection and transmission (Walter 2007) in both
// transport modes and its albedo (a two-sided furnace, both sides), Lambert,
// the metal-rough Schlick Fresnel, and the Kulla-Conty compensation's F_ms
// and E_avg.
//
// Tolerances (pointwise): float_tol = gamma(64) ~ 3.8e-6 relative for a
// closed form (reference_physics.hpp); the references are double (error
// ~1e-15). A BSDF value depends on the half vector prism rounds to float
// (a few u in angle), and D's logarithmic derivative in theta_m reaches
// 2 / alpha, so its tolerance adds 8u / alpha.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/bxdfs/conductor.hpp>
#include <prism/bxdfs/dielectric.hpp>
#include <prism/bxdfs/diffuse.hpp>
#include <prism/bxdfs/metal_rough.hpp>
#include <prism/bxdfs/ms_compensation.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>
#include "support/reference_physics.hpp"

namespace microfacet_reference_test {

using namespace prism;
namespace ref = reference_physics;
using ref::float_tol;

namespace {
constexpr double u = ref::unit_roundoff;
double bsdf_tol(double alpha) { return float_tol + 8 * u / alpha; }

ref::Dir to_dir(const Vector3f& v) { return {v.x, v.y, v.z}; }
double rel_err(double got, double want) { return want == 0 ? std::abs(got) : std::abs(got / want - 1); }

struct Alphas {
  double ax, ay;
};
const Alphas alphas[] = {{0.001, 0.001}, {0.05, 0.05}, {0.3, 0.3}, {1, 1}, {0.05, 0.3}, {0.6, 0.1}, {2, 0.7}};

// Random unit directions, uniform on the sphere, away from the horizon by
// |z| >= 1e-3 (where the quantities are finite and well conditioned).
Vector3f random_direction(PCG32& rng) {
  for (;;) {
    Vector3f w = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    if (std::abs(w.z) >= 1e-3f) return w;
  }
}
// A microfacet normal spread like the distribution (so that narrow lobes
// are probed where they are not 0): a sampled visible normal.
Vector3f random_normal(const TrowbridgeReitz& d, PCG32& rng) {
  Vector3f w = random_direction(rng);
  if (w.z < 0) w = -w;
  return d.sample_wm(w, {rng.next_float(), rng.next_float()});
}
}  // namespace

TEST_CASE("D, Lambda, G1, G and D_visible equal Walter 2007 / Heitz 2014 / Heitz 2018 pointwise", "[reference][microfacet]") {
  PCG32 rng(2014, 1);
  double worst[5] = {0, 0, 0, 0, 0};
  int n = 0;
  for (const Alphas& a : alphas) {
    TrowbridgeReitz d(Float(a.ax), Float(a.ay));
    const double ax = d.alpha_x(), ay = d.alpha_y();
    for (int i = 0; i < 400; ++i, ++n) {
      Vector3f wo = random_direction(rng), wi = random_direction(rng), wm = random_normal(d, rng);
      INFO("alpha (" << ax << ", " << ay << ") wo " << wo.x << " " << wo.y << " " << wo.z << " wi " << wi.x << " "
                     << wi.y << " " << wi.z << " wm " << wm.x << " " << wm.y << " " << wm.z);
      double e[5] = {rel_err(d.D(wm), ref::ggx_D(ax, ay, to_dir(wm))),
                     rel_err(d.lambda(wo), ref::ggx_lambda(ax, ay, to_dir(wo))),
                     rel_err(d.G1(wo), ref::smith_G1(ax, ay, to_dir(wo))),
                     rel_err(d.G(wo, wi), ref::smith_G2(ax, ay, to_dir(wo), to_dir(wi))), 0};
      Vector3f up = wo.z > 0 ? wo : -wo;  // D_visible's reference is for wo above
      e[4] = rel_err(d.D_visible(up, wm), ref::ggx_vndf(ax, ay, to_dir(up), to_dir(wm)));
      // D_visible's factor wo.wm cancels: its rounding (3u sum |wo_i wm_i|)
      // relative to |wo.wm| is the condition number of the dot product.
      double cond = (std::abs(double(up.x) * wm.x) + std::abs(double(up.y) * wm.y) + std::abs(double(up.z) * wm.z)) /
                    std::abs(ref::dot(to_dir(up), to_dir(wm)));
      for (int k = 0; k < 5; ++k) {
        CHECK(e[k] <= float_tol + (k == 4 ? 4 * u * cond : 0));
        worst[k] = std::max(worst[k], e[k]);
      }
    }
  }
  WARN(n << " points: max relative error D " << worst[0] << ", Lambda " << worst[1] << ", G1 " << worst[2]
         << ", G " << worst[3] << ", D_visible " << worst[4] << " (tolerance " << float_tol << ")");
}

TEST_CASE("rough conductor eval and pdf equal Torrance-Sparrow with the exact Fresnel and the VNDF pdf", "[reference][conductor]") {
  PCG32 rng(2007, 2);
  double worst_f = 0, worst_p = 0;
  struct EtaK {
    double eta, k;
  };
  for (const Alphas& a : alphas)
    for (EtaK ek : {EtaK{0.2, 3.0}, EtaK{1.1, 0.5}, EtaK{0, 1}}) {
      TrowbridgeReitz d(Float(a.ax), Float(a.ay));
      ConductorBxDF<RGB> b(d, RGB(Float(ek.eta)), RGB(Float(ek.k)));
      const double ax = d.alpha_x(), ay = d.alpha_y();
      for (int i = 0; i < 300; ++i) {
        Vector3f wo = random_direction(rng);
        if (wo.z < 0) wo = -wo;
        // wi: the reflection of wo about a sampled normal, so that narrow lobes are hit.
        Vector3f wi = reflect(wo, random_normal(d, rng));
        if (!(wi.z > 1e-3f)) continue;
        double f = b.eval(wo, wi, TransportMode::radiance)[1], p = b.pdf(wo, wi, TransportMode::radiance);
        auto F = [&](double c) { return ref::fresnel_conductor(c, double(Float(ek.eta)), double(Float(ek.k))); };
        double fr = ref::torrance_sparrow(ax, ay, to_dir(wo), to_dir(wi), F);
        double pr = ref::torrance_sparrow_pdf(ax, ay, to_dir(wo), to_dir(wi));
        INFO("alpha (" << ax << ", " << ay << ") eta " << ek.eta << " k " << ek.k << " wo.z " << wo.z << " wi.z "
                       << wi.z << ": f " << f << " vs " << fr << ", pdf " << p << " vs " << pr);
        CHECK(rel_err(f, fr) <= bsdf_tol(std::min(ax, ay)));
        CHECK(rel_err(p, pr) <= bsdf_tol(std::min(ax, ay)));
        worst_f = std::max(worst_f, rel_err(f, fr) * std::min(ax, ay));
        worst_p = std::max(worst_p, rel_err(p, pr) * std::min(ax, ay));
      }
    }
  WARN("rough conductor: max relative error x alpha: f " << worst_f << ", pdf " << worst_p);
}

TEST_CASE("rough dielectric eval equals Walter 2007 reflection and transmission, both sides and modes", "[reference][dielectric]") {
  PCG32 rng(2007, 3);
  double worst = 0;
  int transmitted = 0;
  for (double eta : {1.5, 1.33, 1 / 1.5})
    for (const Alphas& a : alphas) {
      if (a.ax < 0.01) continue;  // the narrow lobes: the conductor test covers them
      TrowbridgeReitz d(Float(a.ax), Float(a.ay));
      DielectricBxDF<RGB> b(Float(eta), d);
      const double ax = d.alpha_x(), ay = d.alpha_y(), e = double(Float(eta));
      for (int i = 0; i < 300; ++i) {
        Vector3f wo = random_direction(rng), wi = random_direction(rng);
        ref::Dir o = to_dir(wo), in = to_dir(wi);
        // Away from the critical angle, where 1 - F falls like
        // sqrt(1 - sin_t^2) to 0: its relative derivative in sin_t^2 is
        // 1 / (2 (1 - sin_t^2)), and rounding moves sin_t^2 by a few u
        // times the half vector's conditioning; 2% away keeps that within
        // the tolerance. h: the (generalised) half vector of this pair.
        double n_o = o.z > 0 ? 1 : e, n_i = in.z > 0 ? 1 : e, n_t = o.z > 0 ? e : 1;
        bool reflection = o.z * in.z > 0;
        ref::Dir h = reflection ? ref::Dir{o.x + in.x, o.y + in.y, o.z + in.z}
                                : ref::Dir{n_o * o.x + n_i * in.x, n_o * o.y + n_i * in.y, n_o * o.z + n_i * in.z};
        h = ref::normalized(h);
        double c = std::abs(ref::dot(o, h)), sin2_t = (1 - c * c) * (n_o / n_t) * (n_o / n_t);
        if (std::abs(sin2_t - 1) < 0.02) continue;
        for (auto mode : {TransportMode::radiance, TransportMode::importance}) {
          double f = b.eval(wo, wi, mode)[0], fr;
          if (reflection) {
            ref::Dir o2 = o.z > 0 ? o : ref::Dir{-o.x, -o.y, -o.z}, i2 = o.z > 0 ? in : ref::Dir{-in.x, -in.y, -in.z};
            // Seen from below, the interface is 1 / eta from above.
            double e_side = o.z > 0 ? e : 1 / e;
            fr = ref::torrance_sparrow(ax, ay, o2, i2, [&](double cc) { return ref::fresnel_dielectric(cc, e_side); });
          } else {
            fr = ref::walter_transmission(ax, ay, e, o, in, mode == TransportMode::radiance);
            ++transmitted;
          }
          INFO("eta " << eta << " alpha (" << ax << ", " << ay << ") wo " << wo.x << " " << wo.y << " " << wo.z
                      << " wi " << wi.x << " " << wi.y << " " << wi.z << " mode " << int(mode) << ": " << f << " vs "
                      << fr);
          // The transmission's half vector sums two vectors (one scaled by
          // eta), whose float rounding the 1/alpha term covers too (x4).
          // Fresnel is ill-conditioned where a direction grazes the
          // microfacet: directions of length 1 +- 2u move cos^2 = 1 - sin^2
          // of the other side (Snell) by ~4u absolute, i.e. cos_t by 2u /
          // cos_t^2 relative; the smaller of |wo.h|, |wi.h| bounds cos_t.
          double c_min = std::min(std::abs(ref::dot(o, h)), std::abs(ref::dot(in, h)));
          CHECK(rel_err(f, fr) <= 4 * bsdf_tol(std::min(ax, ay)) + 8 * u / (c_min * c_min));
          if (fr > 0) worst = std::max(worst, rel_err(f, fr) * std::min(ax, ay));
        }
      }
    }
  CHECK(transmitted > 1000);
  WARN("rough dielectric: max relative error x alpha " << worst);
}

TEST_CASE("rough dielectric albedo (R + T, importance transport) equals its double quadrature from both sides", "[reference][dielectric][furnace]") {
  // Two-sided: each estimate of f |cos| / pdf = G2 / G1 in [0, 1] (the
  // energy fraction) over 40000 samples against ref::dielectric_albedo
  // (resolution 256 x 16 panels: within 3.3e-5 of twice that, so 1e-4 is
  // added), sigma = ref::bounded_sigma, z = sidak_z(1e-3, 18) = 4.03.
  // From inside (wo below) the interface is seen with 1 / eta, total
  // internal reflection included.
  const int m = 18;
  const double z = ref::sidak_z(1e-3, m);
  PCG32 rng(2007, 5);
  double worst = 0;
  for (double side : {1.0, -1.0})
    for (double alpha : {0.05, 0.3, 1.0})
      for (double theta : {0.0, 45.0, 80.0}) {
        DielectricBxDF<RGB> b(1.5f, TrowbridgeReitz(Float(alpha), Float(alpha)));
        double t = theta * ref::pi / 180;
        Vector3f wo(Float(std::sin(t)), 0, Float(side * std::cos(t)));
        const int n = 40000;
        double sum = 0;
        for (int i = 0; i < n; ++i) {
          auto bs = b.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::importance);
          if (bs && bs->pdf > 0) sum += double(bs->f[0]) * std::abs(bs->wi.z) / bs->pdf;
        }
        double mean = sum / n;
        double want = ref::dielectric_albedo(std::acos(std::abs(double(wo.z))), alpha, side > 0 ? 1.5 : 1 / 1.5, 256, 16);
        double sigma = ref::bounded_sigma(want, n);
        INFO((side > 0 ? "outside" : "inside") << " alpha " << alpha << " theta " << theta << ": " << mean << " vs "
                                               << want << " +- " << sigma);
        CHECK(std::abs(mean - want) <= z * sigma + 1e-4);
        worst = std::max(worst, std::abs(mean - want) / sigma);
      }
  WARN("rough dielectric furnace: " << m << " comparisons, max |albedo - reference| / sigma " << worst << ", z " << z);
}

TEST_CASE("Lambert is rho / pi and the metal-rough Fresnel is Schlick's", "[reference][diffuse][metal_rough]") {
  PCG32 rng(1994, 4);
  DiffuseBxDF<RGB> lambert(RGB(0.25f, 0.5f, 1));
  for (int i = 0; i < 100; ++i) {
    Vector3f wo = random_direction(rng), wi = random_direction(rng);
    RGB f = lambert.eval(wo, wi, TransportMode::radiance);
    double want = wo.z * wi.z > 0 ? ref::lambert(0.5) : 0;
    CHECK(rel_err(f.g, want) <= float_tol);
  }
  // A metal (metallic 1): F = Schlick with F0 = the base colour (glTF 2.0, appendix B).
  MetalRoughMaterial m;
  m.base_color = RGB(0.9f, 0.5f, 0.1f);
  m.metallic = 1;
  m.roughness = 0.5f;
  auto b = bxdf_traits<MetalRoughBxDF<RGB>>::make(m, SurfaceInteraction{}, RGBWavelengths{});
  for (int i = 0; i <= 100; ++i) {
    Float c = Float(i) / 100;
    RGB F = b.specular_fresnel(c);
    for (int ch = 0; ch < 3; ++ch) {
      double want = ref::fresnel_schlick(double(m.base_color[ch]), double(c));
      INFO("cos " << c << " channel " << ch << ": " << F[ch] << " vs " << want);
      CHECK(std::abs(F[ch] - want) <= float_tol);
    }
  }
}

TEST_CASE("Kulla-Conty: F_ms and the tabulated E_avg equal the formula and a double quadrature", "[reference][ms]") {
  // F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)) (Kulla & Conty 2017, slide 18).
  for (double fa : {0.0, 0.3, 0.7, 0.95, 1.0})
    for (double ea : {0.3, 0.6, 0.9, 0.99}) {
      double want = fa * fa * ea / (1 - fa * (1 - ea));
      CHECK(std::abs(MultipleScattering<RGB>::fms(Float(fa), Float(ea)) - want) <= float_tol);
    }
  // E_avg(alpha): the table (32 x 32 quadrature, piecewise-linear in mu)
  // against ref::conductor_average_albedo (Gauss-Legendre in mu over the
  // 2D quadrature of E; < 1e-6 from its own doubled resolution). The table
  // is deterministic, so its bound is its measured maximum over these
  // alphas, 5.17e-4 (at 64 x 64 strata, linear in alpha), plus the
  // reference's 1e-6 and 1e-6 for float rounding of the table (2^-24 of
  // values <= 1 over a few roundings). A wrong E (a separable G moves E_avg
  // by up to 0.07 at alpha = 1) fails it.
  const auto& table = MicrofacetAlbedoTable::get();
  double worst = 0;
  for (double alpha : {0.05, 0.3, 0.6, 1.0}) {
    double want = ref::conductor_average_albedo(alpha), got = table.E_avg(Float(alpha));
    INFO("alpha " << alpha << ": E_avg " << got << " vs " << want);
    CHECK(std::abs(got - want) <= 5.17e-4 + 1e-6 + 1e-6);
    worst = std::max(worst, std::abs(got - want));
  }
  WARN("E_avg table: max |table - reference| " << worst);
}

}  // namespace microfacet_reference_test
