// prism/integrators/path.hpp — unidirectional path tracing.
//
// PathIntegrator: next-event estimation (one light sample per non-specular
// vertex) and BSDF sampling, combined by multiple importance sampling with the
// power heuristic (Veach 1997, ch. 9), Russian roulette and a maximum depth.
// BSDFPathIntegrator: BSDF sampling only; emission is gathered only when a path
// hits a light. It is simpler and serves as the reference the MIS estimator
// must agree with.
// Both are unbiased for the same max_depth; both count the rays they trace.
//
// Caustics. A path that leaves the camera, meets a non-specular surface, then
// only specular ones (glass, mirrors) and ends on an area light is a caustic
// that next-event estimation cannot reach: BSDF sampling must hit the light
// through the specular chain, which is hopeless for small lights. When a scene
// has specular materials and area lights, PathIntegrator therefore leaves
// exactly those paths (camera - first vertex non-specular - one or more
// specular vertices - area light) to a light-tracing pass: paths start on the
// lights, follow specular scattering, and at the first non-specular vertex are
// joined to the camera and splatted onto the film (trace_caustic_path; the
// renderer runs it). The two sets of paths are disjoint and together cover
// every path, so the sum is unbiased; docs/caustics.md has the derivation.
// PathOptions::light_traced_caustics = false turns the split off.
//
// MIS on or off. PathOptions::mis = false (for comparisons, e.g. the
// convergence harness; the default is true) keeps next-event estimation but
// drops the weighting: a light sample counts in full, and emission that BSDF
// sampling hits after a non-specular vertex counts only when next-event
// estimation could not have sampled that point (light pmf x pdf_li = 0), so
// every path is still counted exactly once and the estimator stays unbiased.
//
// Both model IntegratorLike (integrators/integrator.hpp) for any SceneLike
// scene; PathIntegrator declares the caustic pass as a capability.
#pragma once
#include <algorithm>
#include <cstdint>
#include <optional>
#include <type_traits>
#include <variant>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/volume.hpp"
#include "prism/cameras/perspective.hpp"
#include "prism/film/aov.hpp"
#include "prism/integrators/integrator.hpp"
#include "prism/lights/light.hpp"
#include "prism/sampling/warps.hpp"

