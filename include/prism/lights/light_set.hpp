// prism/lights/light_set.hpp — the set of light types a scene holds, as a
// std::variant dispatched statically (no virtual calls): light_variant<S,
// L...> checks that every member models LightLike and that its kind agrees
// with its capabilities; Light<S> is prism's built-in set, the one Scene uses.
#pragma once
#include <string_view>
#include <variant>
#include "prism/lights/area.hpp"
#include "prism/lights/image_infinite.hpp"
#include "prism/lights/infinite.hpp"
#include "prism/lights/light.hpp"
#include "prism/lights/punctual.hpp"

namespace prism {

template <class S, class... Ls>
  requires(LightLike<Ls, S> && ...)
using light_variant = std::variant<Ls...>;

// Every built-in light. light_kind_names (below) names them in this order.
template <class S>
using Light = light_variant<S, TriangleAreaLight<S>, SphereAreaLight<S>, UniformInfiniteLight<S>, ImageInfiniteLight<S>,
                           SunLight<S>, PointLight<S>, SpotLight<S>, DistantLight<S>>;

inline constexpr std::string_view light_kind_names[] = {"triangle_area", "sphere_area", "uniform_environment",
                                                        "image_environment", "sun", "point", "spot", "distant"};

// Area lights are surfaces that emit and start light paths; environments and
// the sun are seen by escaping rays.
static_assert(SurfaceEmitter<TriangleAreaLight<RGB>, RGB> && LightPathEmitter<TriangleAreaLight<RGB>, RGB>);
static_assert(SurfaceEmitter<SphereAreaLight<RGB>, RGB> && LightPathEmitter<SphereAreaLight<RGB>, RGB>);
static_assert(EscapeEmitter<UniformInfiniteLight<RGB>, RGB> && EscapeEmitter<ImageInfiniteLight<RGB>, RGB> &&
              EscapeEmitter<SunLight<RGB>, RGB>);
static_assert(!EscapeEmitter<PointLight<RGB>, RGB> && !SurfaceEmitter<PointLight<RGB>, RGB>);

}  // namespace prism
