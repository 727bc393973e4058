// prism/io/gltf/materials.hpp — glTF materials as prism's
// MetalRoughMaterial: the metallic-roughness factors and textures, alpha
// modes, normal maps, KHR_materials_ior, _specular, _anisotropy, _clearcoat, _iridescence,
// _sheen, // _transmission, _volume
// and _dispersion; emission (KHR_materials_emissive_strength,
// emissiveTexture) as AreaEmission; KHR_materials_unlit as a black surface
// that emits its base colour; textures with their samplers (wrap and filter
// modes) and KHR_texture_transform.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <tiny_gltf.h>
#include "prism/bxdfs/metal_rough.hpp"
#include "prism/bxdfs/volume.hpp"
#include "prism/io/gltf/container.hpp"
#include "prism/io/gltf/images.hpp"
#include "prism/lights/area.hpp"
#include "prism/math/float.hpp"
#include "prism/spectra/rgb.hpp"
#include "prism/textures/texture.hpp"

namespace prism::gltf_detail {

// A member that is an array of 3 numbers, else `fallback` (element by element
// where some are not numbers).
inline std::array<double, 3> vec3(const tinygltf::Value* v, const char* key, std::array<double, 3> fallback) {
  if (!v || !v->Has(key)) return fallback;
  const auto& x = v->Get(key);
  if (!x.IsArray() || x.ArrayLen() != 3) return fallback;
  for (int i = 0; i < 3; ++i)
    if (x.Get(i).IsNumber()) fallback[size_t(i)] = x.Get(i).GetNumberAsDouble();
  return fallback;
}

// A textureInfo-like object from an extension's JSON value.
struct TexRef {
  int index = -1, texcoord = 0;
  const tinygltf::ExtensionMap* extensions = nullptr;
  const tinygltf::Value* json = nullptr;
};
inline TexRef ref(const tinygltf::TextureInfo& t) { return {t.index, t.texCoord, &t.extensions, nullptr}; }
inline TexRef ref(const tinygltf::Value* v, const char* key) {
  TexRef r;
  if (!v || !v->Has(key) || !v->Get(key).IsObject()) return r;
  const auto& o = v->Get(key);
  r.index = int(number(&o, "index", -1));
  r.texcoord = int(number(&o, "texCoord", 0));
  r.json = &o;
  return r;
}

// Reads the file's materials; warnings and errors go through the Document.
class Materials {
 public:
  // texture_filter: every material texture's ImageTexture::filtering; for
  // trilinear and EWA each image gets its MIP pyramid (once per image and
  // colour encoding).
  Materials(Document& doc, const Images& images, bool multiple_scattering,
            TextureFilter texture_filter = TextureFilter::bilinear)
      : m_doc(doc), m_images(images), m_multiple_scattering(multiple_scattering), m_filter(texture_filter) {}

  // A number of an extension object (`ew` names it): finite, and in [0, 1]
  // when `unit`.
  Float factor(const tinygltf::Value* e, const std::string& ew, const char* key, double fallback, bool unit) const {
    double v = number(e, key, fallback);
    m_doc.check_finite_number(v, ew + "." + key);
    if (unit && (v < 0 || v > 1)) m_doc.fail(ew + "." + key, "must be in [0, 1]");
    return Float(v);
  }

