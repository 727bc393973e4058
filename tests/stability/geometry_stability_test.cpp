// Stability suite, geometry: thin occluders and closed enclosures at the 1e-4,
// 1 and 1e6 scales (far from the origin), a camera inside objects, long thin
// (sliver) triangles and coplanar overlapping triangles. References are exact:
//   - a floor whose only light is hidden behind a thin black slab is black;
//   - the inside of a closed emitting diffuse enclosure has L = Le / (1 - rho);
//   - the inside of a closed opaque object in a bright environment is black;
//   - a diffuse floor (albedo rho) in a uniform environment of radiance 1 is
//     rho, whatever its tessellation; with BSDF sampling every sample is rho,
//     so a ray slipping through the floor (1) or re-hitting it (rho^2) shows.
// Slivers and coplanar triangles must also render the same image twice and
// with 1 and 2 threads. See docs/stability.md.
#include "stability/stability.hpp"

namespace geometry_stability_test {

using namespace prism;
using namespace prism::stability;

namespace {

std::string scale_name(double s) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

// Far from the origin, in units of the scale.
Vector3f far_offset(double s) { return Vector3f{Float(30 * s), Float(-20 * s), Float(50 * s)}; }

uint64_t positive_pixels(const Film& f) {
  uint64_t n = 0;
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) {
      RGB p = f.pixel(x, y);
      if (p.r > 0 || p.g > 0 || p.b > 0) ++n;
    }
  return n;
}

// Both integrators render a scene whose reference is black: every pixel 0.
template <class Scene, class Camera>
void check_black(const Scene& scene, const Camera& cam, const RunSpec& spec, const std::string& c) {
  const std::vector<double> ref_px(size_t(spec.width) * size_t(spec.height), 0.0);
  for (int which = 0; which < 2; ++which) {
    Run r = which ? run(scene, cam, PathIntegrator{}, spec) : run(scene, cam, BSDFPathIntegrator{}, spec);
    Row row = make_row(c, which ? "NEE+MIS RGB" : "BSDF-only RGB", r, 1, 0, ref_px);
    row.note = "lit pixels: " + std::to_string(positive_pixels(r.film)) + " (must be 0)";
    row.check();
    CHECK(positive_pixels(r.film) == 0);
  }
}

}  // namespace

TEST_CASE("a thin slab hides a light at the 1e-4, 1 and 1e6 scales", "[stability][geometry][scale]") {
  // Floor y = 0, a black closed slab 1e-4 s thick at y = s covering the
  // light (radius 0.3 s at height 2 s) from the whole window; the camera
  // between slab and floor. Any light on the floor went through the slab.
  for (double s : {1e-4, 1.0, 1e6}) {
    Vector3f o = far_offset(s);
    Scene<RGB> scene;
    const Scene<RGB>::material_type floor_m = DiffuseMaterial{RGB(0.8f)};
    const Scene<RGB>::material_type black_m = DiffuseMaterial{RGB(0.f)};
    uint32_t fm = scene.add_material(floor_m), bm = scene.add_material(black_m);
    Float S = Float(s);
    TriangleMesh floor, slab;
    append_quad(floor, Point3f(o) + Vector3f{-10 * S, 0, -10 * S}, {0, 0, 20 * S}, {20 * S, 0, 0});
    append_box(slab, Point3f(o) + Vector3f{-6 * S, S * (1 - 5e-5f), -6 * S},
               Point3f(o) + Vector3f{6 * S, S * (1 + 5e-5f), 6 * S});
    scene.add_mesh_instance(std::move(floor), fm);
    scene.add_mesh_instance(std::move(slab), bm);
    scene.add_sphere(Sphere{Point3f(o) + Vector3f{0, 2 * S, 0}, 0.3f * S}, bm, AreaEmission{RGB(10.f)});
    scene.build();
    OrthographicCamera cam(look_at_camera_to_world(Point3f(o) + Vector3f{0, 0.5f * S, 0}, Point3f(o), {0, 0, -1}),
                           2 * S, 16, 16);
    RunSpec spec;
    spec.spp = 64;
    std::string c = "thin slab over floor, scale " + scale_name(s);
    check_black(scene, cam, spec, c);
  }
}