namespace prism {

struct PathOptions {
  int max_depth = 64;       // maximum number of scattering events
  int rr_min_depth = 1;     // Russian roulette from this depth on (0-based)
  bool light_traced_caustics = true;  // see the file comment
  bool mis = true;  // false: NEE without MIS weights (see the file comment)
};

namespace detail {

// What every path loop does at a vertex, written once.
//
// The weight of emission that BSDF sampling reached after a non-specular
// vertex, where next-event estimation could have sampled the same point
// with density p_light (light pmf x solid-angle pdf): the power heuristic;
// without MIS, all of it where a light sample cannot reach the point
// (p_light = 0) and none elsewhere (nullopt), so that every path counts once.
inline std::optional<Float> emission_weight(Float bsdf_pdf, Float p_light, bool mis) {
  if (mis) return power_heuristic(bsdf_pdf, p_light);
  if (!(p_light > 0)) return Float(1);
  return std::nullopt;
}
// The throughput after scattering into bs.wi: beta *= f |cos theta_i| / pdf.
template <class S>
void scatter(S& beta, const BSDFSample<S>& bs, const Normal3f& ns) {
  beta *= bs.f * (abs_dot(bs.wi, ns) / bs.pdf);
}
// Russian roulette on the path's continuation weight rr (the throughput's
// largest component, refraction's radiance scale removed for camera paths):
// below 1 the path survives with probability rr (u >= 1 - rr) and beta is
// divided by it. Returns false when the path ends.
template <class S>
bool russian_roulette(S& beta, Float rr, Float u) {
  if (!(rr < 1)) return true;
  Float q = std::max(Float(0), 1 - rr);
  if (u < q) return false;
  beta = beta / (1 - q);
  return true;
}

// Radiance emitted by the light a path hit at si towards wo.
template <class Scene, class W>
typename Scene::spectrum_type emitted(const Scene& scene, const SurfaceInteraction& si, const W& lambda) {
  using S = typename Scene::spectrum_type;
  if (si.area_light < 0) return S{};
  return std::visit(
      [&](const auto& l) -> S {
        if constexpr (SurfaceEmitter<std::decay_t<decltype(l)>, S>)
          return l.L(si, lambda);
        else
          return S{};
      },
      scene.lights()[size_t(si.area_light)]);
}

template <class Scene, class W>
typename Scene::spectrum_type escaped(const Scene& scene, const Ray& ray, const W& lambda, Float bsdf_pdf,
                                      bool weigh_by_mis, const LightSampleContext& prev, bool mis = true) {
  using S = typename Scene::spectrum_type;
  S L{};
  for (uint32_t idx : scene.infinite_lights()) {
    std::visit(
        [&](const auto& light) {
          if constexpr (EscapeEmitter<std::decay_t<decltype(light)>, S>) {
            S Le = light.Le(ray, lambda);
            if (Le.is_black()) return;
            if (!weigh_by_mis) {
              L += Le;
            } else {
              Float p_l = scene.light_pmf(prev, idx) * light.pdf_li(prev, ray.d, SurfaceInteraction{});
              if (auto w = emission_weight(bsdf_pdf, p_l, mis)) L += Le * *w;
            }
          }
        },
        scene.lights()[idx]);
  }
  return L;
}

// Continues a path by BSDF sampling: updates the throughput and eta scale,
// spawns the next ray, and plays Russian roulette on the throughput with the
// radiance scale of refraction removed (pbrt-v4 book, section 13.1.4). Returns
// the sample, or nullopt when the path ends.
template <class S, class BSDFT, class Sampler>
std::optional<BSDFSample<S>> continue_path(const BSDFT& bsdf, const SurfaceInteraction& si, int depth,
                                           const PathOptions& opt, Sampler& sampler, S& beta, Float& eta_scale,
                                           Ray& ray) {
  Float uc = sampler.get_1d();
  Point2f u = sampler.get_2d();
  auto bs = bsdf.sample(si.wo, uc, u);
  if (!bs) return std::nullopt;
  scatter(beta, *bs, si.ns);
  if (bs->is_transmission()) eta_scale *= sqr(bs->eta);
  ray = si.spawn_ray(bs->wi);
  Float u_rr = sampler.get_1d();
  if (depth >= opt.rr_min_depth && !russian_roulette(beta, beta.max_component() * eta_scale, u_rr))
    return std::nullopt;
  if (!beta.is_finite() || beta.is_black()) return std::nullopt;
  return bs;
}

// Absorbing interiors (bxdfs/volume.hpp): after a transmission, the path is
// inside the object if it left the surface against the geometric normal (which
// points out of closed meshes and spheres); the object's absorption then
// applies until the next transmission takes it out.
template <class Scene, class S, class W>
void update_medium(const Scene& scene, const SurfaceInteraction& si, const BSDFSample<S>& bs, const W& lambda,
                   std::optional<S>& sigma_a) {
  if (!bs.is_transmission()) return;
  if (dot(bs.wi, si.n) < 0)
    sigma_a = scene.interior_absorption(si, lambda);
  else
    sigma_a.reset();
}
// Attenuates beta over the segment from the ray's origin to si.
template <class S>
void attenuate(S& beta, const std::optional<S>& sigma_a, const Ray& ray, const SurfaceInteraction& si) {
  if (sigma_a) beta *= transmittance(*sigma_a, distance(ray.o, si.p));
}

}  // namespace detail

class PathIntegrator {
 public:
  static constexpr IntegratorCapability capabilities = IntegratorCapability::caustic_pass;
  PathIntegrator() = default;
  explicit PathIntegrator(PathOptions opt) : m_opt(opt) {}
  const PathOptions& options() const { return m_opt; }

