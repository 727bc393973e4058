// Stability suite, lights: a tiny, very bright sphere light; a light seen only
// through a specular sheet (a caustic next-event estimation cannot reach); an
// environment map with a 10^5:1 sun; dispersive glass under a small light.
// References are closed forms (or, for the last, the BSDF-sampling path
// tracer, unbiased); each method's image mean must be within 4 standard
// errors of the reference, no sample or pixel may be non-finite, and the
// firefly ratio is reported and, where a method is meant to be robust, bounded
// by a per-sample maximum derived from the estimator. See docs/stability.md.
#include "stability/stability.hpp"

namespace lights_stability_test {

using namespace prism;
using namespace prism::stability;

namespace {

// Top-down orthographic view of the floor window [-a, a]^2 (in units of s,
// around `origin`), from height cam_h: pixel (px, py) covers
// x in [-a + px d, -a + (px + 1) d], z in [-a + py d, ...], d = 2a / n.
OrthographicCamera top_down(const Point3f& origin, double s, double a, double cam_h, int n) {
  Point3f eye = origin + Vector3f{0, Float(cam_h * s), 0};
  return OrthographicCamera(look_at_camera_to_world(eye, origin, {0, 0, -1}), Float(2 * a * s), n, n);
}

const char* sampler_name(SamplerKind k) {
  return k == SamplerKind::sobol ? "sobol" : (k == SamplerKind::stratified ? "stratified" : "independent");
}

// ---------------------------------------------------------------------------
// A diffuse floor (albedo rho) lit by a sphere light of radius r at height h,
// offset by lx from the window's centre; nothing else. E(x) = pi Le (r/d)^2
// cos(theta) exactly (the sphere is above the horizon), so the floor's
// radiance is rho Le r^2 h / d^3, whose mean over a rectangle is
// rho Le r^2 Omega(rectangle) / area (rectangle_solid_angle).
struct SphereLightFloor {
  double s = 1;                 // scale of everything
  Vector3f offset{0, 0, 0};     // world position of the window's centre
  double a = 1, h = 1, lx = 2.5, r = 1e-3, rho = 0.5;
  int n = 16;
  double Le() const {  // irradiance 1 at the window's centre
    double d = std::sqrt(lx * lx + h * h);
    return d * d * d / (pi * r * r * h);
  }
  template <class S>
  void build(Scene<S>& scene) const {
    const typename Scene<S>::material_type floor_m = DiffuseMaterial{RGB(Float(rho))};
    const typename Scene<S>::material_type black_m = DiffuseMaterial{RGB(0.f)};
    uint32_t fm = scene.add_material(floor_m), bm = scene.add_material(black_m);
    TriangleMesh floor;
    Float e = Float(10 * s);
    append_quad(floor, Point3f(offset) + Vector3f{-e, 0, -e}, {0, 0, 2 * e}, {2 * e, 0, 0});
    scene.add_mesh_instance(std::move(floor), fm);
    scene.add_sphere(Sphere{Point3f(offset) + Vector3f{Float(lx * s), Float(h * s), 0}, Float(r * s)}, bm,
                     AreaEmission{RGB(Float(Le()))});
    scene.build();
  }
  OrthographicCamera camera() const { return top_down(Point3f(offset), s, a, 2 * h * 0.25, n); }
  // Pixel (px, py) covers x in [x0, x0 + d] etc.; relative to the light's foot.
  double pixel_reference(int px, int py) const {
    double d = 2 * a / n, x0 = -a + px * d - lx, z0 = -a + py * d;
    return rho * Le() * r * r * rectangle_solid_angle(x0, x0 + d, z0, z0 + d, h) / (d * d);
  }
  double reference() const {
    return rho * Le() * r * r * rectangle_solid_angle(-a - lx, a - lx, -a, a, h) / (4 * a * a);
  }
  std::vector<double> reference_pixels() const {
    std::vector<double> v;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) v.push_back(pixel_reference(x, y));
    return v;
  }
  // The BSDF-sampling estimator's exact standard error: a sample is rho Le
  // when the cosine-sampled direction hits the light (probability
  // p = r^2 h / d^3 at the point, averaged over the pixel) and 0 otherwise.
  double bsdf_sigma(int spp) const {
    double var = 0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        double m = pixel_reference(x, y), p = m / (rho * Le());
        var += (rho * Le() * rho * Le() * p - m * m) / spp;
      }
    return std::sqrt(var) / (n * n);
  }
  // Largest value one sample of the NEE + MIS estimator can take (RGB, one
  // light, uniform cone sampling with pdf 1 / Omega): the light sample adds at
  // most (rho/pi) Le Omega (cosine <= 1, MIS weight <= 1); a BSDF sample that
  // hits the light adds rho Le w_b with w_b = p_b^2 / (p_b^2 + p_l^2) <=
  // p_b / (2 p_l) <= Omega / (2 pi). Omega is largest at the window point
  // nearest the light.
  double nee_sample_max() const {
    double dx = std::max(0.0, lx - a), dmin = std::sqrt(dx * dx + h * h);
    double cos_max = std::sqrt(std::max(0.0, 1 - r * r / (dmin * dmin)));
    double omega = 2 * pi * (1 - cos_max);
    return 1.5 * rho / pi * Le() * omega;
  }
};

