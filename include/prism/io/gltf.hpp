// prism/io/gltf.hpp — opt-in: loads a glTF 2.0 file (.gltf with external or
// data-URI buffers, or .glb) into a prism Scene, through Debian's tinygltf.
// Link prism::gltf. What is supported and how each feature maps onto prism:
// docs/gltf.md.
//
// Meshes: every triangle primitive (strips and fans converted), indices of any
// component type, sparse, normalized and strided accessors; NORMAL (flat when
// absent), TANGENT, TEXCOORD_0/1, COLOR_0. A primitive whose accessors match
// another's shares its prism mesh (and BVH); a glTF mesh used by several
// nodes, and EXT_mesh_gpu_instancing, become instances (a transform each).
// Materials: MetalRoughMaterial with its textures; emission (with
// KHR_materials_emissive_strength and emissiveTexture) becomes the
// instance's AreaEmission; KHR_materials_unlit surfaces emit their base
// colour and reflect nothing; KHR_materials_variants through
// GltfOptions::variant. Images are decoded once each, in parallel, and
// shared. Errors throw prism::Error naming the file, the element
// (`meshes[3].primitives[0].attributes.POSITION`) and what is wrong.
//
// The loader, by concept, under prism/io/gltf/ (namespace gltf_detail):
//   container.hpp    the file: .gltf or .glb, preflight and extension checks
//   images.hpp       images decoded once each, in parallel (io/image_io.hpp)
//   accessors.hpp    typed, bounds-checked accessor reads
//   meshes.hpp       primitives as TriangleMeshes (and Draco's, decoded)
//   meshopt.hpp      EXT_meshopt_compression's bufferViews, decoded
//   materials.hpp    materials, textures, samplers, texture transforms
//   animation.hpp    animation channels evaluated at a time
//   scene_graph.hpp  GltfOptions, GltfCamera, GltfScene; nodes, instances,
//                    cameras, lights; gltf_framing_camera
#pragma once
#include <cmath>
#include <exception>
#include <new>
#include <string>
#include "prism/error.hpp"
#include "prism/io/gltf/accessors.hpp"
#include "prism/io/gltf/animation.hpp"
#include "prism/io/gltf/container.hpp"
#include "prism/io/gltf/images.hpp"
#include "prism/io/gltf/materials.hpp"
#include "prism/io/gltf/meshes.hpp"
#include "prism/io/gltf/meshopt.hpp"
#include "prism/io/gltf/scene_graph.hpp"

namespace prism {

// Loads a .gltf or .glb file. The scene is not built: add lights (an
// environment), set options, then call scene.build(). Throws prism::Error.
template <class S, class Set = gltf_bxdf_set<S>>
GltfScene<S, Set> load_gltf(const std::string& path, const GltfOptions& opt = {}) {
  if (!std::isfinite(opt.time)) throw Error(path + ": the animation time must be finite");
  if (!(opt.shutter >= 0) || !std::isfinite(opt.shutter))
    throw Error(path + ": the shutter interval must be finite and non-negative, got " + std::to_string(opt.shutter));
  if (opt.deformation_keys < 2 || opt.deformation_keys > 1024)
    throw Error(path + ": GltfOptions::deformation_keys must be from 2 to 1024, got " +
                std::to_string(opt.deformation_keys));
  try {
    GltfScene<S, Set> out = gltf_detail::Loader<S, Set>(path, opt).load();
    out.scene.set_source(path);
    return out;
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw Error(path + ": out of memory while loading");
  } catch (const std::exception& e) {  // a loader bug, but still an error about this file
    throw Error(path + ": internal error while loading: " + e.what());
  }
}

}  // namespace prism
