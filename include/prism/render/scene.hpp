// prism/render/scene.hpp — a scene built in code: meshes and spheres with
// materials, optional area emission, and lights: uniform and image
// environments, sun, point, spot and distant lights. Templated on the colour
// type S and the BxDF set, so a renderer is instantiated for what it needs.
// build() validates and builds the acceleration structure; it throws
// prism::Error naming the object and what is wrong.
#pragma once
#include <cstring>
#include <string>
#include <variant>
#include <vector>
#include "prism/accel/scene_accel.hpp"
#include "prism/bxdfs/bsdf.hpp"
#include "prism/bxdfs/hooks.hpp"
#include "prism/bxdfs/sets.hpp"
#include "prism/cameras/footprint.hpp"
#include "prism/error.hpp"
#include "prism/integrators/integrator.hpp"
#include "prism/lights/bvh_sampler.hpp"
#include "prism/lights/light_sampler.hpp"
#include "prism/lights/light_set.hpp"
#include "prism/lights/power_sampler.hpp"

namespace prism {

// How next-event estimation chooses a light: with probability proportional
// to its power, uniformly, by a light BVH that weighs the lights by their
// importance for the shading point (lights/bvh_sampler.hpp), or (the default)
// automatically: power below `bvh_light_threshold` lights with bounds (area
// lights, point and spot lights), the BVH from there on (docs/lights.md has
// the measurements behind the choice).
enum class LightSelection { power, uniform, bvh, automatic };
inline constexpr size_t bvh_light_threshold = 8;

inline const char* light_selection_name(LightSelection s) {
  switch (s) {
    case LightSelection::power: return "power";
    case LightSelection::uniform: return "uniform";
    case LightSelection::bvh: return "bvh";
    case LightSelection::automatic: return "auto";
  }
  return "?";
}

template <class S, class Set = default_bxdf_set<S>>
class Scene {
 public:
  using spectrum_type = S;
  using bxdf_set_type = Set;
  using material_type = typename Set::material_variant;
  using bsdf_type = BSDF<S, Set>;
  using light_type = Light<S>;

  uint32_t add_material(const material_type& m) {
    m_materials.push_back(m);
    return uint32_t(m_materials.size() - 1);
  }
  uint32_t add_mesh(TriangleMesh mesh) { return m_accel.add_mesh(std::move(mesh)); }
  // A mesh whose vertices move during the shutter (deformation blur; see
  // SceneAccel::add_deforming_mesh). Its instances do not emit: area lights
  // do not deform.
  uint32_t add_deforming_mesh(TriangleMesh mesh, VertexMotion motion) {
    return m_accel.add_deforming_mesh(std::move(mesh), std::move(motion));
  }
  // An instance of a mesh; with emission, each of its triangles becomes an area light.
  uint32_t add_instance(uint32_t mesh, uint32_t material, const Transform& object_to_world = {},
                        std::optional<AreaEmission> emission = std::nullopt) {
    uint32_t id = m_accel.add_mesh_instance(mesh, object_to_world);
    m_info.push_back({int32_t(material), -1, emission});
    return id;
  }
  // An instance that moves during the shutter (motion blur): object_to_world
  // is motion.at(ray time). It does not emit: area lights stay still.
  uint32_t add_instance(uint32_t mesh, uint32_t material, const AnimatedTransform& motion) {
    uint32_t id = m_accel.add_mesh_instance(mesh, motion);
    m_info.push_back({int32_t(material), -1, std::nullopt});
    return id;
  }
  // Convenience: a mesh used once.
  uint32_t add_mesh_instance(TriangleMesh mesh, uint32_t material, std::optional<AreaEmission> emission = std::nullopt) {
    return add_instance(add_mesh(std::move(mesh)), material, {}, emission);
  }
  uint32_t add_sphere(const Sphere& s, uint32_t material, std::optional<AreaEmission> emission = std::nullopt) {
    uint32_t id = m_accel.add_sphere(s);
    m_info.push_back({int32_t(material), -1, emission});
    return id;
  }
  // A light that is not an emitting surface: an environment (uniform or
  // image), a sun, a point, spot or distant light.
  template <class L>
    requires(!std::is_same_v<L, TriangleAreaLight<S>> && !std::is_same_v<L, SphereAreaLight<S>>)
  void add_light(const L& l) {
    m_extra_lights.emplace_back(l);
  }
  void add_infinite_light(const UniformInfiniteLight<S>& l) { add_light(l); }
  void set_light_selection(LightSelection s) { m_selection = s; }
  // Off: triangle lights are always sampled by area (lights/area.hpp), for
  // comparisons; takes effect at build().
  void set_triangle_solid_angle_sampling(bool on) { m_triangle_solid_angle = on; }

