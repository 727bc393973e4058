// BxDF micro-benchmarks on Google Benchmark:
// - visible-normal sampling of the Trowbridge–Reitz distribution: Heitz 2018
//   against the spherical caps of Dupuy & Benyoub 2023 (bxdfs/microfacet.hpp),
//   and a whole rough-conductor sample() with each;
// - sample() and eval() of every BxDF prism ships (diffuse, dielectric smooth
//   and rough, conductor smooth and rough, thin dielectric, metal-rough), in
//   RGB and spectral (4 wavelengths) mode;
// - the BSDF's std::variant dispatch (std::visit) against a hand-written
//   switch on the variant's index, over the same mix of BxDFs, in random and
//   in coherent order.
//
// Inputs are precomputed (random view directions over the hemisphere, random
// u), so the loop measures the sampler; the sampled normals are summed into
// a value kept alive with DoNotOptimize. Run with, e.g.,
//   ./bxdf_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
// docs/bxdfs.md has the figures.
#include <benchmark/benchmark.h>
#include <variant>
#include <vector>
#include <prism/bxdfs/bsdf.hpp>
#include <prism/bxdfs/conductor.hpp>
#include <prism/bxdfs/dielectric.hpp>
#include <prism/bxdfs/diffuse.hpp>
#include <prism/bxdfs/metal_rough.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>
#include <prism/spectra/traits.hpp>