template <class S, class Integrator>
Row sphere_light_row(const SphereLightFloor& setup, const char* case_name, const std::string& method,
                     const Integrator& integrator, const RunSpec& spec) {
  Scene<S> scene;
  setup.build(scene);
  Run r = run(scene, setup.camera(), integrator, spec);
  return make_row(case_name, method, r, 1, setup.reference(), setup.reference_pixels());
}

}  // namespace

TEST_CASE("tiny very bright sphere light over a diffuse floor", "[stability][lights]") {
  SphereLightFloor setup;  // r = 1e-3 at distance ~2.7: Le ~ 6e6
  const std::vector<double> ref_px = setup.reference_pixels();
  for (SamplerKind k : {SamplerKind::independent, SamplerKind::stratified, SamplerKind::sobol}) {
    RunSpec spec;
    spec.spp = 64;
    spec.sampler = k;
    Row row = sphere_light_row<RGB>(setup, "tiny bright light r=1e-3", std::string("NEE+MIS RGB ") + sampler_name(k),
                                    PathIntegrator{}, spec);
    row.firefly_bound = setup.nee_sample_max() / percentile(ref_px, 0.9999);
    row.check();
  }
  {
    RunSpec spec;
    spec.spp = 64;
    Row row = sphere_light_row<Spectral>(setup, "tiny bright light r=1e-3", "NEE+MIS spectral independent",
                                         PathIntegrator{}, spec);
    row.check();
  }
  {
    // BSDF sampling alone almost never finds the light (p ~ 5e-8 a sample):
    // its exact standard error is used, as the film's is 0 without a hit.
    RunSpec spec;
    spec.spp = 64;
    Row row = sphere_light_row<RGB>(setup, "tiny bright light r=1e-3", "BSDF-only RGB independent",
                                    BSDFPathIntegrator{}, spec);
    row.est.sigma = setup.bsdf_sigma(spec.spp);
    row.note = "exact sigma";
    row.check();
  }
}

TEST_CASE("small sphere light, BSDF sampling against NEE", "[stability][lights]") {
  // r = 0.2: BSDF sampling hits it ~1 sample in 500, enough to converge.
  SphereLightFloor setup;
  setup.r = 0.2;
  const std::vector<double> ref_px = setup.reference_pixels();
  RunSpec spec;
  spec.spp = 256;
  Row nee = sphere_light_row<RGB>(setup, "small light r=0.2", "NEE+MIS RGB independent", PathIntegrator{}, spec);
  nee.firefly_bound = setup.nee_sample_max() / percentile(ref_px, 0.9999);
  nee.check();
  Row bsdf = sphere_light_row<RGB>(setup, "small light r=0.2", "BSDF-only RGB independent", BSDFPathIntegrator{}, spec);
  double film_sigma = bsdf.est.sigma;
  bsdf.est.sigma = setup.bsdf_sigma(spec.spp);
  bsdf.note = "exact sigma; film sigma " + std::to_string(film_sigma);
  bsdf.check();
}