  // The material of materials[i]; i = -1: glTF's default material.
  MetalRoughMaterial material(int i) {
    MetalRoughMaterial mat;
    mat.multiple_scattering = m_multiple_scattering;
    if (i < 0) {
      mat.name = "glTF default material";
    } else {
      const auto& g = m_doc.model.materials[size_t(i)];
      std::string where = idx("materials", i);
      mat.name = g.name.empty() ? where : g.name;
      const auto& pbr = g.pbrMetallicRoughness;
      if (pbr.baseColorFactor.size() != 4)
        m_doc.fail(where + ".pbrMetallicRoughness.baseColorFactor", "must have 4 numbers");
      for (double c : pbr.baseColorFactor) m_doc.check_finite_number(c, where + ".pbrMetallicRoughness.baseColorFactor");
      mat.base_color = RGB(Float(pbr.baseColorFactor[0]), Float(pbr.baseColorFactor[1]), Float(pbr.baseColorFactor[2]));
      mat.alpha = Float(pbr.baseColorFactor[3]);
      m_doc.check_finite_number(pbr.metallicFactor, where + ".pbrMetallicRoughness.metallicFactor");
      m_doc.check_finite_number(pbr.roughnessFactor, where + ".pbrMetallicRoughness.roughnessFactor");
      mat.metallic = Float(pbr.metallicFactor);
      mat.roughness = Float(pbr.roughnessFactor);
      if (g.alphaMode == "MASK") mat.alpha_mode = AlphaMode::mask;
      else if (g.alphaMode == "BLEND") mat.alpha_mode = AlphaMode::blend;
      else if (g.alphaMode != "OPAQUE")
        m_doc.fail(where + ".alphaMode", "'" + g.alphaMode + "' is not OPAQUE, MASK or BLEND");
      m_doc.check_finite_number(g.alphaCutoff, where + ".alphaCutoff");
      mat.alpha_cutoff = Float(g.alphaCutoff);
      auto textures = std::make_shared<MetalRoughTextures>();
      bool any = false;
      auto set = [&](std::optional<ImageTexture>& dst, std::optional<ImageTexture> t) {
        if (t) any = true;
        dst = std::move(t);
      };
      set(textures->base_color, texture(ref(pbr.baseColorTexture), true, where + ".pbrMetallicRoughness.baseColorTexture"));
      set(textures->metallic_roughness,
          texture(ref(pbr.metallicRoughnessTexture), false, where + ".pbrMetallicRoughness.metallicRoughnessTexture"));
      TexRef nref{g.normalTexture.index, g.normalTexture.texCoord, &g.normalTexture.extensions, nullptr};
      set(textures->normal, texture(nref, false, where + ".normalTexture"));
      m_doc.check_finite_number(g.normalTexture.scale, where + ".normalTexture.scale");
      textures->normal_scale = Float(g.normalTexture.scale);
      if (const auto* e = ext(g.extensions, "KHR_materials_ior")) {
        mat.ior = Float(number(e, "ior", 1.5));
        m_doc.check_finite_number(mat.ior, where + ".extensions.KHR_materials_ior.ior");
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_specular")) {
        std::string ew = where + ".extensions.KHR_materials_specular";
        mat.specular = Float(number(e, "specularFactor", 1));
        auto c = vec3(e, "specularColorFactor", {1, 1, 1});
        mat.specular_color = RGB(Float(c[0]), Float(c[1]), Float(c[2]));
        set(textures->specular, texture(ref(e, "specularTexture"), false, ew + ".specularTexture"));
        set(textures->specular_color, texture(ref(e, "specularColorTexture"), true, ew + ".specularColorTexture"));
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_anisotropy")) {
        std::string ew = where + ".extensions.KHR_materials_anisotropy";
        mat.anisotropy = factor(e, ew, "anisotropyStrength", 0, true);
        mat.anisotropy_rotation = factor(e, ew, "anisotropyRotation", 0, false);
        set(textures->anisotropy, texture(ref(e, "anisotropyTexture"), false, ew + ".anisotropyTexture"));
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_clearcoat")) {
        std::string ew = where + ".extensions.KHR_materials_clearcoat";
        mat.clearcoat = factor(e, ew, "clearcoatFactor", 0, true);
        mat.clearcoat_roughness = factor(e, ew, "clearcoatRoughnessFactor", 0, true);
        set(textures->clearcoat, texture(ref(e, "clearcoatTexture"), false, ew + ".clearcoatTexture"));
        set(textures->clearcoat_roughness,
            texture(ref(e, "clearcoatRoughnessTexture"), false, ew + ".clearcoatRoughnessTexture"));
        TexRef nref = ref(e, "clearcoatNormalTexture");
        set(textures->clearcoat_normal, texture(nref, false, ew + ".clearcoatNormalTexture"));
        double scale = nref.json ? number(nref.json, "scale", 1) : 1;
        m_doc.check_finite_number(scale, ew + ".clearcoatNormalTexture.scale");
        textures->clearcoat_normal_scale = Float(scale);
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_sheen")) {
        std::string ew = where + ".extensions.KHR_materials_sheen";
        if (e->Has("sheenColorFactor")) {
          const auto& c = e->Get("sheenColorFactor");
          if (!c.IsArray() || c.ArrayLen() != 3) m_doc.fail(ew + ".sheenColorFactor", "must have 3 numbers");
          for (int k = 0; k < 3; ++k) {
            if (!c.Get(k).IsNumber()) m_doc.fail(ew + ".sheenColorFactor", "must have 3 numbers");
            double v = c.Get(k).GetNumberAsDouble();
            m_doc.check_finite_number(v, ew + ".sheenColorFactor");
            if (v < 0 || v > 1) m_doc.fail(ew + ".sheenColorFactor", "must be in [0, 1]");
            mat.sheen_color[k] = Float(v);
          }
        }
        mat.sheen_roughness = factor(e, ew, "sheenRoughnessFactor", 0, true);
        set(textures->sheen_color, texture(ref(e, "sheenColorTexture"), true, ew + ".sheenColorTexture"));
        set(textures->sheen_roughness, texture(ref(e, "sheenRoughnessTexture"), false, ew + ".sheenRoughnessTexture"));
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_iridescence")) {
        std::string ew = where + ".extensions.KHR_materials_iridescence";
        mat.iridescence = factor(e, ew, "iridescenceFactor", 0, true);
        mat.iridescence_ior = factor(e, ew, "iridescenceIor", 1.3, false);
        if (!(mat.iridescence_ior >= 1)) m_doc.fail(ew + ".iridescenceIor", "must be >= 1");
        mat.iridescence_thickness_min = factor(e, ew, "iridescenceThicknessMinimum", 100, false);
        mat.iridescence_thickness_max = factor(e, ew, "iridescenceThicknessMaximum", 400, false);
        if (mat.iridescence_thickness_min < 0) m_doc.fail(ew + ".iridescenceThicknessMinimum", "is negative");
        if (mat.iridescence_thickness_max < 0) m_doc.fail(ew + ".iridescenceThicknessMaximum", "is negative");
        set(textures->iridescence, texture(ref(e, "iridescenceTexture"), false, ew + ".iridescenceTexture"));
        set(textures->iridescence_thickness,
            texture(ref(e, "iridescenceThicknessTexture"), false, ew + ".iridescenceThicknessTexture"));
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_transmission")) {
        mat.transmission = Float(number(e, "transmissionFactor", 0));
        set(textures->transmission, texture(ref(e, "transmissionTexture"), false,
                                            where + ".extensions.KHR_materials_transmission.transmissionTexture"));
      }
      // KHR_materials_volume: thicknessFactor > 0 makes a refracting volume
      // (with transmission), absorbing by Beer–Lambert; the thickness
      // texture is a rasteriser's stand-in for the geometry prism traces.
      const auto* vol = ext(g.extensions, "KHR_materials_volume");
      if (vol) {
        std::string ew = where + ".extensions.KHR_materials_volume";
        double thickness = number(vol, "thicknessFactor", 0);
        m_doc.check_finite_number(thickness, ew + ".thicknessFactor");
        if (thickness < 0) m_doc.fail(ew + ".thicknessFactor", "is negative");
        mat.thickness = Float(thickness);
        double distance = number(vol, "attenuationDistance", std::numeric_limits<double>::infinity());
        if (std::isnan(distance) || !(distance > 0)) m_doc.fail(ew + ".attenuationDistance", "must be positive");
        auto c = vec3(vol, "attenuationColor", {1, 1, 1});
        for (double v : c)
          if (!(v >= 0 && v <= 1)) m_doc.fail(ew + ".attenuationColor", "must have 3 numbers in [0, 1]");
        mat.attenuation = VolumeAbsorption{RGB(Float(c[0]), Float(c[1]), Float(c[2])),
                                           std::isfinite(distance) ? Float(distance) : infinity};
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_dispersion")) {
        std::string ew = where + ".extensions.KHR_materials_dispersion.dispersion";
        double d = number(e, "dispersion", 0);
        m_doc.check_finite_number(d, ew);
        if (d < 0) m_doc.fail(ew, "is negative");
        mat.dispersion = Float(d);
        if (d > 0 && !mat.is_volume() && !m_warned_dispersion) {
          m_warned_dispersion = true;
          m_doc.warn(where + ": KHR_materials_dispersion acts only inside a volume (KHR_materials_volume with "
                             "thicknessFactor > 0 and transmission): ignored");
        }
      }
      if (any) mat.textures = textures;
      if (unlit(i)) {
        // KHR_materials_unlit: the surface shows its base colour and takes no
        // light. It reflects and transmits nothing (no lobe: a path ends
        // there) and emits the base colour (emission()); alpha, its mode and
        // cutoff, and the base colour texture's alpha still cut it out.
        MetalRoughMaterial black;
        black.name = mat.name;
        black.base_color = RGB(0);
        black.metallic = 0;
        black.specular = 0;
        black.alpha = mat.alpha;
        black.alpha_mode = mat.alpha_mode;
        black.alpha_cutoff = mat.alpha_cutoff;
        if (textures->base_color) {
          auto alpha_only = std::make_shared<MetalRoughTextures>();
          alpha_only->base_color = textures->base_color;
          black.textures = alpha_only;
        }
        return black;
      }
    }
    return mat;
  }

