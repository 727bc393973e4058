// prism/integrators/path.hpp — unidirectional path tracing.
//
// PathIntegrator: next-event estimation (one light sample per non-specular
// vertex) and BSDF sampling, combined by multiple importance sampling with the
// power heuristic (Veach 1997, ch. 9), Russian roulette and a maximum depth.
// BSDFPathIntegrator: BSDF sampling only; emission is gathered only when a path
// hits a light. It is simpler and serves as the reference the MIS estimator
// must agree with.
// Both are unbiased for the same max_depth; both count the rays they trace.
#pragma once
#include <cstdint>
#include "prism/lights/light.hpp"
#include "prism/sampling/warps.hpp"

namespace prism {

struct PathOptions {
  int max_depth = 64;       // maximum number of scattering events
  int rr_min_depth = 1;     // Russian roulette from this depth on (0-based)
};

struct RayCounter {
  uint64_t rays = 0;
};

namespace detail {

// Radiance emitted by the light a path hit at si towards wo.
template <class Scene, class W>
typename Scene::spectrum_type emitted(const Scene& scene, const SurfaceInteraction& si, const W& lambda) {
  using S = typename Scene::spectrum_type;
  if (si.area_light < 0) return S{};
  return std::visit(
      [&](const auto& l) -> S {
        if constexpr (requires { l.L(si.n, si.wo, lambda); })
          return l.L(si.n, si.wo, lambda);
        else
          return S{};
      },
      scene.lights()[size_t(si.area_light)]);
}

template <class Scene, class W>
typename Scene::spectrum_type escaped(const Scene& scene, const Ray& ray, const W& lambda, Float bsdf_pdf,
                                      bool weigh_by_mis, const LightSampleContext& prev) {
  using S = typename Scene::spectrum_type;
  S L{};
  for (uint32_t idx : scene.infinite_lights()) {
    const auto& light = std::get<UniformInfiniteLight<S>>(scene.lights()[idx]);
    S Le = light.Le(ray, lambda);
    if (!weigh_by_mis) {
      L += Le;
    } else {
      Float p_l = scene.light_sampler().pmf(idx) * light.pdf_li(prev, ray.d, SurfaceInteraction{});
      L += Le * power_heuristic(bsdf_pdf, p_l);
    }
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
  beta *= bs->f * (abs_dot(bs->wi, si.ns) / bs->pdf);
  if (bs->is_transmission()) eta_scale *= sqr(bs->eta);
  ray = si.spawn_ray(bs->wi);
  Float rr = beta.max_component() * eta_scale;
  Float u_rr = sampler.get_1d();
  if (depth >= opt.rr_min_depth && rr < 1) {
    Float q = std::max(Float(0), 1 - rr);
    if (u_rr < q) return std::nullopt;
    beta = beta / (1 - q);
  }
  if (!beta.is_finite() || beta.is_black()) return std::nullopt;
  return bs;
}

}  // namespace detail

class PathIntegrator {
 public:
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
    for (int depth = 0;; ++depth) {
      ++counter.rays;
      auto si = scene.intersect(ray);
      if (!si) {
        L += beta * detail::escaped(scene, ray, lambda, bsdf_pdf, depth > 0 && !specular_bounce, prev);
        break;
      }
      // Emission hit by the path: weighed against the light sample that could
      // have found it at the previous vertex.
      S Le = detail::emitted(scene, *si, lambda);
      if (!Le.is_black()) {
        if (depth == 0 || specular_bounce) {
          L += beta * Le;
        } else {
          const auto& light = scene.lights()[size_t(si->area_light)];
          Float p_l = scene.light_sampler().pmf(uint32_t(si->area_light)) *
                      std::visit([&](const auto& l) { return Float(l.pdf_li(prev, ray.d, *si)); }, light);
          L += beta * Le * power_heuristic(bsdf_pdf, p_l);
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
      bsdf_pdf = bs->pdf;
      specular_bounce = bs->is_specular();
    }
    return L;
  }

 private:
  template <class Scene, class Sampler, class W, class BSDFT>
  typename Scene::spectrum_type sample_light(const Scene& scene, const SurfaceInteraction& si, const BSDFT& bsdf,
                                             const W& lambda, Sampler& sampler, RayCounter& counter) const {
    using S = typename Scene::spectrum_type;
    Float ul = sampler.get_1d();
    Point2f u = sampler.get_2d();
    auto sl = scene.light_sampler().sample(ul);
    if (!sl) return S{};
    LightSampleContext ctx(si);
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
    Float w = power_heuristic(p_l, bsdf.pdf(si.wo, ls->wi));
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
    for (int depth = 0;; ++depth) {
      ++counter.rays;
      auto si = scene.intersect(ray);
      if (!si) {
        L += beta * detail::escaped(scene, ray, lambda, 1, false, LightSampleContext{});
        break;
      }
      L += beta * detail::emitted(scene, *si, lambda);
      if (depth == m_opt.max_depth) break;
      auto bsdf = scene.bsdf(*si, lambda);
      if (!any(bsdf.flags())) break;
      if (!detail::continue_path(bsdf, *si, depth, m_opt, sampler, beta, eta_scale, ray)) break;
    }
    return L;
  }

 private:
  PathOptions m_opt;
};

}  // namespace prism