TEST_CASE("tiny bright sphere light at the 1e-4 and 1e6 scales", "[stability][lights][scale]") {
  // The same scene scaled by s and moved far from the origin: radiance is
  // scale-free, so the reference is unchanged; shadow acne (rays re-hitting
  // the floor) or rays slipping past the light would bias it.
  for (double s : {1e-4, 1e6}) {
    SphereLightFloor setup;
    setup.s = s;
    setup.offset = Vector3f{Float(30 * s), Float(-20 * s), Float(50 * s)};
    const std::vector<double> ref_px = setup.reference_pixels();
    RunSpec spec;
    spec.spp = 32;
    std::string name = "tiny bright light, scale " + std::to_string(s);
    Row row = sphere_light_row<RGB>(setup, name.c_str(), "NEE+MIS RGB independent", PathIntegrator{}, spec);
    row.firefly_bound = setup.nee_sample_max() / percentile(ref_px, 0.9999);
    row.check();
  }
}

// ---------------------------------------------------------------------------
// A light seen only through a thin dielectric sheet: floor (albedo rho) at
// y = 0, an infinite-ish thin glass sheet (eta 1.5) at y = 0.6, a sphere light
// of radius r at height 1 above the window's centre, the camera below the
// sheet looking down. Shadow rays stop at the sheet, so next-event estimation
// never reaches the light: every path is a caustic (floor - sheet - light).
// With max_depth 2 (floor, sheet) the floor's radiance is
//   L(x) = rho/pi * integral over the light's cone of Le T(cos) cos dw,
// T = (1 - R) / (1 + R) the thin sheet's transmittance (R Fresnel), by
// quadrature (the cone is small and T smooth: 24 x 48 midpoint nodes).
namespace {

struct SheetCaustic {
  double a = 1, h = 1, r = 0.1, rho = 0.5, sheet_y = 0.6;
  int n = 16;
  double Le() const { return 1 / (pi * r * r); }  // irradiance ~1 under the light without the sheet
  template <class S>
  void build(Scene<S>& scene) const {
    const typename Scene<S>::material_type floor_m = DiffuseMaterial{RGB(Float(rho))};
    const typename Scene<S>::material_type black_m = DiffuseMaterial{RGB(0.f)};
    const typename Scene<S>::material_type sheet_m = ThinDielectricMaterial{IOR(1.5f)};
    uint32_t fm = scene.add_material(floor_m), bm = scene.add_material(black_m), sm = scene.add_material(sheet_m);
    TriangleMesh floor, sheet;
    append_quad(floor, {-10, 0, -10}, {0, 0, 20}, {20, 0, 0});
    append_quad(sheet, {-20, Float(sheet_y), -20}, {0, 0, 40}, {40, 0, 0});
    scene.add_mesh_instance(std::move(floor), fm);
    scene.add_mesh_instance(std::move(sheet), sm);
    scene.add_sphere(Sphere{{0, Float(h), 0}, Float(r)}, bm, AreaEmission{RGB(Float(Le()))});
    scene.build();
  }
  OrthographicCamera camera() const { return top_down({0, 0, 0}, 1, a, 0.3, n); }
  double radiance_at(double x, double z) const {
    double cx = -x, cy = h, cz = -z, d = std::sqrt(cx * cx + cy * cy + cz * cz);
    Vector3f c{Float(cx / d), Float(cy / d), Float(cz / d)};
    Frame f = Frame::from_z(c);
    double cos_max = std::sqrt(1 - r * r / (d * d));
    const int nu = 24, nphi = 48;
    double e = 0;
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nphi; ++j) {
        double ca = cos_max + (1 - cos_max) * (i + 0.5) / nu, sa = std::sqrt(1 - ca * ca);
        double phi = 2 * pi * (j + 0.5) / nphi;
        Vector3f w = f.from_local({Float(sa * std::cos(phi)), Float(sa * std::sin(phi)), Float(ca)});
        double R = fresnel_dielectric(w.y, 1.5f), T = (1 - R) / (1 + R);
        e += Le() * T * double(w.y);
      }
    e *= 2 * pi * (1 - cos_max) / (nu * nphi);
    return rho / pi * e;
  }
  std::vector<double> reference_pixels() const {
    std::vector<double> v;
    double d = 2 * a / n;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        double m = 0;  // 3 x 3 midpoint nodes per pixel
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) m += radiance_at(-a + (x + (i + 0.5) / 3) * d, -a + (y + (j + 0.5) / 3) * d);
        v.push_back(m / 9);
      }
    return v;
  }
};

}  // namespace

