// prism/bxdfs/bxdf.hpp — the BxDF concept, its sample record, and the extension
// point bxdf_traits.
//
// Conventions (every BxDF, built-in or user-defined):
// - Directions are unit vectors in the local shading frame (+z = shading normal);
//   wo points away from the surface towards the viewer, wi towards the light.
// - eval(wo, wi, mode) is the BSDF value f; it EXCLUDES the cosine |cos theta_i|.
// - pdf(wo, wi, mode) is the density of sample() per unit SOLID ANGLE of wi.
// - sample(wo, uc, u, mode) returns std::nullopt on failure, or a BSDFSample
//   with f, wi, pdf (solid angle) and the lobe flags of the sampled lobe.
// - Specular (delta) lobes set BxDFFlags::specular; their f and pdf carry the
//   same delta factor, so f/pdf is meaningful but the pdf is never compared
//   with another technique's (MIS skips them), and eval/pdf return 0 for them.
#pragma once
#include <concepts>
#include <cstdint>
#include <optional>
#include <string_view>
#include "prism/math/frame.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

enum class BxDFFlags : uint8_t {
  none = 0,
  reflection = 1 << 0,
  transmission = 1 << 1,
  diffuse = 1 << 2,
  glossy = 1 << 3,
  specular = 1 << 4,
  diffuse_reflection = diffuse | reflection,
  diffuse_transmission = diffuse | transmission,
  glossy_reflection = glossy | reflection,
  glossy_transmission = glossy | transmission,
  specular_reflection = specular | reflection,
  specular_transmission = specular | transmission,
  all = diffuse | glossy | specular | reflection | transmission,
};
constexpr BxDFFlags operator|(BxDFFlags a, BxDFFlags b) { return BxDFFlags(uint8_t(a) | uint8_t(b)); }
constexpr BxDFFlags operator&(BxDFFlags a, BxDFFlags b) { return BxDFFlags(uint8_t(a) & uint8_t(b)); }
constexpr bool any(BxDFFlags f) { return f != BxDFFlags::none; }
constexpr bool is_specular(BxDFFlags f) { return any(f & BxDFFlags::specular); }
constexpr bool is_non_specular(BxDFFlags f) { return any(f & (BxDFFlags::diffuse | BxDFFlags::glossy)); }
constexpr bool is_transmissive(BxDFFlags f) { return any(f & BxDFFlags::transmission); }

// Radiance: paths traced from the camera. Importance: from lights (adjoint).
enum class TransportMode : uint8_t { radiance, importance };

template <class S>
struct BSDFSample {
  S f;          // BSDF value (no cosine)
  Vector3f wi;  // sampled direction
  Float pdf = 0;  // per unit solid angle
  BxDFFlags flags = BxDFFlags::none;
  Float eta = 1;  // relative IOR across a transmission, 1 otherwise

  bool is_specular() const { return prism::is_specular(flags); }
  bool is_transmission() const { return prism::is_transmissive(flags); }
};

inline bool same_hemisphere(const Vector3f& w, const Vector3f& wp) { return w.z * wp.z > 0; }
inline Float abs_cos_theta(const Vector3f& w) { return std::abs(w.z); }

// What every BxDF provides (see the conventions above).
template <class B, class S>
concept BxDFLike = requires(const B& b, Vector3f w, Float uc, Point2f u, TransportMode mode) {
  { b.eval(w, w, mode) } -> std::same_as<S>;
  { b.pdf(w, w, mode) } -> std::convertible_to<Float>;
  { b.sample(w, uc, u, mode) } -> std::same_as<std::optional<BSDFSample<S>>>;
  { b.flags() } -> std::same_as<BxDFFlags>;
};

// The extension point. Specialise bxdf_traits<MyBxDF> with:
//   static constexpr std::string_view name;      // for logs and docs
//   static constexpr BxDFFlags flags;             // the lobes it may have
//   using material_type = MyParams;               // unique per BxDF in a set
//   template <class W> static MyBxDF make(const MyParams&, const SurfaceInteraction&, const W& lambda);
// and render with a set that includes it (bxdf_set<...>::with<MyBxDF>).
// Optional hooks (validate, needs_spectral, has_specular, opacity, volume,
// shading_frame, ...) are declared in `static constexpr BxDFHook hooks`:
// bxdfs/hooks.hpp lists them with their signatures and defaults.
// A BxDF whose make() takes `W& lambda` (non-const) may call
// lambda.terminate_secondary() in spectral mode (dispersion).
template <class B> struct bxdf_traits;

}  // namespace prism
