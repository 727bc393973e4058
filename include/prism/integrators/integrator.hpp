// prism/integrators/integrator.hpp — the two seams of the integrator layer.
//
// SceneLike: what an integrator may ask of a scene. prism's Scene<S, Set>
// (render/scene.hpp) models it; a user's own scene type may too.
//   spectrum_type                       the colour type S (RGB or SampledSpectrum<N>)
//   intersect(ray[, t_max])             the closest surface: optional<SurfaceInteraction>
//   occluded(ray, t_max[, inst, prim])  any surface before t_max, ignoring that primitive
//   bsdf(si, lambda)                    the BSDF at a hit (flags, eval, pdf, sample)
//   interior_absorption(si, lambda)     the absorbing interior behind a surface, if any
//   lights(), infinite_lights()         the lights (variants of LightLike types) and
//                                       the indices of those an escaping ray sees
//   sample_light(ctx, u), light_pmf(ctx, i)  next-event light selection
//   area_light_sampler()                where light paths start (by power)
//   has_specular(), has_area_lights()   what decides whether caustics are light traced
//
// IntegratorLike: what render() asks of an integrator: Li(scene, ray, lambda,
// sampler, counter), the radiance along a camera ray. Anything more is a
// CAPABILITY the integrator declares in `capabilities`:
//
//   static constexpr IntegratorCapability capabilities = IntegratorCapability::caustic_pass;
//
//   caustic_pass  bool caustics_active(const Scene&) const and
//                 void trace_caustic_path(scene, camera, sampler, counter, splat) const:
//                 render() runs a light-tracing pass and splats its paths (path.hpp);
//   aovs          AovSample aovs(scene, ray, lambda, u) const: the integrator's own
//                 albedo, normal and depth for RenderOptions::aovs; without it,
//                 render() uses first_hit_aovs (film/aov.hpp's default meaning).
//
// As with BxDF hooks (bxdfs/hooks.hpp), a declared capability whose members
// are missing, and a capability member that is not declared, are compile
// errors naming the capability: nothing is discovered by probing.
#pragma once
#include <concepts>
#include <cstdint>
#include <optional>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/film/aov.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/lights/light.hpp"
#include "prism/lights/light_sampler.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

// Rays an integrator traced, for RenderStats.
struct RayCounter {
  uint64_t rays = 0;
};

template <class Sc>
concept SceneLike =
    Spectrum<typename Sc::spectrum_type> &&
    requires(const Sc& sc, const Ray& ray, Float t, uint32_t i, const SurfaceInteraction& si,
             const LightSampleContext& ctx, wavelengths_t<typename Sc::spectrum_type>& lambda) {
      { sc.intersect(ray) } -> std::same_as<std::optional<SurfaceInteraction>>;
      { sc.intersect(ray, t) } -> std::same_as<std::optional<SurfaceInteraction>>;
      { sc.occluded(ray, t) } -> std::convertible_to<bool>;
      { sc.occluded(ray, t, i, i) } -> std::convertible_to<bool>;
      { sc.bsdf(si, lambda).flags() } -> std::same_as<BxDFFlags>;
      { sc.interior_absorption(si, lambda) } -> std::same_as<std::optional<typename Sc::spectrum_type>>;
      { sc.has_specular() } -> std::convertible_to<bool>;
      { sc.has_area_lights() } -> std::convertible_to<bool>;
      sc.lights()[i];
      { sc.infinite_lights()[i] } -> std::convertible_to<uint32_t>;
      { sc.sample_light(ctx, t) } -> std::same_as<std::optional<SampledLight>>;
      { sc.light_pmf(ctx, i) } -> std::convertible_to<Float>;
      { sc.area_light_sampler().sample(t) } -> std::same_as<std::optional<SampledLight>>;
    };

enum class IntegratorCapability : uint32_t { none = 0, caustic_pass = 1u << 0, aovs = 1u << 1 };
constexpr IntegratorCapability operator|(IntegratorCapability a, IntegratorCapability b) {
  return IntegratorCapability(uint32_t(a) | uint32_t(b));
}
constexpr bool declares(IntegratorCapability set, IntegratorCapability c) { return (uint32_t(set) & uint32_t(c)) != 0; }

// The capabilities an integrator type declares (none when it declares no
// `capabilities` member), checked against the members it has.
template <class I>
struct integrator_capabilities {
  static constexpr IntegratorCapability declared = [] {
    if constexpr (requires { I::capabilities; })
      return IntegratorCapability(I::capabilities);
    else
      return IntegratorCapability::none;
  }();
  static constexpr bool caustic_pass = declares(declared, IntegratorCapability::caustic_pass);
  static constexpr bool aovs = declares(declared, IntegratorCapability::aovs);

 private:
  static constexpr bool has_caustic_members = requires { &I::template caustics_active<int>; } ||
                                              requires { &I::caustics_active; } ||
                                              requires { &I::template trace_caustic_path<int, int, int, int>; };
  static constexpr bool has_aov_members = requires { &I::aovs; } || requires { &I::template aovs<int, int, int>; };
  static_assert(caustic_pass || !has_caustic_members,
                "the integrator has caustics_active/trace_caustic_path but does not declare "
                "IntegratorCapability::caustic_pass in `capabilities`");
  static_assert(aovs || !has_aov_members,
                "the integrator has a member 'aovs' but does not declare IntegratorCapability::aovs in `capabilities`");
};

// What render() needs of an integrator for a scene and a sampler type.
template <class I, class Sc, class Sampler>
concept IntegratorLike =
    SceneLike<Sc> && requires(const I& integrator, const Sc& sc, Ray ray,
                              wavelengths_t<typename Sc::spectrum_type>& lambda, Sampler& sampler, RayCounter& c) {
      { integrator.Li(sc, ray, lambda, sampler, c) } -> std::same_as<typename Sc::spectrum_type>;
    };

// The members a declared caustic pass must have, for a scene, camera and sampler.
template <class I, class Sc, class Camera, class Sampler>
concept CausticPassIntegrator = requires(const I& integrator, const Sc& sc, const Camera& camera, Sampler& sampler,
                                         RayCounter& c) {
  { integrator.caustics_active(sc) } -> std::convertible_to<bool>;
  integrator.trace_caustic_path(sc, camera, sampler, c, [](Point2f, const RGB&) {});
};

// The member a declared AOV capability must have (u: uniform numbers).
template <class I, class Sc>
concept AovIntegrator = requires(const I& integrator, const Sc& sc, Ray ray,
                                 const wavelengths_t<typename Sc::spectrum_type>& lambda, Float (*u)()) {
  { integrator.aovs(sc, ray, lambda, u) } -> std::same_as<AovSample>;
};

}  // namespace prism