TEST_CASE("light seen only through a specular sheet (caustic)", "[stability][lights][caustics]") {
  SheetCaustic setup;
  const std::vector<double> ref_px = setup.reference_pixels();
  double ref = 0;
  for (double v : ref_px) ref += v;
  ref /= double(ref_px.size());
  PathOptions opt;
  opt.max_depth = 2;
  Scene<RGB> scene;
  setup.build(scene);
  Scene<Spectral> scene_spectral;
  setup.build(scene_spectral);
  OrthographicCamera cam = setup.camera();

  // NEE + MIS with the light-tracing caustic pass: splats carry no film
  // variance, so 16 renders with different seeds give the standard error.
  auto batched = [&](const auto& sc, const char* method) {
    std::vector<double> means;
    Film sum(setup.n, setup.n);
    Row row;
    row.case_name = "caustic through thin glass";
    row.method = method;
    std::vector<std::vector<double>> images;
    for (int k = 0; k < 16; ++k) {
      RunSpec spec;
      spec.spp = 4;
      spec.seed = uint64_t(100 + k);
      Run r = run(sc, cam, PathIntegrator(opt), spec);
      means.push_back(image_average(r.film, 1));
      images.push_back(channel(r.film, 1));
      row.dropped += r.stats.dropped;
      row.nonfinite += nonfinite_pixels(r.film);
    }
    std::vector<double> avg(images[0].size(), 0.0);
    for (const auto& im : images)
      for (size_t i = 0; i < im.size(); ++i) avg[i] += im[i] / double(images.size());
    row.est = batch_mean(means);
    row.reference = ref;
    row.firefly = firefly_ratio(avg, ref_px);
    row.note = "sigma from 16 seeds";
    row.check();
  };
  batched(scene, "NEE+MIS+light tracing RGB");
  batched(scene_spectral, "NEE+MIS+light tracing spectral");

  RunSpec spec;
  spec.spp = 64;
  PathOptions no_split = opt;
  no_split.light_traced_caustics = false;
  Row pt = make_row("caustic through thin glass", "NEE+MIS, no light tracing, RGB",
                    run(scene, cam, PathIntegrator(no_split), spec), 1, ref, ref_px);
  pt.check();
  Row bsdf = make_row("caustic through thin glass", "BSDF-only RGB", run(scene, cam, BSDFPathIntegrator(opt), spec), 1,
                      ref, ref_px);
  bsdf.check();
}

