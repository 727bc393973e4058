// prism/render/render.hpp — the parallel tile driver. The image is cut into
// tiles that threads take from a shared counter; each pixel belongs to one
// tile, and its samples run in order with random numbers that depend only on
// the pixel, the sample index and the seed. The image is therefore the same
// whatever the thread count. A non-finite sample is dropped and counted.
// With RenderOptions::adaptive_target set, render() samples adaptively
// (render_adaptive below, docs/adaptive.md): rounds of samples go to the
// pixels whose estimated relative error is still above the target.
#pragma once
#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <functional>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>
#include "prism/cameras/orthographic.hpp"
#include "prism/cameras/perspective.hpp"
#include "prism/film/film.hpp"
#include "prism/film/filter.hpp"
#include "prism/integrators/path.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/sobol.hpp"
#include "prism/sampling/stratified.hpp"

namespace prism {

// Where a pixel sample's numbers come from (sampling/*.hpp, docs/samplers.md).
enum class SamplerKind { independent, stratified, sobol };

struct RenderOptions {
  int spp = 16;
  uint64_t seed = 0;
  SamplerKind sampler = SamplerKind::independent;
  int threads = 0;       // 0 = all hardware threads
  int tile_size = 16;
  // Called from worker threads (serialised) after each unit of work (a tile,
  // or a chunk of the caustic pass): units done, total (tiles + chunks).
  std::function<void(int, int)> progress;
  const std::atomic<bool>* cancel = nullptr;  // set to stop early
  // When set, also filled with albedo, normal and depth per pixel (the same
  // size as the film; film/aov.hpp). Costs one more ray per camera sample.
  AovFilm* aovs = nullptr;
  // A share of the work, for splitting one image among processes
  // (render/mpi.hpp) or passes. Only samples [first_sample, first_sample +
  // sample_count) of each pixel are taken (-1: up to spp); the sample index
  // stays global, so its random numbers are those of the whole render, and
  // the films of disjoint shares merge (Film::merge) into the whole render's
  // up to summation order. Likewise only tiles t with t % tile_stride ==
  // tile_offset are rendered. The caustic pass is split the same way: the
  // light paths of those samples, and of those chunks of 4096 paths.
  int first_sample = 0;
  int sample_count = -1;
  int tile_stride = 1;
  int tile_offset = 0;
  // Adaptive sampling (docs/adaptive.md), on when adaptive_target > 0: every
  // pixel first takes adaptive_min_spp samples, then rounds of samples go to
  // the pixels whose estimated relative error (the standard error of the
  // mean of the three channels over that mean, floored at adaptive_floor;
  // the per-sample relative variance taken as the largest of the 3x3
  // neighbourhood's: adaptive_errors below)
  // exceeds adaptive_target, until none does or they reach spp, which is then
  // the most samples any pixel takes. Sample i of a pixel has the same random
  // numbers as in a uniform render, so a pixel that took n samples holds the
  // uniform n-spp value. Not combined with first_sample/sample_count or
  // tile_stride (splitting among processes): render() rejects that.
  double adaptive_target = 0;
  int adaptive_min_spp = 16;
  double adaptive_floor = 1e-2;
  // When set (adaptive only), filled with each pixel's sample count (w h,
  // row-major). The progress callback reports each round's tiles anew.
  std::vector<uint32_t>* adaptive_counts = nullptr;
};

struct RenderStats {
  double seconds = 0;
  uint64_t samples = 0;
  uint64_t light_paths = 0;  // paths of the light-tracing (caustics) pass, if it ran
  uint64_t rays = 0;
  uint64_t dropped = 0;  // non-finite samples, never written to the film
  bool cancelled = false;
  // Threads the render ran on, the calling one included: RenderOptions::threads
  // (or the hardware's), but no more than the pass's tiles and caustic chunks
  // together, and at least 1; adaptive sampling: the most that one of its
  // passes used.
  int threads = 0;
  // Adaptive sampling only: rounds after the first pass, pixels that stopped
  // at spp with their error still above the target, and the estimated
  // relative error (as the rounds measure it, 3x3 neighbourhood included)
  // over all pixels: the largest among those below the cap, and the mean.
  int adaptive_rounds = 0;
  uint64_t adaptive_capped = 0;
  double adaptive_max_error = 0, adaptive_mean_error = 0;
};

namespace detail {
// One pass of an adaptive render: per pixel, samples [first[i], last[i])
// (i = y w + x); camera samples and/or the caustic pass.
struct PassPlan {
  const uint32_t* first = nullptr;
  const uint32_t* last = nullptr;
  bool camera = true, caustics = true;
};
}  // namespace detail

// One pass over the image: the whole render (plan == nullptr), or one round
// of an adaptive render.
namespace detail {
template <class Scene, class Integrator, class Filter, class Camera>
RenderStats render_pass(const Scene& scene, const Camera& camera, const Integrator& integrator, Film& film,
                        const RenderOptions& opt, const Filter& filter, const PassPlan* plan) {
  using S = typename Scene::spectrum_type;
  using traits = spectrum_traits<S>;
  auto start = std::chrono::steady_clock::now();
  film.prepare(traits::film_xyz ? FilmEncoding::xyz : FilmEncoding::rgb);
  if (opt.aovs) {
    if (opt.aovs->width() != film.width() || opt.aovs->height() != film.height())
      throw Error("render: the AOV film's size differs from the film's");
    opt.aovs->set_xyz(traits::film_xyz);
  }
  const int w = film.width(), h = film.height(), ts = std::max(1, opt.tile_size);
  const Shutter shutter = camera.shutter();
  const int spp = std::max(0, opt.spp);
  if (opt.first_sample < 0 || opt.first_sample > spp)
    throw Error("render: first_sample " + std::to_string(opt.first_sample) + " is outside [0, spp = " +
                std::to_string(spp) + "]");
  const int s_begin = opt.first_sample;
  const int s_end = opt.sample_count < 0 ? spp : opt.first_sample + opt.sample_count;
  if (s_end > spp)
    throw Error("render: samples [" + std::to_string(s_begin) + ", " + std::to_string(s_end) + ") exceed spp = " +
                std::to_string(spp));
  if (opt.tile_stride < 1 || opt.tile_offset < 0 || opt.tile_offset >= opt.tile_stride)
    throw Error("render: tile_offset " + std::to_string(opt.tile_offset) + " is outside [0, tile_stride = " +
                std::to_string(opt.tile_stride) + ")");
  const int stride = opt.tile_stride, offset = opt.tile_offset;
  const int tiles_x = (w + ts - 1) / ts, tiles_y = (h + ts - 1) / ts, all_tiles = tiles_x * tiles_y;
  // This share's tiles: offset, offset + stride, ...
  const int tiles = plan && !plan->camera ? 0 : all_tiles > offset ? (all_tiles - offset + stride - 1) / stride : 0;
  // Tile t's pixels: [x0, x1) x [y0, y1).
  struct TileBox {
    int x0, y0, x1, y1;
  };
  auto tile_box = [&](int t) {
    const int x0 = (t % tiles_x) * ts, y0 = (t / tiles_x) * ts;
    return TileBox{x0, y0, std::min(x0 + ts, w), std::min(y0 + ts, h)};
  };

  // The light-tracing pass for caustics, when the integrator has one and the
  // scene needs it (path.hpp): as many light paths as camera samples, in
  // chunks taken from a counter like the tiles. Light path i belongs to
  // sample i / (w h), so a sample range owns a range of paths; a tile stride
  // takes every stride-th chunk of it.
  constexpr bool has_caustic_pass = integrator_capabilities<Integrator>::caustic_pass;
  bool caustics = false;
  if constexpr (has_caustic_pass) caustics = (!plan || plan->caustics) && integrator.caustics_active(scene);
  const uint64_t pixels = uint64_t(w) * uint64_t(h);
  const uint64_t light_paths = caustics ? pixels * uint64_t(spp) : 0;
  const uint64_t lp_begin = caustics ? pixels * uint64_t(s_begin) : 0;
  const uint64_t lp_end = caustics ? pixels * uint64_t(s_end) : 0;
  constexpr uint64_t chunk_size = 4096;
  const int range_chunks = int((lp_end - lp_begin + chunk_size - 1) / chunk_size);
  const int chunks = range_chunks > offset ? (range_chunks - offset + stride - 1) / stride : 0;
  const int total_work = tiles + chunks;
  // No more threads than units of work: tiles and caustic chunks alike (a
  // caustic-only pass, as adaptive sampling ends with, has no tiles).
  int threads = opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::max(1, std::min(threads, std::max(1, total_work)));

  // An adaptive round's tiles, the most samples first (then in raster
  // order): the rounds after the first give a few tiles most of the work,
  // and one of them taken last would keep a thread busy while the others
  // wait. The image does not depend on the order (each pixel's samples are
  // its own). A uniform pass keeps raster order.
  std::vector<int> tile_order;
  if (plan && tiles > 0) {
    std::vector<std::pair<uint64_t, int>> by_work(size_t(tiles), {0, 0});
    for (int k = 0; k < tiles; ++k) {
      const int t = offset + k * stride;
      const TileBox b = tile_box(t);
      uint64_t n = 0;
      for (int y = b.y0; y < b.y1; ++y)
        for (int x = b.x0; x < b.x1; ++x) {
          const size_t i = size_t(y) * size_t(w) + size_t(x);
          n += plan->last[i] > plan->first[i] ? plan->last[i] - plan->first[i] : 0;
        }
      by_work[size_t(k)] = {n, t};
    }
    std::stable_sort(by_work.begin(), by_work.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    tile_order.resize(size_t(tiles));
    for (int k = 0; k < tiles; ++k) tile_order[size_t(k)] = by_work[size_t(k)].second;
  }

  std::atomic<int> next{0}, done{0}, next_chunk{0};
  std::atomic<uint64_t> samples{0}, rays{0}, dropped{0};
  std::atomic<bool> cancelled{false};
  std::mutex progress_mutex;
  // Splats are summed in 64-bit fixed point (2^-32 of the final pixel value):
  // integer addition is associative, so the sum does not depend on the order
  // in which threads add, and the image stays independent of the thread count.
  constexpr double fixed_scale = 4294967296.0;
  std::vector<std::atomic<int64_t>> splat_sum(caustics ? size_t(w) * size_t(h) * 3 : 0);
  const double inv_paths = light_paths > 0 ? 1.0 / double(light_paths) : 0.0;

  auto work = [&](auto& sampler) {
    RayCounter counter;
    uint64_t my_samples = 0, my_dropped = 0;
    for (;;) {
      if (opt.cancel && opt.cancel->load(std::memory_order_relaxed)) {
        cancelled = true;
        break;
      }
      int k = next.fetch_add(1);
      if (k >= tiles) break;
      const TileBox b = tile_box(tile_order.empty() ? offset + k * stride : tile_order[size_t(k)]);
      for (int y = b.y0; y < b.y1; ++y)
        for (int x = b.x0; x < b.x1; ++x) {
          int sb = s_begin, se = s_end;
          if (plan) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            sb = int(plan->first[i]), se = int(plan->last[i]);
          }
          for (int s = sb; s < se; ++s) {
            sampler.start_pixel_sample(x, y, s);
            // Fixed dimension order: wavelengths, filter, lens, time (only
            // when the shutter is open for an interval), then the integrator's.
            auto lambda = traits::sample_wavelengths(sampler.get_1d());
            FilterSample fs = filter.sample(sampler.get_2d());
            CameraSample cs;
            cs.p_film = {Float(x) + 0.5f + fs.offset.x, Float(y) + 0.5f + fs.offset.y};
            cs.p_lens = sampler.get_2d();
            cs.time = shutter.is_open_interval() ? shutter.time(sampler.get_1d()) : shutter.open;
            Ray ray = camera.generate_ray(cs);
            S L = integrator.Li(scene, ray, lambda, sampler, counter);
            RGB v = traits::to_film(L, lambda);  // linear sRGB, or XYZ in spectral mode
            ++my_samples;
            if (!v.is_finite()) {
              ++my_dropped;
              continue;
            }
            film.add_sample(x, y, v, fs.weight);
            if (opt.aovs) {
              // Their own random stream, so the image does not depend on them.
              PCG32 aov_rng(hash_values(uint64_t(x), uint64_t(y), uint64_t(s), opt.seed), 0xa0f5a0f5ull);
              auto u = [&] { return aov_rng.next_float(); };
              if constexpr (integrator_capabilities<Integrator>::aovs)
                opt.aovs->add_sample(x, y, integrator.aovs(scene, ray, lambda, u), fs.weight);
              else
                opt.aovs->add_sample(x, y, first_hit_aovs(scene, ray, lambda, u), fs.weight);
            }
          }
        }
      int d = ++done;
      if (opt.progress) {
        std::lock_guard lock(progress_mutex);
        opt.progress(d, total_work);
      }
    }
    if constexpr (has_caustic_pass) {
      for (;;) {
        if (!caustics || (opt.cancel && opt.cancel->load(std::memory_order_relaxed))) {
          if (caustics) cancelled = true;
          break;
        }
        int k = next_chunk.fetch_add(1);
        if (k >= chunks) break;
        uint64_t c = uint64_t(offset) + uint64_t(k) * uint64_t(stride);
        uint64_t i0 = lp_begin + c * chunk_size, i1 = std::min(lp_end, i0 + chunk_size);
        for (uint64_t i = i0; i < i1; ++i) {
          // Light path i draws its numbers from its own stream, disjoint from
          // the camera samples' (rows h..2h-1 of the sampler's pixel grid).
          sampler.start_pixel_sample(int(i % uint64_t(w)), h + int((i / uint64_t(w)) % uint64_t(h)),
                                     int(i / (uint64_t(w) * uint64_t(h))));
          integrator.trace_caustic_path(scene, camera, sampler, counter, [&](Point2f pr, const RGB& v) {
            int px = std::clamp(int(pr.x), 0, w - 1), py = std::clamp(int(pr.y), 0, h - 1);
            double q[3];
            for (int k = 0; k < 3; ++k) {
              q[k] = double(v[k]) * inv_paths * fixed_scale;
              if (!std::isfinite(q[k]) || std::abs(q[k]) > 9.0e18 / 4) {
                ++my_dropped;
                return;
              }
            }
            size_t base = (size_t(py) * size_t(w) + size_t(px)) * 3;
            for (int k = 0; k < 3; ++k)
              splat_sum[base + size_t(k)].fetch_add(int64_t(std::llround(q[k])), std::memory_order_relaxed);
          });
        }
        int d = ++done;
        if (opt.progress) {
          std::lock_guard lock(progress_mutex);
          opt.progress(d, total_work);
        }
      }
    }
    samples += my_samples;
    dropped += my_dropped;
    rays += counter.rays;
  };
  auto worker = [&] {
    switch (opt.sampler) {
      case SamplerKind::stratified: {
        StratifiedSampler sampler(opt.spp, opt.seed);
        work(sampler);
        break;
      }
      case SamplerKind::sobol: {
        SobolSampler sampler(opt.spp, opt.seed);
        work(sampler);
        break;
      }
      default: {
        IndependentSampler sampler(opt.seed);
        work(sampler);
      }
    }
  };

  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();

  if (caustics && !cancelled) {
    std::vector<double> values(splat_sum.size());
    for (size_t i = 0; i < values.size(); ++i) values[i] = double(splat_sum[i].load()) / fixed_scale;
    film.add_splats(values, 1.0);
  }

  RenderStats st;
  uint64_t my_paths = 0;
  for (int k = 0; k < chunks; ++k) {
    uint64_t i0 = lp_begin + (uint64_t(offset) + uint64_t(k) * uint64_t(stride)) * chunk_size;
    my_paths += std::min(lp_end, i0 + chunk_size) - i0;
  }
  st.light_paths = cancelled ? 0 : my_paths;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  st.threads = threads;
  st.samples = samples;
  st.rays = rays;
  st.dropped = dropped;
  st.cancelled = cancelled;
  return st;
}
}  // namespace detail

// The estimated relative error of each pixel's camera-sample estimate, as
// adaptive sampling measures it (RenderOptions::adaptive_target). Per pixel,
// with n samples: the brightness m = (r + g + b) / 3 of its mean, and the
// per-sample standard deviation of that brightness, bounded by sd = sqrt(n)
// (se_r + se_g + se_b) / 3 from the channels' standard errors (exact when the
// channels' noise is fully correlated, as when a path's throughput scales all
// three; the film keeps no covariances). Then the per-sample relative
// variance r2 = sd^2 / max(M, floor)^2, with M the mean of m over the 3x3
// neighbourhood, and the error sqrt(R2 / n), with R2 the largest r2 over the
// 3x3 neighbourhood. Taking the brightness from the neighbourhood keeps a
// pixel whose own samples happen to be high from judging itself precise and
// stopping on them (the stopping rule's bias, docs/adaptive.md); the largest
// r2 around keeps a pixel whose few samples all missed a rare bright path
// from stopping while its neighbours see it. Returns the error per pixel
// (w h, row-major), infinity below 2 samples. With neighbourhood = false:
// the plain sd / (sqrt(n) max(m, floor)) of the pixel alone.
inline std::vector<double> adaptive_errors(const Film& film, double floor, bool neighbourhood = true) {
  const int w = film.width(), h = film.height();
  const size_t np = size_t(w) * size_t(h);
  std::vector<double> sd2(np, 0.0), m(np, 0.0), r2(np, 0.0), out(np, 0.0);
  const double inf = std::numeric_limits<double>::infinity();
  auto at = [w](int x, int y) { return size_t(y) * size_t(w) + size_t(x); };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint64_t n = film.sample_count(x, y);
      const RGB mean = film.sample_mean(x, y);
      m[at(x, y)] = (double(mean[0]) + double(mean[1]) + double(mean[2])) / 3;
      if (n >= 2) {
        const RGB var = film.variance(x, y);
        const double se = (std::sqrt(double(var[0])) + std::sqrt(double(var[1])) + std::sqrt(double(var[2]))) / 3;
        sd2[at(x, y)] = se * se * double(n);
      } else {
        sd2[at(x, y)] = inf;
      }
    }
  auto box = [&](const std::vector<double>& v, int x, int y, bool take_max) {
    double acc = 0;
    int k = 0;
    for (int yy = std::max(0, y - 1); yy <= std::min(h - 1, y + 1); ++yy)
      for (int xx = std::max(0, x - 1); xx <= std::min(w - 1, x + 1); ++xx, ++k)
        acc = take_max ? std::max(acc, v[at(xx, yy)]) : acc + v[at(xx, yy)];
    return take_max ? acc : acc / k;
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double d = std::max(neighbourhood ? box(m, x, y, false) : m[at(x, y)], floor);
      r2[at(x, y)] = sd2[at(x, y)] / (d * d);
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint64_t n = film.sample_count(x, y);
      const double r = neighbourhood ? box(r2, x, y, true) : r2[at(x, y)];
      out[at(x, y)] = n >= 2 ? std::sqrt(r / double(n)) : inf;
    }
  return out;
}

