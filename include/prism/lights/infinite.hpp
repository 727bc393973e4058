// prism/lights/infinite.hpp — a uniform infinite light: radiance Le from every
// direction, sampled uniformly over the sphere (pdf 1/(4 pi) per solid angle).
#pragma once
#include "prism/lights/light.hpp"
#include "prism/sampling/warps.hpp"

namespace prism {

template <class S>
class UniformInfiniteLight {
 public:
  explicit UniformInfiniteLight(const RGB& radiance, Float scale = 1) : m_radiance(radiance * scale) {}

  LightKind kind() const { return LightKind::infinite; }

  // Radiance arriving along a ray that escapes the scene.
  template <class W>
  S Le(const Ray&, const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_radiance, lambda);
  }

  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext&, Point2f u, const W& lambda) const {
    Vector3f wi = sample_uniform_sphere(u);
    return LightLiSample<S>{spectrum_traits<S>::illuminant(m_radiance, lambda), wi, pdf_uniform_sphere(), {}, true};
  }
  Float pdf_li(const LightSampleContext&, const Vector3f&, const SurfaceInteraction&) const {
    return pdf_uniform_sphere();
  }

  // Power through a disk of the scene's bounding radius.
  void set_scene_radius(Float r) { m_scene_radius = r; }
  template <class W>
  S power(const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_radiance, lambda) * (4 * pi * pi * sqr(m_scene_radius));
  }

 private:
  RGB m_radiance;
  Float m_scene_radius = 1;
};

}  // namespace prism