// ---------------------------------------------------------------------------
// An equirectangular environment of 64 x 32 texels: sky 1, one sun texel
// 10^5, over a diffuse floor. The lookup is nearest-texel, so the floor's
// radiance is exactly rho/pi sum over the upper-hemisphere texels of
// L_t * dphi * (sin^2 theta_1 - sin^2 theta_0) / 2 (theta from +y).
namespace {

struct SunEnv {
  int w = 64, hgt = 32, sun_x = 20, sun_y = 9;
  double sky = 1, sun = 1e5, rho = 0.5;
  int n = 16;
  EnvironmentImage image() const {
    EnvironmentImage img{w, hgt, std::vector<float>(size_t(w) * size_t(hgt) * 3, float(sky))};
    for (int c = 0; c < 3; ++c) img.rgb[3 * (size_t(sun_y) * size_t(w) + size_t(sun_x)) + size_t(c)] = float(sun);
    return img;
  }
  // Cosine-weighted solid angle of row y's texels over pi: a cosine-sampled
  // direction lands in one texel of row y with this probability.
  double texel_q(int y) const {
    double t0 = pi * y / hgt, t1 = pi * (y + 1) / hgt;
    if (t0 >= pi / 2) return 0;
    double dphi = 2 * pi / w;
    return dphi * (std::sin(t1) * std::sin(t1) - std::sin(t0) * std::sin(t0)) / 2 / pi;
  }
  double reference() const {
    double m = 0;
    for (int y = 0; y < hgt; ++y) m += texel_q(y) * (w * sky);
    m += texel_q(sun_y) * (sun - sky);
    return rho * m;
  }
  // Exact standard error of BSDF sampling: a sample is rho L(texel).
  double bsdf_sigma(int samples) const {
    double m2 = 0;
    for (int y = 0; y < hgt; ++y) m2 += texel_q(y) * w * sky * sky;
    m2 += texel_q(sun_y) * (sun * sun - sky * sky);
    m2 *= rho * rho;
    double m = reference();
    return std::sqrt((m2 - m * m) / samples);
  }
  template <class S>
  void build(Scene<S>& scene) const {
    const typename Scene<S>::material_type floor_m = DiffuseMaterial{RGB(Float(rho))};
    TriangleMesh floor;
    append_quad(floor, {-50, 0, -50}, {0, 0, 100}, {100, 0, 0});
    scene.add_mesh_instance(std::move(floor), scene.add_material(floor_m));
    scene.add_light(ImageInfiniteLight<S>(image()));
    scene.build();
  }
  // Per-sample maximum of NEE + MIS (RGB): a texel's light-sample term is
  // (rho/pi) L cos w_l / p_l <= (rho/pi) L cos / p_l, its BSDF-hit term
  // rho L w_b <= rho L p_b / (2 p_l) = (rho/pi) L cos / (2 p_l); where p_l = 0
  // (texels the MIS-compensated density drops) only the BSDF term, rho L.
  // The sun texel's p_l, from the light's own pdf_li, is evaluated on a 17 x 17
  // grid over the texel (edges included): the maximum of L cos / p_l there.
  template <class S>
  double nee_sample_max(const Scene<S>& scene) const {
    double best = rho * sky;
    const auto& light = std::get<ImageInfiniteLight<S>>(scene.lights()[scene.infinite_lights()[0]]);
    for (int i = 0; i <= 16; ++i)
      for (int j = 0; j <= 16; ++j) {
        Point2f uv{Float((sun_x + i / 16.0) / w), Float((sun_y + j / 16.0) / hgt)};
        uv.x = std::clamp(uv.x, 1e-6f, 1 - 1e-6f);
        uv.y = std::clamp(uv.y, 1e-6f, 1 - 1e-6f);
        Vector3f wdir = equirect_to_direction(uv);
        Float pl = light.pdf_li(LightSampleContext{}, wdir, SurfaceInteraction{});
        if (pl > 0 && wdir.y > 0) best = std::max(best, 1.5 * rho / pi * sun * double(wdir.y) / double(pl));
      }
    return best;
  }
};

}  // namespace

TEST_CASE("environment map with a 1e5 to 1 sun over a diffuse floor", "[stability][lights][environment]") {
  SunEnv env;
  const double ref = env.reference();
  const std::vector<double> ref_px(size_t(env.n * env.n), ref);
  Scene<RGB> scene;
  env.build(scene);
  Scene<Spectral> scene_spectral;
  env.build(scene_spectral);
  OrthographicCamera cam = top_down({0, 0, 0}, 1, 1, 1, env.n);
  const double bound = env.nee_sample_max(scene) / ref;
  for (SamplerKind k : {SamplerKind::independent, SamplerKind::stratified, SamplerKind::sobol}) {
    RunSpec spec;
    spec.spp = 64;
    spec.sampler = k;
    spec.width = spec.height = env.n;
    Row row = make_row("env map, 1e5:1 sun", std::string("NEE+MIS RGB ") + sampler_name(k),
                       run(scene, cam, PathIntegrator{}, spec), 1, ref, ref_px);
    row.firefly_bound = bound;
    row.check();
  }
  RunSpec spec;
  spec.spp = 64;
  spec.width = spec.height = env.n;
  Row spectral = make_row("env map, 1e5:1 sun", "NEE+MIS spectral independent",
                          run(scene_spectral, cam, PathIntegrator{}, spec), 1, ref, ref_px);
  spectral.check();
  // BSDF sampling hits the sun with probability ~2e-4 a sample: its film
  // variance is unreliable, so its exact standard error is used.
  Row bsdf = make_row("env map, 1e5:1 sun", "BSDF-only RGB independent", run(scene, cam, BSDFPathIntegrator{}, spec), 1,
                      ref, ref_px);
  double film_sigma = bsdf.est.sigma;
  bsdf.est.sigma = env.bsdf_sigma(env.n * env.n * spec.spp);
  bsdf.note = "exact sigma; film sigma " + std::to_string(film_sigma);
  bsdf.check();
}