  // The file (or other source) the scene came from, e.g. set by load_gltf:
  // build() starts its error messages with it, so that an error found only
  // when building (a light whose power overflows, say) still names the file.
  void set_source(std::string source) { m_source = std::move(source); }
  const std::string& source() const { return m_source; }

  // Validates the scene and builds lights and the acceleration structure.
  // Throws prism::Error naming the object and what is wrong (after source()
  // when set); the scene is then not usable until a build() succeeds.
  void build(const BVHBuildOptions& opt = {}) {
    if (m_source.empty()) return build_unnamed(opt);
    try {
      build_unnamed(opt);
    } catch (const Error& e) {
      throw Error(m_source + ": " + e.what());
    }
  }

 private:
  void build_unnamed(const BVHBuildOptions& opt) {
    const auto& meshes = m_accel.meshes();
    for (size_t m = 0; m < meshes.size(); ++m) validate_mesh(meshes[m], m);
    for (size_t i = 0; i < m_accel.spheres().size(); ++i) {
      const Sphere& s = m_accel.spheres()[i];
      if (!(s.radius > 0) || !std::isfinite(s.radius) || s.center.has_nan())
        throw Error("scene: sphere " + std::to_string(i) + ": radius must be positive and finite, centre finite");
    }
    for (size_t i = 0; i < m_materials.size(); ++i)
      std::visit([&](const auto& p) { hooks_of<std::decay_t<decltype(p)>>::validate(p, "scene: material " + std::to_string(i)); },
                 m_materials[i]);
    for (size_t i = 0; i < m_info.size(); ++i) {
      if (m_info[i].material < 0 || size_t(m_info[i].material) >= m_materials.size())
        throw Error("scene: instance " + std::to_string(i) + ": material index " + std::to_string(m_info[i].material) +
                    " out of range (" + std::to_string(m_materials.size()) + " materials)");
      const Instance& in = m_accel.instances()[i];
      if (in.kind != Instance::Kind::sphere && !in.object_to_world.invertible())
        throw Error("scene: instance " + std::to_string(i) + ": transform is singular");
      if (auto& e = m_info[i].emission) {
        if (!e->radiance.is_finite() || e->radiance.r < 0 || e->radiance.g < 0 || e->radiance.b < 0 ||
            !(e->scale >= 0) || !std::isfinite(e->scale))
          throw Error("scene: instance " + std::to_string(i) + ": emission must be finite and non-negative");
        if (in.kind == Instance::Kind::deforming_mesh)
          throw Error("scene: instance " + std::to_string(i) +
                      ": a deforming mesh cannot emit (area lights do not deform)");
        if (e->back && in.kind == Instance::Kind::sphere)
          throw Error("scene: instance " + std::to_string(i) +
                      ": a sphere light emits outwards or both ways, not from its back (EmittingSide::back)");
      }
    }
    m_accel.build(opt);

    m_lights.clear();
    m_infinite_indices.clear();
    for (size_t i = 0; i < m_info.size(); ++i) {
      auto& info = m_info[i];
      info.light_offset = -1;
      if (!info.emission || info.emission->radiance.is_black() || info.emission->scale == 0) continue;
      const Instance& in = m_accel.instances()[i];
      info.light_offset = int32_t(m_lights.size());
      if (in.kind == Instance::Kind::sphere) {
        m_lights.emplace_back(SphereAreaLight<S>(m_accel.spheres()[in.geometry], *info.emission, uint32_t(i)));
        continue;
      }
      const TriangleMesh& mesh = meshes[in.geometry];
      // A mirroring transform reverses the winding (glTF: the front face is
      // the one the object-space winding names, whatever the determinant).
      // EmittingSide::back turns the emitting side over the same way.
      bool mirror = in.mirror != info.emission->back;
      std::optional<RGB> texture_mean;
      if (info.emission->texture) texture_mean = info.emission->texture->average();
      for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        Point3f p[3];
        for (int j = 0; j < 3; ++j) p[j] = in.object_to_world(mesh.positions[mesh.indices[3 * t + size_t(j)]]);
        std::array<Point2f, 3> uv{};
        if (info.emission->texture) {
          const auto& set = info.emission->texture->texcoord == 1 ? mesh.uvs1 : mesh.uvs;
          if (!set.empty())
            for (int j = 0; j < 3; ++j) uv[size_t(j)] = set[mesh.indices[3 * t + size_t(j)]];
        }
        if (mirror) {
          std::swap(p[1], p[2]);
          std::swap(uv[1], uv[2]);
        }
        TriangleAreaLight<S> light(p[0], p[1], p[2], *info.emission, uint32_t(i), uint32_t(t), uv, texture_mean);
        light.set_solid_angle_sampling(m_triangle_solid_angle);
        m_lights.emplace_back(std::move(light));
      }
    }
    m_area_light_count = m_lights.size();
    m_transparent.assign(m_materials.size(), 0);
    m_any_transparent = false;
    for (size_t i = 0; i < m_materials.size(); ++i) {
      m_transparent[i] = std::visit(
          [](const auto& p) -> uint8_t { return hooks_of<std::decay_t<decltype(p)>>::may_be_transparent(p) ? 1 : 0; },
          m_materials[i]);
      if (m_transparent[i]) m_any_transparent = true;
    }
    m_has_specular = false;
    for (const auto& m : m_materials)
      if (std::visit([](const auto& p) { return hooks_of<std::decay_t<decltype(p)>>::has_specular(p); }, m))
        m_has_specular = true;
    Bounds3f b = m_accel.bounds();
    Float radius = b.empty() ? 1 : length(b.diagonal()) / 2;
    for (auto l : m_extra_lights) {
      std::visit(
          [&](auto& light) {
            if constexpr (SceneSizedLight<std::decay_t<decltype(light)>>) light.set_scene_radius(radius);
          },
          l);
      m_lights.push_back(l);
      // Lights that a ray escaping the scene can see (detail::escaped).
      bool has_le =
          std::visit([](const auto& light) { return EscapeEmitter<std::decay_t<decltype(light)>, S>; }, l);
      if (has_le) m_infinite_indices.push_back(uint32_t(m_lights.size() - 1));
    }
    m_resolved = m_selection;
    std::vector<std::optional<LightBounds>> bounds;
    if (m_selection == LightSelection::bvh || m_selection == LightSelection::automatic) {
      size_t bounded = 0;
      for (const auto& l : m_lights) {
        std::optional<LightBounds> b = light_bounds<S>(l);
        // Unbounded lights of zero power: a bound of zero power, never chosen.
        if (!b && !(light_power_luminance<S>(l) > 0)) b = LightBounds{};
        if (b && b->phi > 0) ++bounded;
        bounds.push_back(b);
      }
      if (m_selection == LightSelection::automatic)
        m_resolved = bounded >= bvh_light_threshold ? LightSelection::bvh : LightSelection::power;
    }
    if (m_resolved == LightSelection::bvh) {
      m_bvh_sampler = BVHLightSampler(bounds);
      m_light_sampler = make_power_light_sampler<S>(m_lights);
    } else if (m_resolved == LightSelection::power) {
      m_bvh_sampler = BVHLightSampler();
      m_light_sampler = make_power_light_sampler<S>(m_lights);
    } else {
      m_bvh_sampler = BVHLightSampler();
      std::vector<Float> ones(m_lights.size(), Float(1));
      m_light_sampler = PowerLightSampler(ones);
    }
    // The caustic pass starts light paths on area lights only, by power.
    std::vector<Float> area_power(m_lights.size(), Float(0));
    if (m_area_light_count > 0) {
      PowerLightSampler all = make_power_light_sampler<S>(m_lights);
      for (size_t i = 0; i < m_area_light_count; ++i) area_power[i] = all.pmf(uint32_t(i));
      m_area_light_sampler = PowerLightSampler(area_power);
    } else {
      m_area_light_sampler = PowerLightSampler();
    }
  }