  // Whether materials[i] is KHR_materials_unlit (never the default material).
  bool unlit(int i) const {
    return i >= 0 && ext(m_doc.model.materials[size_t(i)].extensions, "KHR_materials_unlit") != nullptr;
  }

  // The emission of materials[i] (none for -1), built once.
  std::optional<AreaEmission> emission(int i) {
    if (i < 0) return std::nullopt;
    auto found = m_emission_cache.find(i);
    if (found != m_emission_cache.end()) return found->second;
    const auto& g = m_doc.model.materials[size_t(i)];
    std::string where = idx("materials", i);
    std::optional<AreaEmission> out;
    if (unlit(i)) {
      // An unlit material emits its base colour (factor times texture, with
      // no emissive factor or strength: the extension ignores them), from
      // both sides when the material is double-sided. Vertex colours
      // (COLOR_0) do not tint area emission and are ignored here.
      const auto& bc = g.pbrMetallicRoughness.baseColorFactor;
      if (bc.size() != 4) m_doc.fail(where + ".pbrMetallicRoughness.baseColorFactor", "must have 4 numbers");
      AreaEmission e;
      e.radiance = RGB(Float(std::max(bc[0], 0.0)), Float(std::max(bc[1], 0.0)), Float(std::max(bc[2], 0.0)));
      e.two_sided = g.doubleSided;
      if (auto t = texture(ref(g.pbrMetallicRoughness.baseColorTexture), true,
                           where + ".pbrMetallicRoughness.baseColorTexture"))
        e.texture = std::make_shared<const ImageTexture>(std::move(*t));
      if (e.texture || bc[0] > 0 || bc[1] > 0 || bc[2] > 0) out = e;
      m_emission_cache.emplace(i, out);
      return out;
    }
    std::array<double, 3> f{0, 0, 0};
    if (!g.emissiveFactor.empty()) {
      if (g.emissiveFactor.size() != 3) m_doc.fail(where + ".emissiveFactor", "must have 3 numbers");
      for (int k = 0; k < 3; ++k) f[size_t(k)] = g.emissiveFactor[size_t(k)];
    }
    double strength = 1;
    if (const auto* e = ext(g.extensions, "KHR_materials_emissive_strength")) strength = number(e, "emissiveStrength", 1);
    for (double v : f) m_doc.check_finite_number(v, where + ".emissiveFactor");
    m_doc.check_finite_number(strength, where + ".extensions.KHR_materials_emissive_strength.emissiveStrength");
    if (strength < 0) m_doc.fail(where + ".extensions.KHR_materials_emissive_strength.emissiveStrength", "is negative");
    if ((f[0] > 0 || f[1] > 0 || f[2] > 0) && strength > 0) {
      AreaEmission e;
      e.radiance = RGB(Float(std::max(f[0], 0.0)), Float(std::max(f[1], 0.0)), Float(std::max(f[2], 0.0)));
      e.scale = Float(strength);
      e.two_sided = g.doubleSided;
      if (auto t = texture(ref(g.emissiveTexture), true, where + ".emissiveTexture"))
        e.texture = std::make_shared<const ImageTexture>(std::move(*t));
      out = e;
    }
    m_emission_cache.emplace(i, out);
    return out;
  }

