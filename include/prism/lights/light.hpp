// prism/lights/light.hpp — what lights share: the context a light is sampled
// from, the record a light sample returns, and the light family's concept.
// Densities: sample_li returns a pdf per unit SOLID ANGLE at the receiving point
// (area samples are converted by distance^2 / |cos theta_light|), except for
// delta lights, whose pdf is 1 and which MIS never weighs.
#pragma once
#include <concepts>
#include <optional>
#include "prism/geometry/interaction.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

struct LightSampleContext {
  Point3f p;
  Vector3f p_error;
  Normal3f n;   // geometric normal
  Normal3f ns;  // shading normal
  Float time = 0;

  LightSampleContext() = default;
  explicit LightSampleContext(const SurfaceInteraction& si)
      : p(si.p), p_error(si.p_error), n(si.n), ns(si.ns), time(si.time) {}
};

enum class LightKind : uint8_t { area, infinite, delta_position, delta_direction };
constexpr bool is_delta(LightKind k) { return k == LightKind::delta_position || k == LightKind::delta_direction; }

template <class S>
struct LightLiSample {
  S L;              // emitted radiance arriving along -wi
  Vector3f wi;      // unit direction from the receiver towards the light
  Float pdf = 0;    // solid angle at the receiver (1 for delta lights)
  Point3f p_light;  // the sampled point, offset off the light's surface; unused when infinite
  bool infinite = false;
  uint32_t instance = UINT32_MAX, primitive = UINT32_MAX;  // the surface sampled, for shadow rays
};

// A ray leaving a light, for tracing paths from the lights (light tracing):
// L is the radiance along the ray, pdf_pos the area density of its origin and
// pdf_dir the solid-angle density of its direction.
template <class S>
struct LightLeSample {
  S L;
  Ray ray;
  Normal3f n;  // the light's surface normal at the origin (on the emitting side)
  Float pdf_pos = 0, pdf_dir = 0;
  uint32_t instance = UINT32_MAX, primitive = UINT32_MAX;
};

// What every light provides: its kind, a sample towards a receiving point
// with the sample's solid-angle density, and its power (for light selection).
template <class L, class S>
concept LightLike = requires(const L& l, const LightSampleContext& ctx, Point2f u, Vector3f w, wavelengths_t<S> lambda,
                             SurfaceInteraction si, Ray ray) {
  { l.kind() } -> std::same_as<LightKind>;
  { l.sample_li(ctx, u, lambda) } -> std::same_as<std::optional<LightLiSample<S>>>;
  { l.pdf_li(ctx, w, si) } -> std::convertible_to<Float>;
  { l.power(lambda) } -> std::same_as<S>;
};

// What some lights provide besides, each a named concept that the scene and
// the integrators test (lights/light_set.hpp checks them against the kind):
// a surface that paths can hit and that emits there (area lights),
template <class L, class S>
concept SurfaceEmitter = LightLike<L, S> && requires(const L& l, const SurfaceInteraction& si, wavelengths_t<S> lambda) {
  { l.L(si, lambda) } -> std::same_as<S>;
};
// radiance that a ray escaping the scene sees (environments, the sun),
template <class L, class S>
concept EscapeEmitter = LightLike<L, S> && requires(const L& l, const Ray& ray, wavelengths_t<S> lambda) {
  { l.Le(ray, lambda) } -> std::same_as<S>;
};
// rays leaving the light, where light paths start (area lights),
template <class L, class S>
concept LightPathEmitter = LightLike<L, S> && requires(const L& l, Point2f u, Float uc, wavelengths_t<S> lambda) {
  { l.sample_le(u, u, uc, lambda) } -> std::same_as<std::optional<LightLeSample<S>>>;
};
// and a light that needs the scene's bounding radius before rendering
// (Scene::build passes it: lights at infinity, distant lights).
template <class L>
concept SceneSizedLight = requires(L& l, Float radius) { l.set_scene_radius(radius); };

}  // namespace prism
