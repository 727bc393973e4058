// Glossy transport through the path integrators: a Cornell box built only
// of rough conductors (measured gold and copper walls, rough aluminium floor,
// ceiling and back wall), a rough glass box and a rough metal-rough sphere
// (bxdfs/metal_rough.hpp), lit by a square area light. No material is
// specular (every alpha is 0.09 or more), so PathIntegrator runs no
// caustic pass, and every light path is found both by next-event estimation
// (weighted by MIS) and by BSDF sampling: PathIntegrator (NEE + MIS) and
// BSDFPathIntegrator (BSDF sampling only) must agree within z standard
// errors in every 16x16 region and channel, in RGB and in spectral mode,
// with z from Sidak's correction over the 48 comparisons of a test case at a
// family-wise false-alarm rate of 10^-3 (4.2). The standard errors come from
// the film's per-pixel variance.
#include <catch2/catch.hpp>
#include "support/reference_physics.hpp"
#include <cmath>
#include <vector>
#include <prism/bxdfs/metal_rough.hpp>
#include <prism/prism.hpp>

namespace rough_cornell_test {

using namespace prism;

namespace {

template <class S>
using RoughSet = typename default_bxdf_set<S>::template with<MetalRoughBxDF<S>>;

template <class S>
void build_rough_cornell(Scene<S, RoughSet<S>>& scene) {
  const MicrofacetRoughness rough(0.3f);
  uint32_t aluminium = scene.add_material(ConductorMaterial::metal("Al", rough, "rough aluminium"));
  uint32_t gold = scene.add_material(ConductorMaterial::metal("Au", rough, "rough gold"));
  uint32_t copper = scene.add_material(ConductorMaterial::metal("Cu", rough, "rough copper"));
  uint32_t glass = scene.add_material(DielectricMaterial{IOR(1.5f), "rough glass", rough});
  MetalRoughMaterial plastic;
  plastic.base_color = RGB(0.2f, 0.4f, 0.8f);
  plastic.metallic = 0.3f;
  plastic.roughness = 0.55f;  // alpha 0.3
  plastic.transmission = 0.4f;
  plastic.name = "rough metal-rough";
  uint32_t mr = scene.add_material(plastic);

  TriangleMesh shell;  // floor, ceiling, back wall, facing into the box
  append_quad(shell, {-1, -1, -1}, {0, 0, 2}, {2, 0, 0});  // floor, normal +y
  append_quad(shell, {-1, 1, -1}, {2, 0, 0}, {0, 0, 2});   // ceiling, normal -y
  append_quad(shell, {-1, -1, -1}, {2, 0, 0}, {0, 2, 0});  // back, normal +z
  scene.add_mesh_instance(std::move(shell), aluminium);
  TriangleMesh left;
  append_quad(left, {-1, -1, -1}, {0, 2, 0}, {0, 0, 2});  // normal +x
  scene.add_mesh_instance(std::move(left), gold);
  TriangleMesh right;
  append_quad(right, {1, -1, -1}, {0, 0, 2}, {0, 2, 0});  // normal -x
  scene.add_mesh_instance(std::move(right), copper);
  // A large light (BSDF sampling alone must find it) just below the ceiling.
  TriangleMesh lamp;
  append_quad(lamp, {-0.4f, 0.998f, -0.4f}, {0.8f, 0, 0}, {0, 0, 0.8f});  // normal -y
  scene.add_mesh_instance(std::move(lamp), aluminium, AreaEmission{RGB(6.f, 5.f, 4.f), 1, false});
  uint32_t box = scene.add_mesh(make_box({-0.3f, -1, -0.3f}, {0.3f, 0.2f, 0.3f}));
  scene.add_instance(box, glass, translate({-0.35f, 0, -0.3f}) * rotate(radians(18), {0, 1, 0}));
  scene.add_sphere(Sphere{{0.4f, -0.6f, 0.35f}, 0.4f}, mr);
  scene.build();
}

struct Regions {
  std::vector<double> mean, var;  // per region and channel: the mean and the variance of that mean
};

template <class S, class Integrator>
Regions render_regions(const Integrator& integrator, int spp, uint64_t seed) {
  Scene<S, RoughSet<S>> scene;
  build_rough_cornell(scene);
  REQUIRE_FALSE(scene.has_specular());
  REQUIRE_FALSE(PathIntegrator{}.caustics_active(scene));
  const int w = 64, h = 64, region = 16;
  PerspectiveCamera cam = default_camera(w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = seed;
  RenderStats st = render(scene, cam, integrator, film, opt);
  REQUIRE(st.dropped == 0);
  const int nx = w / region, ny = h / region;
  Regions out;
  out.mean.assign(size_t(nx * ny * 3), 0.0);
  out.var.assign(size_t(nx * ny * 3), 0.0);
  const double n = double(region) * region;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      size_t k = size_t((y / region) * nx + x / region) * 3;
      RGB c = film.pixel(x, y), v = film.variance(x, y);
      for (int ch = 0; ch < 3; ++ch) {
        out.mean[k + size_t(ch)] += c[ch] / n;
        out.var[k + size_t(ch)] += v[ch] / (n * n);
      }
    }
  return out;
}

template <class S>
void check_agreement(int spp_mis, int spp_bsdf) {
  Regions a = render_regions<S>(PathIntegrator{}, spp_mis, 11);
  Regions b = render_regions<S>(BSDFPathIntegrator{}, spp_bsdf, 12);
  double worst = 0, brightest = 0, worst_rel_sigma = 0;
  const double z_max = reference_physics::sidak_z(1e-3, int(a.mean.size()));
  for (size_t i = 0; i < a.mean.size(); ++i) {
    double sigma = std::sqrt(a.var[i] + b.var[i]);
    if (a.mean[i] > 0) worst_rel_sigma = std::max(worst_rel_sigma, sigma / a.mean[i]);
    double z = sigma > 0 ? std::abs(a.mean[i] - b.mean[i]) / sigma : 0;
    worst = std::max(worst, z);
    brightest = std::max(brightest, a.mean[i]);
    INFO((is_spectral_v<S> ? "spectral" : "RGB") << " region " << i / 3 << " channel " << i % 3 << ": NEE+MIS "
                                                 << a.mean[i] << " +- " << std::sqrt(a.var[i]) << ", BSDF only "
                                                 << b.mean[i] << " +- " << std::sqrt(b.var[i]));
    CHECK(std::abs(a.mean[i] - b.mean[i]) <= z_max * sigma);
    CHECK(a.mean[i] > 0);  // every region sees lit glossy surfaces
  }
  WARN("rough Cornell box (" << (is_spectral_v<S> ? "spectral" : "RGB") << "): " << a.mean.size()
                             << " region-channels, largest |NEE+MIS - BSDF| / sigma " << worst
                             << ", brightest region " << brightest << ", largest sigma / mean " << worst_rel_sigma);
}

}  // namespace

TEST_CASE("rough Cornell box: NEE with MIS agrees with BSDF sampling per region", "[integrators][rough_cornell]") {
  check_agreement<RGB>(96, 192);
}

TEST_CASE("rough Cornell box: NEE with MIS agrees with BSDF sampling per region, spectral", "[integrators][rough_cornell][spectral]") {
  check_agreement<Spectral>(96, 192);
}

}  // namespace rough_cornell_test