  template <class Scene, class Sampler, class W>
  typename Scene::spectrum_type Li(const Scene& scene, Ray ray, W& lambda, Sampler& sampler,
                                   RayCounter& counter) const {
    using S = typename Scene::spectrum_type;
    S L{}, beta(1);
    bool specular_bounce = false;
    Float bsdf_pdf = 1, eta_scale = 1;
    LightSampleContext prev;
    // True while the path is camera - non-specular first vertex - specular
    // vertices only: its emission then belongs to the light-tracing pass.
    const bool split = caustics_active(scene);
    bool caustic_chain = false;
    std::optional<S> sigma_a;  // absorption of the object the path is inside, if any
    for (int depth = 0;; ++depth) {
      ++counter.rays;
      auto si = scene.intersect(ray);
      if (!si) {
        L += beta * detail::escaped(scene, ray, lambda, bsdf_pdf, depth > 0 && !specular_bounce, prev, m_opt.mis);
        break;
      }
      detail::attenuate(beta, sigma_a, ray, *si);
      // Emission hit by the path: weighed against the light sample that could
      // have found it at the previous vertex.
      S Le = detail::emitted(scene, *si, lambda);
      if (!Le.is_black() && !(caustic_chain && depth >= 2)) {
        if (depth == 0 || specular_bounce) {
          L += beta * Le;
        } else {
          const auto& light = scene.lights()[size_t(si->area_light)];
          Float p_l = scene.light_pmf(prev, uint32_t(si->area_light)) *
                      std::visit([&](const auto& l) { return Float(l.pdf_li(prev, ray.d, *si)); }, light);
          if (auto w = detail::emission_weight(bsdf_pdf, p_l, m_opt.mis)) L += beta * Le * *w;
        }
      }
      if (depth == m_opt.max_depth) break;

      auto bsdf = scene.bsdf(*si, lambda);
      BxDFFlags flags = bsdf.flags();
      if (!any(flags)) break;
      if (is_non_specular(flags)) L += beta * sample_light(scene, *si, bsdf, lambda, sampler, counter);
      else { sampler.get_1d(); sampler.get_2d(); }  // keep the dimension count per vertex fixed

      prev = LightSampleContext(*si);
      auto bs = detail::continue_path(bsdf, *si, depth, m_opt, sampler, beta, eta_scale, ray);
      if (!bs) break;
      detail::update_medium(scene, *si, *bs, lambda, sigma_a);
      bsdf_pdf = bs->pdf;
      specular_bounce = bs->is_specular();
      caustic_chain = split && (depth == 0 ? !specular_bounce : caustic_chain && specular_bounce);
    }
    return L;
  }

  // Whether this integrator leaves caustic paths to trace_caustic_path for
  // this scene (it does when the scene has specular materials and area lights).
  template <class Scene>
  bool caustics_active(const Scene& scene) const {
    return m_opt.light_traced_caustics && scene.has_specular() && scene.has_area_lights();
  }