 private:
  std::optional<ImageTexture> texture(const TexRef& r, bool srgb, const std::string& where) {
    if (r.index == -1 && !r.json) return std::nullopt;  // -1: tinygltf's "absent"
    m_doc.check_index(r.index, m_doc.model.textures.size(), where + ".index", "texture");
    const auto& tex = m_doc.model.textures[size_t(r.index)];
    std::string tw = idx("textures", r.index);
    int source = tex.source;
#if defined(PRISM_HAS_WEBP)
    // EXT_texture_webp: its WebP image, in preference to the fallback.
    if (const auto* webp = ext(tex.extensions, "EXT_texture_webp")) {
      source = as_index(number(webp, "source", -1));
      m_doc.check_index(source, m_doc.model.images.size(), tw + ".extensions.EXT_texture_webp.source", "image");
    }
#endif
    if (source == -1) {
      m_doc.warn(tw + ": no source image that prism can decode (a KHR_texture_basisu" +
                 std::string(webp_decoder ? "" : " or EXT_texture_webp") + " image without a fallback): texture ignored");
      return std::nullopt;
    }
    m_doc.check_index(source, m_doc.model.images.size(), tw + ".source", "image");
    if (!m_images.decoded[size_t(source)]) {
      auto e = m_images.errors.find(size_t(source));
      m_doc.fail(idx("images", source) + (m_doc.model.images[size_t(source)].uri.empty()
                                              ? std::string()
                                              : " ('" + m_doc.model.images[size_t(source)].uri + "')"),
                 e == m_images.errors.end() ? "not loaded" : e->second);
    }
    ImageTexture t;
    t.image = m_images.decoded[size_t(source)];
    t.encoding = srgb ? ColorEncoding::srgb : ColorEncoding::linear;
    t.texcoord = r.texcoord;
    if (t.texcoord < 0 || t.texcoord > 1) {
      m_doc.warn(where + ": texCoord " + std::to_string(t.texcoord) + " is not supported (TEXCOORD_0 used)");
      t.texcoord = 0;
    }
    if (tex.sampler != -1) {
      m_doc.check_index(tex.sampler, m_doc.model.samplers.size(), tw + ".sampler", "sampler");
      const auto& s = m_doc.model.samplers[size_t(tex.sampler)];
      auto wrap = [&](int w, const char* which) {
        switch (w) {
          case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return WrapMode::clamp_to_edge;
          case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return WrapMode::mirrored_repeat;
          case TINYGLTF_TEXTURE_WRAP_REPEAT: return WrapMode::repeat;
          default: m_doc.fail(idx("samplers", tex.sampler) + "." + which, "invalid wrap mode " + std::to_string(w));
        }
      };
      t.wrap_s = wrap(s.wrapS, "wrapS");
      t.wrap_t = wrap(s.wrapT, "wrapT");
      t.filter = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST ? FilterMode::nearest : FilterMode::linear;
      // minFilter NEAREST or LINEAR: no mipmaps (the footprint lookups filter the image alone).
      t.use_mipmaps = !(s.minFilter == TINYGLTF_TEXTURE_FILTER_NEAREST || s.minFilter == TINYGLTF_TEXTURE_FILTER_LINEAR);
    }
    t.filtering = m_filter;
    if ((m_filter == TextureFilter::trilinear || m_filter == TextureFilter::ewa) && t.use_mipmaps) {
      auto& mips = m_mips[{source, srgb}];
      if (!mips) {
        t.build_mipmaps();
        mips = t.mips;
      }
      t.mips = mips;
    }
    // KHR_texture_transform, on the textureInfo.
    const tinygltf::Value* tt = nullptr;
    if (r.extensions) tt = ext(*r.extensions, "KHR_texture_transform");
    if (r.json && r.json->Has("extensions")) {
      const auto& e = r.json->Get("extensions");
      if (e.IsObject() && e.Has("KHR_texture_transform") && e.Get("KHR_texture_transform").IsObject())
        tt = &e.Get("KHR_texture_transform");
    }
    if (tt) {
      auto vec2 = [&](const char* key, Point2f fallback) {
        if (!tt->Has(key)) return fallback;
        const auto& x = tt->Get(key);
        if (!x.IsArray() || x.ArrayLen() != 2 || !x.Get(0).IsNumber() || !x.Get(1).IsNumber())
          m_doc.fail(where + ".extensions.KHR_texture_transform." + key, "must be an array of two numbers");
        return Point2f{Float(x.Get(0).GetNumberAsDouble()), Float(x.Get(1).GetNumberAsDouble())};
      };
      t.transform.offset = vec2("offset", {0, 0});
      t.transform.scale = vec2("scale", {1, 1});
      t.transform.rotation = Float(number(tt, "rotation", 0));
      if (tt->Has("texCoord")) t.texcoord = std::clamp(int(number(tt, "texCoord", 0)), 0, 1);
      if (!std::isfinite(t.transform.rotation) || !std::isfinite(t.transform.offset.x) ||
          !std::isfinite(t.transform.offset.y) || !std::isfinite(t.transform.scale.x) ||
          !std::isfinite(t.transform.scale.y))
        m_doc.fail(where + ".extensions.KHR_texture_transform", "holds a non-finite value");
    }
    return t;
  }

  Document& m_doc;
  const Images& m_images;
  bool m_multiple_scattering;
  TextureFilter m_filter;
  std::map<std::pair<int, bool>, std::shared_ptr<const std::vector<TextureImage>>> m_mips;  // (image, sRGB)
  bool m_warned_dispersion = false;
  std::map<int, std::optional<AreaEmission>> m_emission_cache;
};

}  // namespace prism::gltf_detail
