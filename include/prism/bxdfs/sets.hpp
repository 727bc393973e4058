// prism/bxdfs/sets.hpp — the BxDF sets prism names. default_bxdf_set is what
// Scene<S> holds unless told otherwise; diffuse, metal_rough and full are the
// instantiations prism-render compiles (render/instantiation.hpp picks the
// smallest that renders a scene). A user extends any of them:
// default_bxdf_set<RGB>::with<MyBxDF<RGB>>.
#pragma once
#include "prism/bxdfs/bsdf.hpp"
#include "prism/bxdfs/conductor.hpp"
#include "prism/bxdfs/dielectric.hpp"
#include "prism/bxdfs/diffuse.hpp"
#include "prism/bxdfs/metal_rough.hpp"

namespace prism {

template <class S>
using default_bxdf_set = bxdf_set<DiffuseBxDF<S>, DielectricBxDF<S>, ConductorBxDF<S>, ThinDielectricBxDF<S>>;

// The sets prism-render compiles, smallest first. Each set's BxDFs are a
// subset of the next one's only for diffuse and full; metal_rough (what the
// glTF loader produces) and diffuse are side by side.
template <class S>
using diffuse_bxdf_set = bxdf_set<DiffuseBxDF<S>>;
template <class S>
using metal_rough_bxdf_set = bxdf_set<MetalRoughBxDF<S>>;
// Every built-in BxDF: renders any scene prism can describe.
template <class S>
using full_bxdf_set =
    bxdf_set<DiffuseBxDF<S>, DielectricBxDF<S>, ConductorBxDF<S>, ThinDielectricBxDF<S>, MetalRoughBxDF<S>>;

}  // namespace prism