  // One light path of the caustic pass: from a light through specular
  // vertices; at each later vertex with a non-specular part, a connection to
  // the camera, passed to splat(raster position, value in the film's encoding).
  // Uses TransportMode::importance along the path (the BxDFs' adjoint).
  template <class Scene, CameraLike Camera, class Sampler, class Splat>
  void trace_caustic_path(const Scene& scene, const Camera& camera, Sampler& sampler, RayCounter& counter,
                          Splat&& splat) const {
    using S = typename Scene::spectrum_type;
    using traits = spectrum_traits<S>;
    auto lambda = traits::sample_wavelengths(sampler.get_1d());
    auto sl = scene.area_light_sampler().sample(sampler.get_1d());
    Point2f u_pos = sampler.get_2d(), u_dir = sampler.get_2d();
    Float u_side = sampler.get_1d();
    // The path's time, when the camera's shutter is open for an interval.
    const Shutter sh = camera.shutter();
    const Float time = sh.is_open_interval() ? sh.time(sampler.get_1d()) : sh.open;
    if (!sl) return;
    auto le = std::visit(
        [&](const auto& l) -> std::optional<LightLeSample<S>> {
          if constexpr (LightPathEmitter<std::decay_t<decltype(l)>, S>)
            return l.sample_le(u_pos, u_dir, u_side, lambda);
          else
            return std::nullopt;
        },
        scene.lights()[sl->index]);
    if (!le || le->L.is_black()) return;
    S beta = le->L * (abs_dot(le->n, le->ray.d) / (sl->pmf * le->pdf_pos * le->pdf_dir));
    Ray ray = le->ray;
    ray.time = time;
    std::optional<S> sigma_a;
    for (int specular = 0; specular < m_opt.max_depth; ++specular) {
      ++counter.rays;
      auto si = scene.intersect(ray);
      if (!si) return;
      detail::attenuate(beta, sigma_a, ray, *si);
      auto bsdf = scene.bsdf(*si, lambda);
      BxDFFlags flags = bsdf.flags();
      if (!any(flags)) return;
      Point2f u_lens = sampler.get_2d();
      if (specular > 0 && is_non_specular(flags)) {
        if (auto cc = camera.connect(si->p, u_lens, time)) {
          Vector3f to_cam = cc->p_lens - si->p;
          Float d2 = length_squared(to_cam);
          Vector3f wc = to_cam / std::sqrt(d2);
          S f = d2 > 0 ? bsdf.eval(si->wo, wc, TransportMode::importance) : S{};
          if (!f.is_black()) {
            ++counter.rays;
            if (!scene.occluded(si->spawn_ray_to(cc->p_lens), 1)) {
              S v = beta * f * (abs_dot(wc, si->n) * cc->importance);
              splat(cc->p_raster, traits::to_film(v, lambda));
            }
          }
        }
      }
      // Continue only through a specular lobe: later non-specular vertices
      // belong to the camera paths.
      Float uc = sampler.get_1d();
      Point2f u = sampler.get_2d();
      auto bs = bsdf.sample(si->wo, uc, u, TransportMode::importance);
      if (!bs || !bs->is_specular()) return;
      detail::scatter(beta, *bs, si->ns);
      ray = si->spawn_ray(bs->wi);
      detail::update_medium(scene, *si, *bs, lambda, sigma_a);
      Float u_rr = sampler.get_1d();
      if (specular + 1 >= m_opt.rr_min_depth && !detail::russian_roulette(beta, beta.max_component(), u_rr)) return;
      if (!beta.is_finite() || beta.is_black()) return;
    }
  }

 private:
  template <class Scene, class Sampler, class W, class BSDFT>
  typename Scene::spectrum_type sample_light(const Scene& scene, const SurfaceInteraction& si, const BSDFT& bsdf,
                                             const W& lambda, Sampler& sampler, RayCounter& counter) const {
    using S = typename Scene::spectrum_type;
    Float ul = sampler.get_1d();
    Point2f u = sampler.get_2d();
    LightSampleContext ctx(si);
    auto sl = scene.sample_light(ctx, ul);
    if (!sl) return S{};
    const auto& light = scene.lights()[sl->index];
    auto ls = std::visit([&](const auto& l) { return l.sample_li(ctx, u, lambda); }, light);
    if (!ls || ls->L.is_black() || !(ls->pdf > 0)) return S{};
    S f = bsdf.eval(si.wo, ls->wi) * abs_dot(ls->wi, si.ns);
    if (f.is_black()) return S{};
    ++counter.rays;
    if (ls->infinite) {
      if (scene.occluded(si.spawn_ray(ls->wi), infinity)) return S{};
    } else {
      if (scene.occluded(si.spawn_ray_to(ls->p_light), 1, ls->instance, ls->primitive)) return S{};
    }
    Float p_l = sl->pmf * ls->pdf;
    LightKind kind = std::visit([](const auto& l) { return l.kind(); }, light);
    if (is_delta(kind)) return f * ls->L / p_l;
    Float w = m_opt.mis ? power_heuristic(p_l, bsdf.pdf(si.wo, ls->wi)) : Float(1);
    return f * ls->L * (w / p_l);
  }