namespace {
using namespace prism;

constexpr size_t n_inputs = 4096;  // fits in L1/L2: the samplers, not memory, are timed

struct Inputs {
  std::vector<Vector3f> wo, wi;  // wo over the upper hemisphere, wi over the sphere
  std::vector<Point2f> u;
  std::vector<Float> uc;
  Inputs() {
    PCG32 rng(7, 11);
    for (size_t i = 0; i < n_inputs; ++i) {
      Vector3f w = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
      if (w.z == 0) w.z = 1e-3f;
      wo.push_back(normalize(w));
      u.push_back({rng.next_float(), rng.next_float()});
      uc.push_back(rng.next_float());
      wi.push_back(sample_uniform_sphere({rng.next_float(), rng.next_float()}));
    }
  }
};
const Inputs& inputs() {
  static const Inputs in;
  return in;
}

template <VNDFMethod M>
void BM_sample_wm(benchmark::State& state) {
  const Inputs& in = inputs();
  Float a = Float(state.range(0)) / 1000;
  TrowbridgeReitz d(a, a * Float(0.5));
  size_t i = 0;
  Vector3f acc(0, 0, 0);
  for (auto _ : state) {
    acc += d.sample_wm(in.wo[i], in.u[i], M);
    i = (i + 1) & (n_inputs - 1);
  }
  benchmark::DoNotOptimize(acc);
  state.SetItemsProcessed(int64_t(state.iterations()));
}

// What a rough conductor's sample() does (VNDF, reflection, then f and pdf
// at the recomputed half vector: Fresnel at 4 wavelengths, D, G), with the
// given sampler: how much of a whole BSDF sample the choice is worth.
template <VNDFMethod M>
void BM_conductor_sample(benchmark::State& state) {
  const Inputs& in = inputs();
  Float a = Float(state.range(0)) / 1000;
  using S = SampledSpectrum<4>;
  TrowbridgeReitz d(a, a);
  ConductorBxDF<S> bxdf(d, S(0.2f), S(3.0f));
  size_t i = 0;
  Float acc = 0;
  for (auto _ : state) {
    const Vector3f& wo = in.wo[i];
    Vector3f wm = d.sample_wm(wo, in.u[i], M);
    Vector3f wi = reflect(wo, wm);
    if (same_hemisphere(wo, wi)) acc += bxdf.eval(wo, wi, TransportMode::radiance)[0] + bxdf.pdf(wo, wi, TransportMode::radiance);
    i = (i + 1) & (n_inputs - 1);
  }
  benchmark::DoNotOptimize(acc);
  state.SetItemsProcessed(int64_t(state.iterations()));
}

// ---- sample() and eval() per BxDF -----------------------------------------
// The BxDFs as a renderer builds them (bxdf_traits::make; spectral mode at
// four fixed wavelengths): typical materials, rough ones at alpha 0.3
// (metal-rough: roughness 0.55, metallic 0.5, transmission 0.3, so that
// every lobe is live).
enum class Kind { diffuse, dielectric_smooth, dielectric_rough, conductor_smooth, conductor_rough, thin, metal_rough };

template <class S>
auto wavelengths() {
  if constexpr (spectrum_traits<S>::is_spectral)
    return SampledWavelengths<S::size>::sample(0.37f);
  else
    return RGBWavelengths{};
}
MetalRoughMaterial bench_metal_rough() {
  MetalRoughMaterial m;
  m.base_color = RGB(0.8f, 0.5f, 0.3f);
  m.metallic = 0.5f;
  m.roughness = 0.55f;
  m.transmission = 0.3f;
  return m;
}
template <class S, Kind K>
auto make_bxdf() {
  SurfaceInteraction si;
  auto l = wavelengths<S>();
  const MicrofacetRoughness rough(0.3f);
  if constexpr (K == Kind::diffuse) {
    return bxdf_traits<DiffuseBxDF<S>>::make(DiffuseMaterial{RGB(0.6f, 0.5f, 0.4f)}, si, l);
  } else if constexpr (K == Kind::dielectric_smooth || K == Kind::dielectric_rough) {
    DielectricMaterial m{IOR(1.5f), "glass", K == Kind::dielectric_rough ? rough : MicrofacetRoughness{}};
    return bxdf_traits<DielectricBxDF<S>>::make(m, si, l);
  } else if constexpr (K == Kind::conductor_smooth || K == Kind::conductor_rough) {
    auto m = ConductorMaterial::from_eta_k(RGB(0.2f, 0.9f, 1.1f), RGB(3.9f, 2.4f, 2.2f),
                                           K == Kind::conductor_rough ? rough : MicrofacetRoughness{});
    return bxdf_traits<ConductorBxDF<S>>::make(m, si, l);
  } else if constexpr (K == Kind::thin) {
    return bxdf_traits<ThinDielectricBxDF<S>>::make(ThinDielectricMaterial{IOR(1.5f), "pane"}, si, l);
  } else {
    return bxdf_traits<MetalRoughBxDF<S>>::make(bench_metal_rough(), si, l);
  }
}

template <class S, Kind K>
void BM_bxdf_sample(benchmark::State& state) {
  const Inputs& in = inputs();
  const auto b = make_bxdf<S, K>();
  size_t i = 0;
  Float acc = 0;
  for (auto _ : state) {
    auto bs = b.sample(in.wo[i], in.uc[i], in.u[i], TransportMode::radiance);
    if (bs) acc += bs->f[0] + bs->pdf + bs->wi.z;
    i = (i + 1) & (n_inputs - 1);
  }
  benchmark::DoNotOptimize(acc);
  state.SetItemsProcessed(int64_t(state.iterations()));
}
template <class S, Kind K>
void BM_bxdf_eval(benchmark::State& state) {
  const Inputs& in = inputs();
  const auto b = make_bxdf<S, K>();
  size_t i = 0;
  Float acc = 0;
  for (auto _ : state) {
    acc += b.eval(in.wo[i], in.wi[i], TransportMode::radiance)[0];
    i = (i + 1) & (n_inputs - 1);
  }
  benchmark::DoNotOptimize(acc);
  state.SetItemsProcessed(int64_t(state.iterations()));
}

// ---- variant dispatch against a hand-written switch ---------------------------
// A scene's BxDF set with the metal-rough BxDF, and a table of n_inputs BxDFs
// drawn from the seven kinds above: in random order (range(0) = 0; the branch
// on the kind is unpredictable, as in a path tracer's successive hits on
// different materials) or in runs of 64 of one kind (range(0) = 1, coherent).
template <class S>
using BenchSet = typename bxdf_set<DiffuseBxDF<S>, DielectricBxDF<S>, ConductorBxDF<S>,
                                   ThinDielectricBxDF<S>>::template with<MetalRoughBxDF<S>>;
template <class S>
using BenchVariant = typename BenchSet<S>::bxdf_variant;

template <class S>
std::vector<BenchVariant<S>> bxdf_table(bool coherent) {
  const BenchVariant<S> kinds[] = {make_bxdf<S, Kind::diffuse>(),          make_bxdf<S, Kind::dielectric_smooth>(),
                                   make_bxdf<S, Kind::dielectric_rough>(), make_bxdf<S, Kind::conductor_smooth>(),
                                   make_bxdf<S, Kind::conductor_rough>(),  make_bxdf<S, Kind::thin>(),
                                   make_bxdf<S, Kind::metal_rough>()};
  std::vector<BenchVariant<S>> t;
  PCG32 rng(3, 5);
  for (size_t i = 0; i < n_inputs; ++i) {
    size_t k = coherent ? (i / 64) % 7 : size_t(rng.next_bounded(7));
    t.push_back(kinds[k]);
  }
  return t;
}

// What is dispatched: a whole sample() (Op::sample), or flags() (Op::flags),
// which costs a few instructions, so that the dispatch itself dominates.
enum class Op { sample, flags };
template <Op O, class B>
Float apply(const B& b, const Inputs& in, size_t i) {
  if constexpr (O == Op::sample) {
    auto bs = b.sample(in.wo[i], in.uc[i], in.u[i], TransportMode::radiance);
    return bs ? bs->f[0] + bs->pdf : Float(0);
  } else {
    return Float(uint8_t(b.flags()));
  }
}

template <class S, Op O>
void BM_dispatch_visit(benchmark::State& state) {
  const Inputs& in = inputs();
  const auto table = bxdf_table<S>(state.range(0) != 0);
  size_t i = 0;
  Float acc = 0;
  for (auto _ : state) {
    acc += std::visit([&](const auto& b) { return apply<O>(b, in, i); }, table[i]);
    i = (i + 1) & (n_inputs - 1);
  }
  benchmark::DoNotOptimize(acc);
  state.SetItemsProcessed(int64_t(state.iterations()));
}

// The same calls through a switch on index() and std::get_if.
template <class S, Op O>
void BM_dispatch_switch(benchmark::State& state) {
  const Inputs& in = inputs();
  const auto table = bxdf_table<S>(state.range(0) != 0);
  size_t i = 0;
  Float acc = 0;
  for (auto _ : state) {
    const auto& v = table[i];
    switch (v.index()) {
      case 0: acc += apply<O>(*std::get_if<0>(&v), in, i); break;
      case 1: acc += apply<O>(*std::get_if<1>(&v), in, i); break;
      case 2: acc += apply<O>(*std::get_if<2>(&v), in, i); break;
      case 3: acc += apply<O>(*std::get_if<3>(&v), in, i); break;
      default: acc += apply<O>(*std::get_if<4>(&v), in, i); break;
    }
    i = (i + 1) & (n_inputs - 1);
  }
  benchmark::DoNotOptimize(acc);
  state.SetItemsProcessed(int64_t(state.iterations()));
}
}  // namespace

