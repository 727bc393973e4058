// prism/render/instantiation.hpp — "model no more than a scene needs": the
// renderer instantiations a front end compiles, what a scene uses, and the
// rule that picks the smallest instantiation that renders a scene exactly
// (docs/instantiation.md).
//
// Compile-time choices: the colour model S (RGB or SampledSpectrum) and the
// BxDF set. Run-time branches (always compiled in, each skipped by one test
// when unused): the light variant (Light<S>, eight kinds), textures
// (MetalRoughMaterial's maps, emissive textures), motion blur (per-instance
// `motion >= 0` in the accelerator) and dispersion (a dispersive IOR
// terminates the secondary wavelengths in spectral mode). The benchmark
// bench/instantiation_bench.cpp measures what each compiled-in but unused
// BxDF costs a diffuse-only scene.
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>
#include "prism/bxdfs/hooks.hpp"
#include "prism/bxdfs/sets.hpp"
#include "prism/lights/light_set.hpp"
#include "prism/render/scene.hpp"

namespace prism {

enum class ColourModel { rgb, spectral };
enum class BxDFSetKind { diffuse, metal_rough, full };

inline const char* colour_model_name(ColourModel c) { return c == ColourModel::rgb ? "rgb" : "spectral"; }
inline const char* bxdf_set_kind_name(BxDFSetKind k) {
  switch (k) {
    case BxDFSetKind::diffuse: return "diffuse";
    case BxDFSetKind::metal_rough: return "metal_rough";
    case BxDFSetKind::full: return "full";
  }
  return "?";
}
// The BxDF names a set kind holds (bxdf_traits<...>::name).
inline std::vector<std::string_view> bxdf_set_kind_members(BxDFSetKind k) {
  switch (k) {
    case BxDFSetKind::diffuse: return {"diffuse"};
    case BxDFSetKind::metal_rough: return {"metal_rough"};
    case BxDFSetKind::full: return {"diffuse", "dielectric", "conductor", "thin_dielectric", "metal_rough"};
  }
  return {};
}

// What a built scene uses.
struct SceneFeatures {
  std::vector<std::string_view> bxdfs;  // bxdf_traits names of the materials, each once, in set order
  std::vector<std::string_view> lights;  // light kinds present, each once
  bool needs_spectral = false;  // a material RGB cannot render exactly (dispersion, measured spectra)
  bool dispersion = false;      // a dispersive IOR
  bool textures = false;        // material maps or emissive textures
  bool motion = false;          // a moving instance
  bool transparency = false;    // alpha-masked or blended materials
};

namespace detail {
template <class Set, size_t... I>
std::string_view bxdf_name_at(size_t index, std::index_sequence<I...>) {
  std::string_view out;
  ((index == I ? (out = bxdf_traits<typename Set::template bxdf<I>>::name, true) : false) || ...);
  return out;
}
inline void add_once(std::vector<std::string_view>& v, std::string_view s) {
  for (auto x : v)
    if (x == s) return;
  v.push_back(s);
}
}  // namespace detail

// Inspects a scene after build().
template <class S, class Set>
SceneFeatures scene_features(const Scene<S, Set>& scene) {
  static_assert(std::variant_size_v<Light<S>> == std::size(light_kind_names));
  SceneFeatures f;
  std::vector<uint8_t> used(Set::size, 0);
  for (const auto& m : scene.materials()) {
    used[m.index()] = 1;
    auto ask = [&]<size_t I>(std::integral_constant<size_t, I>) {
      using hooks = bxdf_hooks<typename Set::template bxdf<I>>;
      const auto& p = std::get<I>(m);
      if (hooks::dispersive(p)) f.dispersion = true;
      if (hooks::textured(p)) f.textures = true;
    };
    [&]<size_t... I>(std::index_sequence<I...>) {
      ((m.index() == I ? (ask(std::integral_constant<size_t, I>{}), true) : false) || ...);
    }(std::make_index_sequence<Set::size>{});
  }
  for (size_t i = 0; i < Set::size; ++i)
    if (used[i]) f.bxdfs.push_back(detail::bxdf_name_at<Set>(i, std::make_index_sequence<Set::size>{}));
  for (const auto& l : scene.lights()) detail::add_once(f.lights, light_kind_names[l.index()]);
  f.needs_spectral = scene.needs_spectral();
  f.textures = f.textures || scene.has_emission_textures();
  f.motion = scene.accel().has_motion();
  f.transparency = scene.has_transparency();
  return f;
}

// A renderer instantiation: colour model and BxDF set.
struct Instantiation {
  ColourModel colour = ColourModel::rgb;
  BxDFSetKind bxdfs = BxDFSetKind::full;
  bool operator==(const Instantiation&) const = default;
};

// The rule. Colour model: the one asked for, else spectral exactly when a
// material needs it. BxDF set: the first of `candidates` (smallest first)
// whose members include every BxDF the scene uses; full when none does.
// A scene without materials takes the first candidate.
inline Instantiation pick_instantiation(const SceneFeatures& f, std::optional<ColourModel> requested = std::nullopt,
                                        const std::vector<BxDFSetKind>& candidates = {BxDFSetKind::diffuse,
                                                                                      BxDFSetKind::metal_rough,
                                                                                      BxDFSetKind::full}) {
  Instantiation out;
  out.colour = requested ? *requested : (f.needs_spectral ? ColourModel::spectral : ColourModel::rgb);
  out.bxdfs = BxDFSetKind::full;
  for (BxDFSetKind k : candidates) {
    auto members = bxdf_set_kind_members(k);
    bool covers = true;
    for (auto b : f.bxdfs) {
      bool in = false;
      for (auto m : members) in = in || m == b;
      covers = covers && in;
    }
    if (covers) {
      out.bxdfs = k;
      break;
    }
  }
  return out;
}

namespace detail {
inline std::string join_names(const std::vector<std::string_view>& v) {
  std::string s = "{";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::string(v[i]);
  return s + "}";
}
}  // namespace detail

// One line: the instantiation, then what the scene uses of the run-time
// features, e.g. "rgb, bxdfs {diffuse}; scene uses bxdfs {diffuse}, lights
// {triangle_area}, no textures, no motion, no dispersion".
inline std::string describe(const Instantiation& inst, const SceneFeatures& f) {
  std::string s = std::string(colour_model_name(inst.colour)) + ", bxdfs " +
                  detail::join_names(bxdf_set_kind_members(inst.bxdfs)) + " (" + bxdf_set_kind_name(inst.bxdfs) +
                  "); scene uses bxdfs " + detail::join_names(f.bxdfs) + ", lights " + detail::join_names(f.lights);
  s += f.textures ? ", textures" : ", no textures";
  s += f.motion ? ", motion" : ", no motion";
  s += f.dispersion ? ", dispersion" : ", no dispersion";
  if (f.transparency) s += ", alpha";
  return s;
}

}  // namespace prism