namespace detail {
// Adaptive sampling: a first pass of min_spp samples per pixel, then rounds.
// After each round every pixel's error is measured (adaptive_errors); a
// pixel above the target asks for n_need = n (e / target)^2 samples in all
// and gets, in the next round, enough to reach n_need but at least n / 4 + 1
// and at most n more (the estimate is noisy: no pixel jumps straight to the
// cap on one round's variance), never past spp. The decisions are made
// between rounds from the film alone, so they are the same whatever the
// thread count. The caustic pass (if any) runs last with as many light paths
// as camera samples were taken, rounded up to whole sample layers.
template <class Scene, class Integrator, class Filter, class Camera>
RenderStats render_adaptive(const Scene& scene, const Camera& camera, const Integrator& integrator, Film& film,
                            const RenderOptions& opt, const Filter& filter) {
  const auto start = std::chrono::steady_clock::now();
  if (!(opt.adaptive_target > 0) || !std::isfinite(opt.adaptive_target))
    throw Error("render: adaptive_target must be a positive number");
  if (opt.first_sample != 0 || opt.sample_count >= 0 || opt.tile_stride != 1 || opt.tile_offset != 0)
    throw Error("render: adaptive sampling cannot be split among processes or passes (first_sample, "
                "sample_count, tile_stride); render the whole image in one process");
  if (!(opt.adaptive_floor > 0)) throw Error("render: adaptive_floor must be positive");
  const int max_spp = std::max(1, opt.spp);
  const int min_spp = std::clamp(opt.adaptive_min_spp, std::min(2, max_spp), max_spp);
  const int w = film.width(), h = film.height();
  const size_t n_pix = size_t(w) * size_t(h);
  for (const Film::Pixel& p : film.pixels())
    if (p.count != 0) throw Error("render: adaptive sampling needs an empty film");
  std::vector<uint32_t> first(n_pix, 0), last(n_pix, uint32_t(min_spp));
  RenderOptions pass_opt = opt;
  pass_opt.spp = max_spp;
  pass_opt.adaptive_target = 0;
  RenderStats st;
  auto add = [&](const RenderStats& p) {
    st.samples += p.samples, st.rays += p.rays, st.dropped += p.dropped, st.light_paths += p.light_paths;
    st.cancelled = st.cancelled || p.cancelled;
    st.threads = std::max(st.threads, p.threads);
  };
  PassPlan plan{first.data(), last.data(), true, false};
  add(render_pass(scene, camera, integrator, film, pass_opt, filter, &plan));
  const double target = opt.adaptive_target;
  std::vector<double> err;
  for (;;) {
    err = adaptive_errors(film, opt.adaptive_floor);
    if (st.cancelled) break;
    bool any = false;
    for (size_t i = 0; i < n_pix; ++i) {
      const uint32_t n = last[i];
      first[i] = n;
      if (n >= uint32_t(max_spp) || !(err[i] > target)) continue;
      const double need = std::isfinite(err[i]) ? std::ceil(double(n) * (err[i] / target) * (err[i] / target)) : 2.0 * n;
      const double lo = double(n) + double(n / 4 + 1), hi = 2.0 * double(n);
      last[i] = uint32_t(std::min(double(max_spp), std::clamp(need, lo, hi)));
      any = true;
    }
    if (!any) break;
    ++st.adaptive_rounds;
    add(render_pass(scene, camera, integrator, film, pass_opt, filter, &plan));
  }
  double sum = 0, worst = 0;
  for (size_t i = 0; i < n_pix; ++i) {
    if (last[i] >= uint32_t(max_spp) && err[i] > target) ++st.adaptive_capped;
    else worst = std::max(worst, err[i]);
    sum += err[i];
  }
  st.adaptive_max_error = worst;
  st.adaptive_mean_error = n_pix ? sum / double(n_pix) : 0;
  if (!st.cancelled) {
    // The caustic pass: light paths for ceil(camera samples / pixels) layers.
    uint64_t taken = 0;
    for (uint32_t n : last) taken += n;
    RenderOptions copt = pass_opt;
    copt.spp = int(n_pix ? (taken + n_pix - 1) / n_pix : 0);
    PassPlan cplan{nullptr, nullptr, false, true};
    add(render_pass(scene, camera, integrator, film, copt, filter, &cplan));
  }
  if (opt.adaptive_counts) *opt.adaptive_counts = last;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return st;
}
}  // namespace detail

