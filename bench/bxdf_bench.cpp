// Visible-normal sampling of the Trowbridge–Reitz distribution: Heitz 2018
// against the spherical caps of Dupuy & Benyoub 2023 (bxdfs/microfacet.hpp),
// and a whole rough-conductor sample() with each, on Google Benchmark.
//
// Inputs are precomputed (random view directions over the hemisphere, random
// u), so the loop measures the sampler; the sampled normals are summed into
// a value kept alive with DoNotOptimize. Run with, e.g.,
//   ./bxdf_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
// docs/bxdfs.md has the figures.
#include <benchmark/benchmark.h>
#include <vector>
#include <prism/bxdfs/conductor.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>

namespace {
using namespace prism;

constexpr size_t n_inputs = 4096;  // fits in L1/L2: the samplers, not memory, are timed

struct Inputs {
  std::vector<Vector3f> wo;
  std::vector<Point2f> u;
  Inputs() {
    PCG32 rng(7, 11);
    for (size_t i = 0; i < n_inputs; ++i) {
      Vector3f w = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
      if (w.z == 0) w.z = 1e-3f;
      wo.push_back(normalize(w));
      u.push_back({rng.next_float(), rng.next_float()});
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
}  // namespace

// Argument: alpha in thousandths (the anisotropic pair is (alpha, alpha / 2)).
BENCHMARK(BM_sample_wm<VNDFMethod::heitz2018>)->Arg(50)->Arg(300)->Arg(1000);
BENCHMARK(BM_sample_wm<VNDFMethod::spherical_caps>)->Arg(50)->Arg(300)->Arg(1000);
BENCHMARK(BM_conductor_sample<VNDFMethod::heitz2018>)->Arg(300);
BENCHMARK(BM_conductor_sample<VNDFMethod::spherical_caps>)->Arg(300);

BENCHMARK_MAIN();