 public:
  // The closest surface along the ray. Surfaces whose material may be
  // transparent (glTF alphaMode mask or blend: bxdf_traits::opacity) are
  // passed through where they are not there; a blended surface is kept with
  // probability equal to its opacity, decided by a hash of the ray and the
  // primitive, so the result depends on nothing but the ray.
  std::optional<SurfaceInteraction> intersect(const Ray& ray, Float t_max = infinity) const {
    if (!m_any_transparent) {
      auto h = m_accel.intersect(ray, t_max);
      if (!h) return std::nullopt;
      return interaction(ray, *h);
    }
    return intersect_with_alpha(ray, t_max, UINT32_MAX, UINT32_MAX, nullptr);
  }
  bool occluded(const Ray& ray, Float t_max, uint32_t skip_instance = UINT32_MAX,
                uint32_t skip_primitive = UINT32_MAX) const {
    if (!m_any_transparent) return m_accel.occluded(ray, t_max, skip_instance, skip_primitive);
    bool skipped = false;
    auto si = intersect_with_alpha(ray, t_max, skip_instance, skip_primitive, &skipped);
    return si.has_value() && !skipped;
  }
  // Texture filtering: every hit gets the pixel's footprint in uv
  // (SurfaceInteraction::dudx ...) from this camera model
  // (cameras/footprint.hpp); textures whose ImageTexture::filtering is
  // trilinear or EWA filter over it. The default (inactive) leaves it 0.
  void set_pixel_footprint(const PixelFootprint& f) { m_footprint = f; }
  const PixelFootprint& pixel_footprint() const { return m_footprint; }
  // True if some instance's material may be transparent (alpha); valid after build().
  bool has_transparency() const { return m_any_transparent; }

