// custom_integrator: an ambient-occlusion integrator written in user code
// against prism's seams alone (SceneLike, IntegratorLike; integrators/
// integrator.hpp), rendered with prism's render() on the default Cornell box.
// Usage: custom_integrator [out.pfm] [spp]
#include <cstdio>
#include <cstdlib>
#include <prism/prism.hpp>
#include <prism/io/image_io.hpp>

namespace user {
using namespace prism;

// The fraction of the hemisphere above the first hit that is open to a
// distance `radius`, weighted by the cosine: cosine-weighted directions, one
// shadow ray each, so a sample is 0 or 1 and its mean is the AO value.
class AmbientOcclusion {
 public:
  explicit AmbientOcclusion(Float radius) : m_radius(radius) {}

  // IntegratorLike asks for Li; this integrator declares no capability
  // (no caustic pass, AOVs by render()'s default), so it has no
  // `capabilities` member.
  template <SceneLike Sc, class W, class Sampler>
  typename Sc::spectrum_type Li(const Sc& scene, Ray ray, W& /*lambda*/, Sampler& sampler,
                                RayCounter& counter) const {
    using S = typename Sc::spectrum_type;
    ++counter.rays;
    std::optional<SurfaceInteraction> si = scene.intersect(ray);
    if (!si) return S{};
    // The side of the surface the ray arrived on.
    Vector3f n(si->n);
    if (dot(n, si->wo) < 0) n = -n;
    Vector3f w = Frame::from_z(n).from_local(sample_cosine_hemisphere(sampler.get_2d()));
    ++counter.rays;
    return scene.occluded(si->spawn_ray(w), m_radius) ? S{} : S(1);
  }

 private:
  Float m_radius;
};

}  // namespace user

int main(int argc, char** argv) {
  using namespace prism;
  const char* out = argc > 1 ? argv[1] : "ao.pfm";
  const int spp = argc > 2 ? std::atoi(argv[2]) : 64;
  if (spp < 1) {
    std::fprintf(stderr, "custom_integrator: spp must be a positive integer, got '%s'\n", argv[2]);
    return 1;
  }
  Scene<RGB> scene;
  build_cornell_box(scene);
  scene.build();
  const int width = 128, height = 128;
  PerspectiveCamera camera = default_camera(width, height);
  Film film(width, height);
  RenderOptions options;
  options.spp = spp;
  options.sampler = SamplerKind::sobol;
  static_assert(IntegratorLike<user::AmbientOcclusion, Scene<RGB>, SobolSampler>);
  RenderStats stats = render(scene, camera, user::AmbientOcclusion(0.5f), film, options);
  write_pfm(out, to_image(film));
  std::printf("wrote %s: %d x %d, %d spp, %.2f s, %llu rays\n", out, width, height, spp, stats.seconds,
              static_cast<unsigned long long>(stats.rays));
}
