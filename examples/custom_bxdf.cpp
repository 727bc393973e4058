// custom_bxdf: render a BxDF that prism does not ship. examples/oren_nayar.hpp
// defines example::OrenNayarBxDF (rough diffuse reflection), its material and
// its prism::bxdf_traits specialisation; here a scene is instantiated with
// prism's default BxDF set extended by it, and renders it next to prism's
// own Lambertian BxDF. Lit from behind the camera, the rough spheres look
// flatter (less darkening towards the silhouette), as the Moon does.
#include <cstdio>
#include <prism/io/image_io.hpp>
#include <prism/prism.hpp>
#include "oren_nayar.hpp"

int main() {
  using namespace prism;
  using S = RGB;
  // The default set (diffuse, dielectric, conductor, thin dielectric) plus the user's BxDF.
  using Set = default_bxdf_set<S>::with<example::OrenNayarBxDF<S>>;
  Scene<S, Set> scene;

  const RGB clay(0.8f, 0.45f, 0.3f);
  uint32_t floor_m = scene.add_material(DiffuseMaterial{RGB(0.5f)});
  uint32_t lambert = scene.add_material(DiffuseMaterial{clay});
  uint32_t rough = scene.add_material(example::OrenNayarMaterial{clay, 0.5f, "clay, sigma 0.5"});
  uint32_t rougher = scene.add_material(example::OrenNayarMaterial{clay, 1.0f, "clay, sigma 1"});
  uint32_t black = scene.add_material(DiffuseMaterial{RGB(0.f)});

  TriangleMesh floor;
  append_quad(floor, {-6, 0, 4}, {12, 0, 0}, {0, 0, -10});
  scene.add_mesh_instance(std::move(floor), floor_m);
  scene.add_sphere(Sphere{{-2.2f, 1, 0}, 1}, lambert);
  scene.add_sphere(Sphere{{0, 1, 0}, 1}, rough);
  scene.add_sphere(Sphere{{2.2f, 1, 0}, 1}, rougher);
  // A large lamp behind and above the camera, facing the spheres, and a dim sky.
  TriangleMesh lamp;
  append_quad(lamp, {-2, 2.5f, 9}, {0, 2.5f, 0}, {4, 0, 0});  // normal -z
  scene.add_mesh_instance(std::move(lamp), black, AreaEmission{RGB(6.f)});
  scene.add_infinite_light(UniformInfiniteLight<S>(RGB(0.05f, 0.07f, 0.1f)));
  scene.build();  // validates every material, the user's included

  const int width = 320, height = 160;
  PerspectiveCamera camera(look_at_camera_to_world({0, 1.6f, 7}, {0, 0.9f, 0}, {0, 1, 0}), radians(36), width,
                           height);
  Film film(width, height);
  RenderOptions options;
  options.spp = 64;
  RenderStats stats = render(scene, camera, PathIntegrator{}, film, options);

  write_png("custom_bxdf.png", to_image(film));
  std::printf("wrote custom_bxdf.png in %.2f s: Lambert, Oren-Nayar sigma 0.5 and 1 (%s BxDF from user code)\n",
              stats.seconds, std::string(bxdf_traits<example::OrenNayarBxDF<S>>::name).c_str());
}