  template <class W>
  bsdf_type bsdf(const SurfaceInteraction& si, W&& lambda) const {
    return bsdf_type::from_material(m_materials[size_t(si.material)], si, lambda);
  }

  // The absorption coefficient inside the object hit at si, if its material
  // has an absorbing volume (bxdf_traits::volume).
  template <class W>
  std::optional<S> interior_absorption(const SurfaceInteraction& si, const W& lambda) const {
    return std::visit(
        [&](const auto& p) -> std::optional<S> {
          if (const VolumeAbsorption* v = hooks_of<std::decay_t<decltype(p)>>::volume(p))
            return absorption_coefficient<S>(*v, lambda);
          return std::nullopt;
        },
        m_materials[size_t(si.material)]);
  }

  // True if some material may scatter specularly (a delta lobe):
  // bxdf_hooks::has_specular.
  // Computed by build(): the integrators ask per sample.
  bool has_specular() const { return m_has_specular; }
  // True if the scene has area lights (emitting triangles or spheres); valid after build().
  bool has_area_lights() const { return m_area_light_count > 0; }
  // True if an emitting instance has an emissive texture; valid after build().
  bool has_emission_textures() const {
    for (const auto& info : m_info)
      if (info.emission && info.emission->texture) return true;
    return false;
  }

