// The pixel footprint for texture filtering (cameras/footprint.hpp) against
// closed forms: a perspective camera's pixel on a plane facing it is d s_x
// wide at distance d (s_x = 2 tan(fov/2) aspect / W, the pixel on the image
// plane at distance 1), on a plane tilted by theta about y the shifted ray
// meets it at t = d / (1 - s_x tan(theta)); an orthographic pixel is the
// window's width over W, stretched by the tilt to (s_x, 0, s_x tan(theta));
// the spp scale max(1/8, 1/sqrt(spp)); uv_footprint's least squares.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/cameras/footprint.hpp>

namespace footprint_test {

using namespace prism;

namespace {
// A camera at the origin looking down +z (right-handed look-at: x to the left).
const Transform view = look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0});
double len(const Vector3f& v) { return std::sqrt(double(length_squared(v))); }
}  // namespace

TEST_CASE("a perspective pixel's footprint on facing and tilted planes", "[cameras][footprint]") {
  const int W = 200, H = 100;
  const Float fov = 0.8f;
  PerspectiveCamera cam(view, fov, W, H);
  PixelFootprint fp(cam, 1);
  REQUIRE(fp.active());
  CHECK(fp.scale() == 1);
  const double sx = 2 * std::tan(0.4) * 2.0 / W, sy = 2 * std::tan(0.4) / H;
  for (double d : {1.0, 3.0, 10.0})
    for (Point3f p : {Point3f(0, 0, Float(d)), Point3f(0.3f, -0.2f, Float(d))}) {
      Vector3f dx, dy;
      fp.dp(p, Normal3f(0, 0, -1), &dx, &dy);
      INFO("distance " << d << " point " << p.x << " " << p.y);
      // 1e-5 relative: a few float roundings of values of order 1
      CHECK(len(dx) == Approx(d * sx).epsilon(1e-5));
      CHECK(len(dy) == Approx(d * sy).epsilon(1e-5));
      CHECK(std::abs(dx.z) <= 1e-6 * d);
    }
  // Tilted by theta about y, through (0, 0, d): along x the shifted ray
  // (s_x, 0, 1) meets n . (x - p) = 0 at t = d / (1 - s_x tan(theta)) (its
  // x in the camera's frame, which look_at mirrors in the world's).
  for (double theta : {0.5, 1.2, 1.5}) {
    const double d = 4;
    Normal3f n(Float(std::sin(theta)), 0, Float(-std::cos(theta)));
    Vector3f dx, dy;
    fp.dp(Point3f(0, 0, Float(d)), n, &dx, &dy);
    const Vector3f cx = inverse(view)(dx);  // camera space
    const double t_plus = d / (1 - sx * std::tan(theta)), t_minus = d / (1 + sx * std::tan(theta));
    const double want_plus = std::hypot(t_plus * sx, t_plus - d), want_minus = std::hypot(t_minus * sx, t_minus - d);
    INFO("theta " << theta << ": " << len(cx) << " vs " << want_plus << " or " << want_minus);
    // The camera's x may point either way along the world's: one of the two.
    CHECK((std::abs(len(cx) - want_plus) <= 1e-3 * want_plus || std::abs(len(cx) - want_minus) <= 1e-3 * want_minus));
    CHECK(len(cx) >= 0.99 * d * sx / std::cos(theta) * (1 - sx * std::tan(theta)));
  }
  // Behind the eye or on a plane the shifted ray runs along: zero.
  Vector3f dx, dy;
  fp.dp(Point3f(0, 0, -2), Normal3f(0, 0, 1), &dx, &dy);
  CHECK(len(dx) == 0);
  // The spp scale.
  CHECK(PixelFootprint(cam, 16).scale() == 0.25f);
  CHECK(PixelFootprint(cam, 4096).scale() == 0.125f);
  CHECK_FALSE(PixelFootprint().active());
}

TEST_CASE("an orthographic pixel's footprint is its window width, stretched by the tilt", "[cameras][footprint]") {
  OrthographicCamera cam(view, 2, 64, 32);  // window 4 x 2
  PixelFootprint fp(cam, 1);
  const double sx = 4.0 / 64;
  for (double theta : {0.0, 0.7, 1.3}) {
    Normal3f n(Float(std::sin(theta)), 0, Float(-std::cos(theta)));
    Vector3f dx, dy;
    fp.dp(Point3f(0.5f, 0.2f, 7), n, &dx, &dy);
    INFO("theta " << theta);
    CHECK(len(dx) == Approx(sx / std::cos(theta)).epsilon(1e-5));
    CHECK(len(dy) == Approx(2.0 / 32).epsilon(1e-5));
  }
}

// dp = dp/du du + dp/dv dv solved by least squares: exact for dp in the
// plane of dp/du, dp/dv (here skewed and of different lengths), and the
// component out of the plane is ignored.
TEST_CASE("uv footprints solve dp = dpdu du + dpdv dv", "[cameras][footprint]") {
  const Vector3f dpdu(2, 0, 0), dpdv(1, 3, 0);
  const Vector3f dpdx = dpdu * 0.25f + dpdv * -0.5f, dpdy = dpdu * 0.125f + dpdv * 0.75f + Vector3f(0, 0, 5);
  TextureFootprint f = uv_footprint(dpdx, dpdy, dpdu, dpdv);
  CHECK(f.dudx == Approx(0.25f).margin(1e-6));
  CHECK(f.dvdx == Approx(-0.5f).margin(1e-6));
  CHECK(f.dudy == Approx(0.125f).margin(1e-6));
  CHECK(f.dvdy == Approx(0.75f).margin(1e-6));
  TextureFootprint z = uv_footprint(dpdx, dpdy, dpdu, dpdu * 2.f);  // degenerate
  CHECK((z.dudx == 0 && z.dvdx == 0 && z.dudy == 0 && z.dvdy == 0));
}

}  // namespace footprint_test