// ---------------------------------------------------------------------------
// Dispersive glass (N-SF11), spectral only. (1) A white furnace: a dispersive
// sphere in a uniform environment of radiance 1 returns exactly 1 (a lossless
// dielectric only redirects light). (2) The sphere over a diffuse floor under
// a small sphere light: NEE + MIS with the light-tracing caustic pass against
// BSDF sampling (unbiased, the reference), both with the standard error of
// 16 seeds; the test is on their difference.
TEST_CASE("dispersive glass sphere in a white furnace", "[stability][lights][dispersion]") {
  Scene<Spectral> scene;
  const Scene<Spectral>::material_type glass = DielectricMaterial{IOR(SellmeierIOR::glass("N-SF11")), "sf11"};
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, scene.add_material(glass));
  scene.add_infinite_light(UniformInfiniteLight<Spectral>(RGB(1.f)));
  scene.build();
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 3}, {0, 0, 0}, {0, 1, 0}), radians(40), 16, 16);
  const std::vector<double> ref_px(256, 1.0);
  RunSpec spec;
  spec.spp = 64;
  make_row("dispersive glass furnace", "NEE+MIS spectral", run(scene, cam, PathIntegrator{}, spec), 1, 1.0, ref_px)
      .check();
  make_row("dispersive glass furnace", "BSDF-only spectral", run(scene, cam, BSDFPathIntegrator{}, spec), 1, 1.0,
           ref_px)
      .check();
}

TEST_CASE("dispersive glass sphere under a small light", "[stability][lights][dispersion][caustics]") {
  Scene<Spectral> scene;
  const Scene<Spectral>::material_type floor_m = DiffuseMaterial{RGB(0.5f)};
  const Scene<Spectral>::material_type black_m = DiffuseMaterial{RGB(0.f)};
  const Scene<Spectral>::material_type glass = DielectricMaterial{IOR(SellmeierIOR::glass("N-SF11")), "sf11"};
  TriangleMesh floor;
  append_quad(floor, {-10, 0, -10}, {0, 0, 20}, {20, 0, 0});
  scene.add_mesh_instance(std::move(floor), scene.add_material(floor_m));
  scene.add_sphere(Sphere{{0, 0.6f, 0}, 0.5f}, scene.add_material(glass));
  scene.add_sphere(Sphere{{0.3f, 2.5f, 0}, 0.15f}, scene.add_material(black_m), AreaEmission{RGB(40.f)});
  scene.build();
  // Looking down at the caustic under the sphere and its surroundings.
  PerspectiveCamera cam(look_at_camera_to_world({0, 1.6f, 2.4f}, {0, 0.2f, 0}, {0, 1, 0}), radians(45), 16, 16);
  auto batch = [&](const auto& integrator, const char* method, int spp) {
    std::vector<double> means;
    std::vector<double> avg(256, 0.0);
    Row row;
    row.case_name = "dispersive glass, small light";
    row.method = method;
    for (int k = 0; k < 16; ++k) {
      RunSpec spec;
      spec.spp = spp;
      spec.seed = uint64_t(200 + k);
      Run r = run(scene, cam, integrator, spec);
      means.push_back(image_average(r.film, 1));
      std::vector<double> px = channel(r.film, 1);
      for (size_t i = 0; i < px.size(); ++i) avg[i] += px[i] / 16;
      row.dropped += r.stats.dropped;
      row.nonfinite += nonfinite_pixels(r.film);
    }
    row.est = batch_mean(means);
    row.note = "sigma from 16 seeds";
    return std::pair{row, avg};
  };
  auto [bsdf, bsdf_px] = batch(BSDFPathIntegrator{}, "BSDF-only spectral (reference)", 128);
  auto [nee, nee_px] = batch(PathIntegrator{}, "NEE+MIS+light tracing spectral", 32);
  // The reference is itself an estimate: its variance adds to the method's.
  nee.reference = bsdf.est.mean;
  nee.est.sigma = std::hypot(nee.est.sigma, bsdf.est.sigma);
  nee.firefly = firefly_ratio(nee_px, bsdf_px);
  nee.note = "sigma of the difference, 16 seeds each";
  bsdf.reference = bsdf.est.mean;
  bsdf.firefly = 1;
  bsdf.check(false);
  nee.check();
}

}  // namespace lights_stability_test