// Renders the scene through the camera into the film. Scene models
// SceneLike, Integrator IntegratorLike for it (with each sampler
// RenderOptions::sampler may name), Camera CameraLike; an integrator that
// declares the caustic pass must provide it for this scene and camera, and
// one that declares AOVs its aovs() (integrators/integrator.hpp).
template <class Scene, class Integrator, class Filter = BoxFilter, CameraLike Camera = PerspectiveCamera>
  requires SceneLike<Scene> && IntegratorLike<Integrator, Scene, IndependentSampler> &&
           IntegratorLike<Integrator, Scene, StratifiedSampler> && IntegratorLike<Integrator, Scene, SobolSampler>
RenderStats render(const Scene& scene, const Camera& camera, const Integrator& integrator, Film& film,
                   const RenderOptions& opt, const Filter& filter = Filter{}) {
  static_assert(!integrator_capabilities<Integrator>::caustic_pass ||
                    CausticPassIntegrator<Integrator, Scene, Camera, IndependentSampler>,
                "the integrator declares IntegratorCapability::caustic_pass but has no caustics_active(scene) or "
                "trace_caustic_path(scene, camera, sampler, counter, splat) for this scene and camera");
  static_assert(!integrator_capabilities<Integrator>::aovs || AovIntegrator<Integrator, Scene>,
                "the integrator declares IntegratorCapability::aovs but has no aovs(scene, ray, lambda, u)");
  if (opt.adaptive_target != 0) return detail::render_adaptive(scene, camera, integrator, film, opt, filter);
  return detail::render_pass(scene, camera, integrator, film, opt, filter, nullptr);
}

}  // namespace prism
