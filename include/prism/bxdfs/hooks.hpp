// prism/bxdfs/hooks.hpp — the one place where a material's optional hooks are
// read: bxdf_hooks<B>, with the default of every hook a BxDF's traits do not
// provide, and the BxDF concept that bxdf_set enforces.
//
// A BxDF joins a renderer through bxdf_traits<B> (bxdf.hpp): name, flags,
// material_type and make() are required. Everything else is an optional hook,
// and a traits class that provides one DECLARES it in `hooks`:
//
//   static constexpr BxDFHook hooks = BxDFHook::validate | BxDFHook::has_specular;
//
// | hook               | signature (M = material_type)                          | default              |
// |--------------------|--------------------------------------------------------|----------------------|
// | validate           | static void validate(const M&, std::string_view where) | accepts everything   |
// | needs_spectral     | static bool needs_spectral(const M&)                   | false                |
// | dispersive         | static bool dispersive(const M&)                       | false                |
// | textured           | static bool textured(const M&)                         | false                |
// | has_specular       | static bool has_specular(const M&)                     | is_specular(flags)   |
// | may_be_transparent | static bool may_be_transparent(const M&)               | false                |
// | opacity            | static Float opacity(const M&, const SurfaceInteraction&) | 1                 |
// | volume             | static const VolumeAbsorption* volume(const M&)        | nullptr (no interior)|
// | shading_frame      | static Frame shading_frame(const M&, const SurfaceInteraction&) | si.shading_frame() |
//
// The declaration is what turns a typo into a compile error: a declared hook
// whose member is missing, misspelt or of the wrong signature fails with a
// static_assert naming the hook, and so does a correctly named hook member
// that `hooks` does not declare (it would otherwise be silently ignored or
// silently used). Scene, BSDF and the instantiation rule call these functions
// and nothing else; none of them probes a traits class.
#pragma once
#include <concepts>
#include <cstdint>
#include <string_view>
#include <type_traits>
#include <utility>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/volume.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/spectra/traits.hpp"

namespace prism {

enum class BxDFHook : uint32_t {
  none = 0,
  validate = 1u << 0,
  needs_spectral = 1u << 1,
  dispersive = 1u << 2,
  textured = 1u << 3,
  has_specular = 1u << 4,
  may_be_transparent = 1u << 5,
  opacity = 1u << 6,
  volume = 1u << 7,
  shading_frame = 1u << 8,
};
constexpr BxDFHook operator|(BxDFHook a, BxDFHook b) { return BxDFHook(uint32_t(a) | uint32_t(b)); }
constexpr bool declares(BxDFHook set, BxDFHook h) { return (uint32_t(set) & uint32_t(h)) != 0; }

// What bxdf_traits<B> must provide (bxdf.hpp). make() is checked with the RGB
// and spectral wavelength types in turn: a BxDF is built for one of them.
template <class B>
concept BxDFTraitsLike = requires {
  { bxdf_traits<B>::name } -> std::convertible_to<std::string_view>;
  { bxdf_traits<B>::flags } -> std::convertible_to<BxDFFlags>;
  typename bxdf_traits<B>::material_type;
};

// The colour type a BxDF evaluates to.
template <class B>
using bxdf_spectrum_t = decltype(std::declval<const B&>().eval(Vector3f{}, Vector3f{}, TransportMode::radiance));

// A BxDF a set may hold: it models BxDFLike for its own colour type, and its
// traits give name, flags, material_type and make().
template <class B>
concept BxDF = requires { typename bxdf_spectrum_t<B>; } && BxDFLike<B, bxdf_spectrum_t<B>> && BxDFTraitsLike<B> &&
               requires(const typename bxdf_traits<B>::material_type& m, const SurfaceInteraction& si,
                        wavelengths_t<bxdf_spectrum_t<B>>& lambda) {
                 { bxdf_traits<B>::make(m, si, lambda) } -> std::same_as<B>;
               };

template <class B>
struct bxdf_hooks {
  using traits = bxdf_traits<B>;
  using material_type = typename traits::material_type;

  static constexpr BxDFHook declared = [] {
    if constexpr (requires { traits::hooks; })
      return BxDFHook(traits::hooks);
    else
      return BxDFHook::none;
  }();

