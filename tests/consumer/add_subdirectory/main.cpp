// A consumer of prism through add_subdirectory: a one-triangle scene, instanced
// under a transform, must be hit where expected and missed beside it.
// Returns non-zero on a wrong result.
#include <cmath>
#include <cstdio>
#include "prism/accel/scene_accel.hpp"
#include "prism/math/transform.hpp"

int main() {
  using namespace prism;
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2};

  SceneAccel scene;
  uint32_t m = scene.add_mesh(mesh);
  // The triangle lies in z = 0 in object space; place it at z = 5.
  scene.add_mesh_instance(m, translate(Vector3f{0, 0, 5}));
  scene.build();

  int failures = 0;
  auto h = scene.intersect(Ray{Point3f{0.25f, 0.25f, 0}, Vector3f{0, 0, 1}});
  if (!h || std::abs(h->t - 5) > 1e-4f || std::abs(h->b0 + h->b1 + h->b2 - 1) > 1e-4f) {
    std::printf("expected a hit at t = 5, got %s t = %g\n", h ? "a hit at" : "a miss", h ? double(h->t) : 0.0);
    ++failures;
  }
  if (scene.intersect(Ray{Point3f{2, 2, 0}, Vector3f{0, 0, 1}})) {
    std::printf("expected a miss beside the triangle\n");
    ++failures;
  }
  Point3f p = translate(Vector3f{1, 2, 3})(Point3f{1, 1, 1});
  if (!(p == Point3f{2, 3, 4})) {
    std::printf("translate gave (%g, %g, %g)\n", double(p.x), double(p.y), double(p.z));
    ++failures;
  }
  if (failures == 0) std::printf("prism consumer: ok\n");
  return failures;
}