// Argument: alpha in thousandths (the anisotropic pair is (alpha, alpha / 2)).
BENCHMARK(BM_sample_wm<VNDFMethod::heitz2018>)->Arg(50)->Arg(300)->Arg(1000);
BENCHMARK(BM_sample_wm<VNDFMethod::spherical_caps>)->Arg(50)->Arg(300)->Arg(1000);
BENCHMARK(BM_conductor_sample<VNDFMethod::heitz2018>)->Arg(300);
BENCHMARK(BM_conductor_sample<VNDFMethod::spherical_caps>)->Arg(300);

#define PRISM_BXDF_BENCH(S, K)                                              \
  BENCHMARK_TEMPLATE(BM_bxdf_sample, S, Kind::K)->Name("sample/" #S "/" #K); \
  BENCHMARK_TEMPLATE(BM_bxdf_eval, S, Kind::K)->Name("eval/" #S "/" #K);
#define PRISM_BXDF_BENCH_ALL(S)               \
  PRISM_BXDF_BENCH(S, diffuse)                \
  PRISM_BXDF_BENCH(S, dielectric_smooth)      \
  PRISM_BXDF_BENCH(S, dielectric_rough)       \
  PRISM_BXDF_BENCH(S, conductor_smooth)       \
  PRISM_BXDF_BENCH(S, conductor_rough)        \
  PRISM_BXDF_BENCH(S, thin)                   \
  PRISM_BXDF_BENCH(S, metal_rough)
using Spectral4 = SampledSpectrum<4>;
PRISM_BXDF_BENCH_ALL(RGB)
PRISM_BXDF_BENCH_ALL(Spectral4)

// Argument: 0 random order of BxDF kinds, 1 coherent (runs of 64).
BENCHMARK_TEMPLATE(BM_dispatch_visit, RGB, Op::sample)->Name("dispatch_sample/visit/RGB")->Arg(0)->Arg(1);
BENCHMARK_TEMPLATE(BM_dispatch_switch, RGB, Op::sample)->Name("dispatch_sample/switch/RGB")->Arg(0)->Arg(1);
BENCHMARK_TEMPLATE(BM_dispatch_visit, Spectral4, Op::sample)->Name("dispatch_sample/visit/Spectral")->Arg(0)->Arg(1);
BENCHMARK_TEMPLATE(BM_dispatch_switch, Spectral4, Op::sample)->Name("dispatch_sample/switch/Spectral")->Arg(0)->Arg(1);
BENCHMARK_TEMPLATE(BM_dispatch_visit, Spectral4, Op::flags)->Name("dispatch_flags/visit/Spectral")->Arg(0)->Arg(1);
BENCHMARK_TEMPLATE(BM_dispatch_switch, Spectral4, Op::flags)->Name("dispatch_flags/switch/Spectral")->Arg(0)->Arg(1);

BENCHMARK_MAIN();