 private:
  using M = material_type;
  // Whether the traits class has a member of that name at all (any signature),
  // and whether it has one of the hook's signature.
#define PRISM_BXDF_HOOK_CHECK(hook, signature_ok, signature_text)                                              \
  static constexpr bool named_##hook = requires { &traits::hook; } || signature_ok;                           \
  static_assert(signature_ok || !declares(declared, BxDFHook::hook),                                          \
                "bxdf_traits declares the hook '" #hook "' in `hooks` but has no member " signature_text);   \
  static_assert(!named_##hook || declares(declared, BxDFHook::hook),                                          \
                "bxdf_traits has a member '" #hook "' but does not declare BxDFHook::" #hook " in `hooks`");
  static constexpr bool sig_validate = requires(const M& m, std::string_view w) { traits::validate(m, w); };
  static constexpr bool sig_needs_spectral = requires(const M& m) {
    { traits::needs_spectral(m) } -> std::convertible_to<bool>;
  };
  static constexpr bool sig_dispersive = requires(const M& m) {
    { traits::dispersive(m) } -> std::convertible_to<bool>;
  };
  static constexpr bool sig_textured = requires(const M& m) {
    { traits::textured(m) } -> std::convertible_to<bool>;
  };
  static constexpr bool sig_has_specular = requires(const M& m) {
    { traits::has_specular(m) } -> std::convertible_to<bool>;
  };
  static constexpr bool sig_may_be_transparent = requires(const M& m) {
    { traits::may_be_transparent(m) } -> std::convertible_to<bool>;
  };
  static constexpr bool sig_opacity = requires(const M& m, const SurfaceInteraction& si) {
    { traits::opacity(m, si) } -> std::convertible_to<Float>;
  };
  static constexpr bool sig_volume = requires(const M& m) {
    { traits::volume(m) } -> std::convertible_to<const VolumeAbsorption*>;
  };
  static constexpr bool sig_shading_frame = requires(const M& m, const SurfaceInteraction& si) {
    { traits::shading_frame(m, si) } -> std::convertible_to<Frame>;
  };
  PRISM_BXDF_HOOK_CHECK(validate, sig_validate, "`static void validate(const material_type&, std::string_view)`")
  PRISM_BXDF_HOOK_CHECK(needs_spectral, sig_needs_spectral, "`static bool needs_spectral(const material_type&)`")
  PRISM_BXDF_HOOK_CHECK(dispersive, sig_dispersive, "`static bool dispersive(const material_type&)`")
  PRISM_BXDF_HOOK_CHECK(textured, sig_textured, "`static bool textured(const material_type&)`")
  PRISM_BXDF_HOOK_CHECK(has_specular, sig_has_specular, "`static bool has_specular(const material_type&)`")
  PRISM_BXDF_HOOK_CHECK(may_be_transparent, sig_may_be_transparent,
                        "`static bool may_be_transparent(const material_type&)`")
  PRISM_BXDF_HOOK_CHECK(opacity, sig_opacity,
                        "`static Float opacity(const material_type&, const SurfaceInteraction&)`")
  PRISM_BXDF_HOOK_CHECK(volume, sig_volume, "`static const VolumeAbsorption* volume(const material_type&)`")
  PRISM_BXDF_HOOK_CHECK(shading_frame, sig_shading_frame,
                        "`static Frame shading_frame(const material_type&, const SurfaceInteraction&)`")
#undef PRISM_BXDF_HOOK_CHECK
  static constexpr bool on(BxDFHook h) { return declares(declared, h); }

 public:
  // Throws prism::Error, prefixed by `where`, on a material the BxDF cannot render.
  static void validate(const M& m, std::string_view where) {
    if constexpr (on(BxDFHook::validate)) traits::validate(m, where);
  }
  // True if RGB cannot render the material exactly (dispersion, measured spectra).
  static bool needs_spectral(const M& m) {
    if constexpr (on(BxDFHook::needs_spectral)) return traits::needs_spectral(m);
    else return false;
  }
  // True if the material's index of refraction varies with the wavelength.
  static bool dispersive(const M& m) {
    if constexpr (on(BxDFHook::dispersive)) return traits::dispersive(m);
    else return false;
  }
  // True if the material reads textures at a hit.
  static bool textured(const M& m) {
    if constexpr (on(BxDFHook::textured)) return traits::textured(m);
    else return false;
  }
  // True if the material may scatter through a delta lobe.
  static bool has_specular(const M& m) {
    if constexpr (on(BxDFHook::has_specular)) return traits::has_specular(m);
    else return is_specular(traits::flags);
  }
  // True if the surface may be absent in places (alpha).
  static bool may_be_transparent(const M& m) {
    if constexpr (on(BxDFHook::may_be_transparent)) return traits::may_be_transparent(m);
    else return false;
  }
  // The surface's coverage at a hit, in [0, 1].
  static Float opacity(const M& m, const SurfaceInteraction& si) {
    if constexpr (on(BxDFHook::opacity)) return traits::opacity(m, si);
    else return Float(1);
  }
  // The absorbing interior behind the surface, or nullptr.
  static const VolumeAbsorption* volume(const M& m) {
    if constexpr (on(BxDFHook::volume)) return traits::volume(m);
    else return nullptr;
  }
  // The shading frame at a hit (normal mapping when the traits provide it).
  static Frame shading_frame(const M& m, const SurfaceInteraction& si) {
    if constexpr (on(BxDFHook::shading_frame)) return traits::shading_frame(m, si);
    else return si.shading_frame();
  }
};

}  // namespace prism
