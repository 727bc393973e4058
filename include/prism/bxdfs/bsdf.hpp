// prism/bxdfs/bsdf.hpp — a BSDF: a shading frame plus one BxDF from a closed,
// statically dispatched set (std::variant; no virtual calls). bxdf_set lists
// the BxDF types a renderer is instantiated with; users extend it with their
// own types: bxdf_set<DiffuseBxDF<RGB>>::with<MyBxDF<RGB>>. Every member models
// the BxDF concept (bxdfs/hooks.hpp), and its traits' hooks are checked when
// the set is named.
#pragma once
#include <tuple>
#include <variant>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/hooks.hpp"
#include "prism/geometry/interaction.hpp"

namespace prism {

template <BxDF... Bs>
struct bxdf_set {
  // Instantiates each member's bxdf_hooks, whose static_asserts name a
  // declared hook that is missing and a hook member that is not declared.
  static_assert(((sizeof(bxdf_hooks<Bs>) > 0) && ...));
  template <class... More> using with = bxdf_set<Bs..., More...>;
  using bxdf_variant = std::variant<Bs...>;
  using material_variant = std::variant<typename bxdf_traits<Bs>::material_type...>;
  static constexpr size_t size = sizeof...(Bs);
  template <size_t I> using bxdf = std::tuple_element_t<I, std::tuple<Bs...>>;
};

template <class S, class Set>
class BSDF {
 public:
  using bxdf_variant = typename Set::bxdf_variant;

  BSDF() = default;
  BSDF(const Frame& shading, bxdf_variant b) : m_frame(shading), m_bxdf(std::move(b)) {}

  // Builds the BxDF for a material at a hit. The material variant's index I
  // selects the set's I-th BxDF, built by bxdf_traits<BxDF_I>::make. lambda is
  // passed on as a non-const lvalue when the caller's is one: a dispersive BxDF
  // terminates the secondary wavelengths through it.
  // The shading frame is bxdf_hooks<B>::shading_frame (normal mapping where
  // the traits declare it, else si.shading_frame()).
  template <class W>
  static BSDF from_material(const typename Set::material_variant& m, const SurfaceInteraction& si, W&& lambda) {
    BSDF out;
    build(out, m, si, lambda, std::make_index_sequence<Set::size>{});
    return out;
  }

  BxDFFlags flags() const {
    return std::visit([](const auto& b) { return b.flags(); }, m_bxdf);
  }
  const Frame& frame() const { return m_frame; }
  const bxdf_variant& bxdf() const { return m_bxdf; }

  // World-space wrappers around the local-frame BxDF (see bxdf.hpp for what
  // each returns). Directions exactly in the tangent plane give zero.
  S eval(const Vector3f& wo_w, const Vector3f& wi_w, TransportMode mode = TransportMode::radiance) const {
    Vector3f wo = m_frame.to_local(wo_w), wi = m_frame.to_local(wi_w);
    if (wo.z == 0) return S{};
    return std::visit([&](const auto& b) { return b.eval(wo, wi, mode); }, m_bxdf);
  }
  Float pdf(const Vector3f& wo_w, const Vector3f& wi_w, TransportMode mode = TransportMode::radiance) const {
    Vector3f wo = m_frame.to_local(wo_w), wi = m_frame.to_local(wi_w);
    if (wo.z == 0) return 0;
    return std::visit([&](const auto& b) { return Float(b.pdf(wo, wi, mode)); }, m_bxdf);
  }
  std::optional<BSDFSample<S>> sample(const Vector3f& wo_w, Float uc, Point2f u,
                                      TransportMode mode = TransportMode::radiance) const {
    Vector3f wo = m_frame.to_local(wo_w);
    if (wo.z == 0) return std::nullopt;
    auto bs = std::visit([&](const auto& b) { return b.sample(wo, uc, u, mode); }, m_bxdf);
    if (!bs || bs->f.is_black() || !(bs->pdf > 0) || bs->wi.z == 0) return std::nullopt;
    bs->wi = m_frame.from_local(bs->wi);
    return bs;
  }

 private:
  template <class W, size_t... I>
  static void build(BSDF& out, const typename Set::material_variant& m, const SurfaceInteraction& si, W& lambda,
                    std::index_sequence<I...>) {
    (void)((m.index() == I ? (build_one<I>(out, std::get<I>(m), si, lambda), true) : false) || ...);
  }
  template <size_t I, class M, class W>
  static void build_one(BSDF& out, const M& mat, const SurfaceInteraction& si, W& lambda) {
    using B = typename Set::template bxdf<I>;
    out.m_frame = bxdf_hooks<B>::shading_frame(mat, si);
    out.m_bxdf.template emplace<I>(bxdf_traits<B>::make(mat, si, lambda));
  }

  Frame m_frame;
  bxdf_variant m_bxdf;
};

}  // namespace prism