  // True if a material cannot be rendered exactly in RGB (dispersion, measured
  // spectra): the colour model a front end should choose without being told.
  bool needs_spectral() const {
    for (const auto& m : m_materials)
      if (std::visit([](const auto& p) { return hooks_of<std::decay_t<decltype(p)>>::needs_spectral(p); }, m))
        return true;
    return false;
  }

  const std::vector<light_type>& lights() const { return m_lights; }
  const std::vector<uint32_t>& infinite_lights() const { return m_infinite_indices; }
  // The light for next-event estimation at ctx (a surface point and its
  // shading normal; a zero normal for a point in a medium), and the
  // probability light_pmf(ctx, i) of choosing light i there: by the selection
  // build() resolved (light_selection()).
  std::optional<SampledLight> sample_light(const LightSampleContext& ctx, Float u) const {
    if (m_resolved == LightSelection::bvh) return m_bvh_sampler.sample(ctx, u);
    return m_light_sampler.sample(u);
  }
  Float light_pmf(const LightSampleContext& ctx, uint32_t light) const {
    if (m_resolved == LightSelection::bvh) return m_bvh_sampler.pmf(ctx, light);
    return m_light_sampler.pmf(light);
  }
  // The selection in use after build(): power, uniform or bvh (automatic resolved).
  LightSelection light_selection() const { return m_resolved; }
  // Context-free: by power (or uniform with LightSelection::uniform); with the
  // BVH selection, the power sampler. Next-event estimation uses sample_light.
  const PowerLightSampler& light_sampler() const { return m_light_sampler; }
  const BVHLightSampler& bvh_light_sampler() const { return m_bvh_sampler; }
  // Chooses among the area lights only (by power): where light paths start.
  const PowerLightSampler& area_light_sampler() const { return m_area_light_sampler; }
  const SceneAccel& accel() const { return m_accel; }
  const std::vector<material_type>& materials() const { return m_materials; }
  Bounds3f bounds() const { return m_accel.bounds(); }


 private:
  SurfaceInteraction interaction(const Ray& ray, const Hit& h) const {
    SurfaceInteraction si = m_accel.interaction(ray, h);
    const auto& info = m_info[h.instance];
    si.material = info.material;
    if (m_footprint.active()) {
      Vector3f dpdx, dpdy;
      m_footprint.dp(si.p, si.n, &dpdx, &dpdy);
      const TextureFootprint f = uv_footprint(dpdx, dpdy, si.dpdu, si.dpdv);
      si.dudx = f.dudx;
      si.dvdx = f.dvdx;
      si.dudy = f.dudy;
      si.dvdy = f.dvdy;
    }
    si.area_light = info.light_offset < 0 ? -1 : info.light_offset + int32_t(h.primitive);
    return si;
  }
  Float material_opacity(const SurfaceInteraction& si) const {
    return std::visit([&](const auto& p) -> Float { return hooks_of<std::decay_t<decltype(p)>>::opacity(p, si); },
        m_materials[size_t(si.material)]);
  }
  // A number in [0, 1) from the ray and the primitive it hit.
  static Float alpha_hash(const Ray& r, const Hit& h) {
    auto bits = [](Float f) {
      uint32_t u;
      std::memcpy(&u, &f, sizeof u);
      return uint64_t(u);
    };
    uint64_t k = bits(r.o.x) ^ (bits(r.o.y) << 21) ^ (bits(r.o.z) << 42);
    k ^= (bits(r.d.x) << 7) ^ (bits(r.d.y) << 29) ^ (bits(r.d.z) << 51);
    k ^= (uint64_t(h.instance) << 32) ^ uint64_t(h.primitive) * 0x9E3779B97F4A7C15ull;
    // splitmix64 finaliser
    k = (k ^ (k >> 30)) * 0xBF58476D1CE4E5B9ull;
    k = (k ^ (k >> 27)) * 0x94D049BB133111EBull;
    k ^= k >> 31;
    return Float(k >> 40) * Float(0x1p-24);
  }
  // The closest opaque-enough hit; stops at the skip primitive (setting
  // *skipped) so that a shadow ray ending on a light is not blocked by it.
  std::optional<SurfaceInteraction> intersect_with_alpha(Ray r, Float t_max, uint32_t skip_instance,
                                                         uint32_t skip_primitive, bool* skipped) const {
    // A bound on pass-throughs, so that a ray grazing a stack of cut-out
    // layers ends: past it the surface counts as opaque.
    constexpr int max_layers = 256;
    for (int layer = 0;; ++layer) {
      auto h = m_accel.intersect(r, t_max);
      if (!h) return std::nullopt;
      SurfaceInteraction si = interaction(r, *h);
      if (skipped && h->instance == skip_instance && h->primitive == skip_primitive) {
        *skipped = true;
        return si;
      }
      if (layer == max_layers || !m_transparent[size_t(si.material)]) return si;
      Float a = material_opacity(si);
      if (a >= 1 || (a > 0 && alpha_hash(r, *h) < a)) return si;
      t_max -= h->t;
      r = si.spawn_ray(r.d);
    }
  }