  PathOptions m_opt;
};

class BSDFPathIntegrator {
 public:
  BSDFPathIntegrator() = default;
  explicit BSDFPathIntegrator(PathOptions opt) : m_opt(opt) {}
  const PathOptions& options() const { return m_opt; }

  template <class Scene, class Sampler, class W>
  typename Scene::spectrum_type Li(const Scene& scene, Ray ray, W& lambda, Sampler& sampler,
                                   RayCounter& counter) const {
    using S = typename Scene::spectrum_type;
    S L{}, beta(1);
    Float eta_scale = 1;
    std::optional<S> sigma_a;
    for (int depth = 0;; ++depth) {
      ++counter.rays;
      auto si = scene.intersect(ray);
      if (!si) {
        L += beta * detail::escaped(scene, ray, lambda, 1, false, LightSampleContext{});
        break;
      }
      detail::attenuate(beta, sigma_a, ray, *si);
      L += beta * detail::emitted(scene, *si, lambda);
      if (depth == m_opt.max_depth) break;
      auto bsdf = scene.bsdf(*si, lambda);
      if (!any(bsdf.flags())) break;
      auto bs = detail::continue_path(bsdf, *si, depth, m_opt, sampler, beta, eta_scale, ray);
      if (!bs) break;
      detail::update_medium(scene, *si, *bs, lambda, sigma_a);
    }
    return L;
  }

 private:
  PathOptions m_opt;
};

// The AOVs of one camera ray (film/aov.hpp): albedo, shading normal and depth
// of the first surface that is not purely specular, followed through up to
// `max_specular` mirror or glass bounces. `u()` returns uniform numbers from
// a stream of the caller's that the image's own samples do not use.
template <class Scene, class W, class U>
AovSample first_hit_aovs(const Scene& scene, Ray ray, const W& lambda, U&& u, int max_specular = 8) {
  using S = typename Scene::spectrum_type;
  using traits = spectrum_traits<S>;
  AovSample out;
  S throughput(1);
  for (int depth = 0; depth <= max_specular; ++depth) {
    auto si = scene.intersect(ray);
    if (!si) {
      // Escaped through mirrors or glass: what they pass on, else nothing.
      if (depth > 0) out.albedo = traits::to_film(throughput, lambda);
      return out;
    }
    if (depth == 0) out.depth = length(si->p - ray.o) / length(ray.d);
    auto bsdf = scene.bsdf(*si, lambda);
    BxDFFlags flags = bsdf.flags();
    Normal3f ns = dot(Vector3f(si->ns), si->wo) < 0 ? -si->ns : si->ns;
    Float uc = u();
    Float u0 = u();
    Point2f u2{u0, u()};
    if (!any(flags)) {  // no scattering (e.g. a black emitter): albedo 0
      out.normal = ns;
      return out;
    }
    auto bs = bsdf.sample(si->wo, uc, u2);
    if (!is_non_specular(flags) && depth < max_specular) {
      if (!bs || !(bs->pdf > 0)) return out;
      detail::scatter(throughput, *bs, si->ns);
      ray = si->spawn_ray(bs->wi);
      continue;
    }
    out.normal = ns;
    if (bs && bs->pdf > 0) out.albedo = traits::to_film(throughput * bs->f * (abs_dot(bs->wi, si->ns) / bs->pdf), lambda);
    return out;
  }
  return out;
}

}  // namespace prism