TEST_CASE("inside closed emitting enclosures at the 1e-4 and 1e6 scales", "[stability][geometry][scale]") {
  // L = Le / (1 - rho) everywhere inside a closed enclosure whose walls all
  // emit Le and reflect diffusely with albedo rho; a ray leaking out (a re-hit
  // missed, an edge slipped through) loses energy.
  const float rho = 0.5f, Le = 0.5f;
  const double ref = Le / (1 - rho);
  const std::vector<double> ref_px(256, ref);
  for (double s : {1e-4, 1e6}) {
    Vector3f o = far_offset(s);
    Float S = Float(s);
    for (int shape = 0; shape < 2; ++shape) {
      Scene<RGB> scene;
      const Scene<RGB>::material_type m = DiffuseMaterial{RGB(rho)};
      uint32_t mi = scene.add_material(m);
      if (shape == 0) {
        scene.add_sphere(Sphere{Point3f(o), S}, mi, AreaEmission{RGB(Le), 1, true});
      } else {
        TriangleMesh box;
        append_box(box, Point3f(o) + Vector3f{-S, -S, -S}, Point3f(o) + Vector3f{S, 0.5f * S, 2 * S});
        scene.add_mesh_instance(std::move(box), mi, AreaEmission{RGB(Le), 1, true});
      }
      scene.build();
      // The camera near the wall, looking along it and across.
      PerspectiveCamera cam(look_at_camera_to_world(Point3f(o) + Vector3f{0.9f * S * 0.57f, 0.9f * S * 0.3f, 0},
                                                    Point3f(o) + Vector3f{-S, 0, 0.2f * S}, {0, 1, 0}),
                            radians(90), 16, 16);
      RunSpec spec;
      spec.spp = 64;
      std::string c = std::string(shape == 0 ? "inside emitting sphere" : "inside emitting box") + ", scale " +
                      scale_name(s);
      make_row(c, "NEE+MIS RGB", run(scene, cam, PathIntegrator{}, spec), 1, ref, ref_px).check();
      make_row(c, "BSDF-only RGB", run(scene, cam, BSDFPathIntegrator{}, spec), 1, ref, ref_px).check();
    }
  }
}

TEST_CASE("camera inside an opaque object in a bright environment", "[stability][geometry][camera_inside]") {
  // Nothing gets in: every pixel is exactly 0.
  for (double s : {1e-4, 1.0, 1e6}) {
    Vector3f o = far_offset(s);
    Float S = Float(s);
    for (int shape = 0; shape < 2; ++shape) {
      Scene<RGB> scene;
      const Scene<RGB>::material_type m = DiffuseMaterial{RGB(0.9f)};
      uint32_t mi = scene.add_material(m);
      if (shape == 0) {
        scene.add_sphere(Sphere{Point3f(o), S}, mi);
      } else {
        TriangleMesh box;
        append_box(box, Point3f(o) + Vector3f{-S, -S, -S}, Point3f(o) + Vector3f{S, S, S});
        scene.add_mesh_instance(std::move(box), mi);
      }
      scene.add_infinite_light(UniformInfiniteLight<RGB>(RGB(1000.f)));
      scene.build();
      PerspectiveCamera cam(look_at_camera_to_world(Point3f(o) + Vector3f{0.5f * S, -0.3f * S, 0.2f * S},
                                                    Point3f(o) + Vector3f{S, 0, 0}, {0, 1, 0}),
                            radians(120), 16, 16);
      RunSpec spec;
      spec.spp = 32;
      std::string c = std::string(shape == 0 ? "camera inside opaque sphere" : "camera inside opaque box") +
                      ", scale " + scale_name(s);
      check_black(scene, cam, spec, c);
    }
  }
}

namespace {

// A floor of 2 n sliver triangles: n strips of width 2/n over [-1, 1]^2, each
// cut along its diagonal (aspect ratio n).
TriangleMesh sliver_floor(int n) {
  TriangleMesh m;
  for (int i = 0; i <= n; ++i) {
    Float x = -1 + 2 * Float(i) / Float(n);
    m.positions.push_back({x, 0, -1});
    m.positions.push_back({x, 0, 1});
  }
  for (uint32_t i = 0; i < uint32_t(n); ++i) {
    uint32_t a = 2 * i, b = 2 * i + 1, c = 2 * i + 2, d = 2 * i + 3;  // a, c at z = -1; b, d at z = 1
    m.indices.insert(m.indices.end(), {a, b, d, a, d, c});               // normal +y
  }
  return m;
}

// The film's pixels all lie in [lo, hi] (up to rounding).
bool pixels_within(const Film& f, int c, double lo, double hi) {
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) {
      double v = f.pixel(x, y)[c];
      if (!(v >= lo - rounding_allowance(lo) && v <= hi + rounding_allowance(hi))) return false;
    }
  return true;
}

template <class Scene, class Camera>
void check_deterministic(const Scene& scene, const Camera& cam, const std::string& what) {
  RunSpec one, two, again;
  one.spp = two.spp = again.spp = 16;
  one.threads = 1;
  two.threads = 2;
  again.threads = 2;
  INFO(what);
  for (int which = 0; which < 2; ++which) {
    Run a = which ? run(scene, cam, PathIntegrator{}, one) : run(scene, cam, BSDFPathIntegrator{}, one);
    Run b = which ? run(scene, cam, PathIntegrator{}, two) : run(scene, cam, BSDFPathIntegrator{}, two);
    Run c = which ? run(scene, cam, PathIntegrator{}, again) : run(scene, cam, BSDFPathIntegrator{}, again);
    INFO((which ? "NEE+MIS" : "BSDF-only") << ": 1 vs 2 threads, then twice with 2");
    CHECK(identical(a.film, b.film));
    CHECK(identical(b.film, c.film));
    CHECK(nonfinite_pixels(a.film) == 0);
  }
}

}  // namespace