  // The BxDF whose material type is P (material types are unique in a set).
  template <class P, size_t I = 0>
  static constexpr size_t bxdf_index_of() {
    if constexpr (std::is_same_v<std::variant_alternative_t<I, material_type>, P>) return I;
    else return bxdf_index_of<P, I + 1>();
  }
  template <class P>
  using hooks_of = bxdf_hooks<typename Set::template bxdf<bxdf_index_of<P>()>>;

  static void validate_mesh(const TriangleMesh& m, size_t id) {
    std::string where = "scene: mesh " + std::to_string(id) + ": ";
    if (m.indices.size() % 3 != 0) throw Error(where + "index count is not a multiple of 3");
    for (size_t i = 0; i < m.indices.size(); ++i)
      if (m.indices[i] >= m.positions.size())
        throw Error(where + "index " + std::to_string(i) + " (" + std::to_string(m.indices[i]) +
                    ") is past the vertex count " + std::to_string(m.positions.size()));
    for (size_t i = 0; i < m.positions.size(); ++i) {
      const Point3f& p = m.positions[i];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        throw Error(where + "position " + std::to_string(i) + " is not finite");
    }
    if (!m.normals.empty() && m.normals.size() != m.positions.size())
      throw Error(where + "normal count differs from the vertex count");
    if (!m.uvs.empty() && m.uvs.size() != m.positions.size())
      throw Error(where + "uv count differs from the vertex count");
    if (!m.uvs1.empty() && m.uvs1.size() != m.positions.size())
      throw Error(where + "uv1 count differs from the vertex count");
    if (!m.tangents.empty() && m.tangents.size() != m.positions.size())
      throw Error(where + "tangent count differs from the vertex count");
    if (!m.colors.empty() && m.colors.size() != m.positions.size())
      throw Error(where + "colour count differs from the vertex count");
  }

  struct InstanceInfo {
    int32_t material;
    int32_t light_offset;
    std::optional<AreaEmission> emission;
  };
  SceneAccel m_accel;
  std::vector<material_type> m_materials;
  std::vector<InstanceInfo> m_info;
  std::string m_source;                   // set_source(): prefixes build()'s errors
  std::vector<light_type> m_extra_lights;  // as added; copied into m_lights by build()
  std::vector<light_type> m_lights;        // area lights first, then the others
  size_t m_area_light_count = 0;
  bool m_has_specular = false;
  std::vector<uint8_t> m_transparent;  // per material: may_be_transparent
  bool m_any_transparent = false;
  PixelFootprint m_footprint;
  std::vector<uint32_t> m_infinite_indices;
  LightSelection m_selection = LightSelection::automatic, m_resolved = LightSelection::power;
  bool m_triangle_solid_angle = true;
  PowerLightSampler m_light_sampler, m_area_light_sampler;
  BVHLightSampler m_bvh_sampler;
};

}  // namespace prism
