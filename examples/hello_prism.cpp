// hello_prism: build a scene in code and render it with prism.
#include <cstdio>
#include <prism/prism.hpp>
#include <prism/io/image_io.hpp>

int main() {
  using namespace prism;
  Scene<RGB> scene;  // RGB colour model, the default BxDF set (diffuse)

  // Materials are parameter sets of the BxDFs in the scene's set.
  uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.8f)});
  uint32_t orange = scene.add_material(DiffuseMaterial{RGB(0.9f, 0.4f, 0.1f)});

  // A floor (two triangles) and a sphere on it.
  TriangleMesh floor;
  append_quad(floor, {-4, 0, 4}, {8, 0, 0}, {0, 0, -8});
  scene.add_mesh_instance(std::move(floor), grey);
  scene.add_sphere(Sphere{{0, 1, 0}, 1}, orange);

  // A spherical area light and a dim blue sky.
  scene.add_sphere(Sphere{{-3, 5, 3}, 0.7f}, grey, AreaEmission{RGB(30.f)});
  scene.add_infinite_light(UniformInfiniteLight<RGB>(RGB(0.2f, 0.3f, 0.5f)));
  scene.build();

  const int width = 320, height = 240;
  PerspectiveCamera camera(look_at_camera_to_world({0, 2, 6}, {0, 0.8f, 0}, {0, 1, 0}), radians(40), width, height);
  Film film(width, height);
  RenderOptions options;
  options.spp = 64;
  RenderStats stats = render(scene, camera, PathIntegrator{}, film, options);

  write_png("hello.png", to_image(film));
  std::printf("wrote hello.png in %.2f s (%.2f M rays/s)\n", stats.seconds, double(stats.rays) / stats.seconds * 1e-6);
}