TEST_CASE("long thin triangles in a uniform environment", "[stability][geometry][slivers]") {
  const double rho = 0.5;
  const std::vector<double> ref_px(256, rho);
  for (int n : {1000, 10000}) {  // aspect ratios 1e3 and 1e4
    Scene<RGB> scene;
    const Scene<RGB>::material_type m = DiffuseMaterial{RGB(Float(rho))};
    scene.add_mesh_instance(sliver_floor(n), scene.add_material(m));
    scene.add_infinite_light(UniformInfiniteLight<RGB>(RGB(1.f)));
    scene.build();
    for (double theta : {0.0, 60.0, 85.0}) {
      // Orthographic, tilted about the strips' long axis (z) and slightly
      // about x, so rays cross many sliver edges.
      double t = double(radians(Float(theta)));
      Vector3f dir = normalize(Vector3f{Float(std::sin(t)), Float(std::cos(t)), 0.05f});
      OrthographicCamera cam(look_at_camera_to_world(Point3f{0, 0, 0} + dir * 10.f, {0, 0, 0}, {0, 0, -1}),
                             Float(0.8 * std::cos(t) + 0.05), 16, 16);
      RunSpec spec;
      spec.spp = 32;
      std::string c = "sliver floor aspect " + std::to_string(n) + ", view " + scale_name(theta) + " deg";
      Run rb = run(scene, cam, BSDFPathIntegrator{}, spec), rn = run(scene, cam, PathIntegrator{}, spec);
      Row bsdf = make_row(c, "BSDF-only RGB", rb, 1, rho, ref_px);
      bsdf.firefly_bound = 1 + rounding_allowance(1);  // every sample is rho
      bsdf.check();
      CHECK(pixels_within(rb.film, 1, rho, rho));
      make_row(c, "NEE+MIS RGB", rn, 1, rho, ref_px).check();
      check_deterministic(scene, cam, c);
    }
  }
}

TEST_CASE("coplanar overlapping triangles", "[stability][geometry][coplanar]") {
  // Two coplanar quads, albedo 0.2 on [-1, 1] x [-1, 1] and 0.8 on
  // [-0.5, 1.5] x [-1, 1], in one mesh or as two instances, in a uniform
  // environment of radiance 1: with BSDF sampling each sample is 0.2 or 0.8,
  // so every pixel is in [0.2, 0.8]; the image is deterministic.
  for (int layout = 0; layout < 2; ++layout) {
    Scene<RGB> scene;
    const Scene<RGB>::material_type dark = DiffuseMaterial{RGB(0.2f)};
    const Scene<RGB>::material_type light = DiffuseMaterial{RGB(0.8f)};
    uint32_t dm = scene.add_material(dark), lm = scene.add_material(light);
    TriangleMesh a, b;
    append_quad(a, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0});
    append_quad(b, {-0.5f, 0, -1}, {0, 0, 2}, {2, 0, 0});
    if (layout == 0) {
      scene.add_mesh_instance(std::move(a), dm);
      scene.add_mesh_instance(std::move(b), lm);
    } else {
      // One mesh (one material): the second quad's triangles interleave with
      // the first's in the BVH; both albedo 0.2 here, so the image is 0.2.
      TriangleMesh both = std::move(a);
      uint32_t base = uint32_t(both.positions.size());
      both.positions.insert(both.positions.end(), b.positions.begin(), b.positions.end());
      both.uvs.insert(both.uvs.end(), b.uvs.begin(), b.uvs.end());
      for (uint32_t i : b.indices) both.indices.push_back(base + i);
      scene.add_mesh_instance(std::move(both), dm);
    }
    scene.add_infinite_light(UniformInfiniteLight<RGB>(RGB(1.f)));
    scene.build();
    OrthographicCamera cam(look_at_camera_to_world({0.3f, 5, 0.2f}, {0, 0, 0}, {0, 0, -1}), 1.6f, 16, 16);
    RunSpec spec;
    spec.spp = 32;
    std::string c = layout == 0 ? "coplanar overlapping quads, two instances" : "coplanar overlapping quads, one mesh";
    Run rb = run(scene, cam, BSDFPathIntegrator{}, spec), rn = run(scene, cam, PathIntegrator{}, spec);
    // No single reference: the overlap shows either quad. Reported: the mean.
    const std::vector<double> top(256, layout == 0 ? 0.8 : 0.2);  // the brightest a pixel may be
    Row bsdf = make_row(c, "BSDF-only RGB", rb, 1, 0, top);
    bsdf.reference = bsdf.est.mean;
    bsdf.firefly_bound = 1 + rounding_allowance(1);  // no pixel above the brighter quad
    bsdf.note = "pixels in [0.2, 0.8] checked";
    bsdf.check(false);
    CHECK(pixels_within(rb.film, 1, 0.2, layout == 0 ? 0.8 : 0.2));
    Row nee = make_row(c, "NEE+MIS RGB", rn, 1, 0, top);
    nee.reference = bsdf.est.mean;
    nee.note = "reported only";
    nee.check(false);
    check_deterministic(scene, cam, c);
  }
}

}  // namespace geometry_stability_test
