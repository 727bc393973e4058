// prism/io/gltf/container.hpp — the glTF file itself: the Document every
// part of the loader reads and reports through (the path, tinygltf's model,
// the warnings; errors name the file and the element), reading the file as
// .gltf or .glb (the GLB container checked), the preflight checks on the raw
// JSON that run before tinygltf parses it, and the extension checks.
#pragma once
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <new>
#include <string>
#include <system_error>
#include <vector>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>
#include "prism/error.hpp"
#include "prism/io/gltf/images.hpp"

namespace prism::gltf_detail {

inline std::string idx(const char* array, int i) { return std::string(array) + "[" + std::to_string(i) + "]"; }

// The file being loaded. Every check reports through it: fail throws
// prism::Error "<path>: <element>: <what>", warn keeps "<path>: <what>".
struct Document {
  std::string path;
  tinygltf::Model model;
  std::vector<std::string> warnings;

  [[noreturn]] void fail(const std::string& element, const std::string& what) const {
    throw Error(path + ": " + element + ": " + what);
  }
  void warn(const std::string& what) { warnings.push_back(path + ": " + what); }
  void check_index(int i, size_t n, const std::string& element, const char* kind) const {
    if (i < 0 || size_t(i) >= n)
      fail(element, std::string(kind) + " index " + std::to_string(i) + " out of range (" + std::to_string(n) + " " +
                        kind + "s)");
  }
  void check_finite_number(double v, const std::string& element) const {
    if (!std::isfinite(v)) fail(element, "is not finite");
  }
};

// Extension objects and their members, as tinygltf gives them.
inline const tinygltf::Value* ext(const tinygltf::ExtensionMap& m, const char* name) {
  auto it = m.find(name);
  return it == m.end() || !it->second.IsObject() ? nullptr : &it->second;
}
inline double number(const tinygltf::Value* v, const char* key, double fallback) {
  if (!v || !v->Has(key)) return fallback;
  const auto& x = v->Get(key);
  return x.IsNumber() ? x.GetNumberAsDouble() : fallback;
}

// A JSON number used as an index: -1 (out of every range) unless it is an
// integer that fits in an int.
inline int as_index(double v) {
  return v >= 0 && v <= 2147483647.0 && v == std::floor(v) ? int(v) : -1;
}

// Whether WebP images decode (prism::gltf found libwebp: EXT_texture_webp).
#if defined(PRISM_HAS_WEBP)
inline constexpr bool webp_decoder = true;
#else
inline constexpr bool webp_decoder = false;
#endif

// Whether Draco-compressed meshes decode (KHR_draco_mesh_compression).
#if defined(PRISM_HAS_DRACO)
inline constexpr bool draco_decoder = true;
#else
inline constexpr bool draco_decoder = false;
#endif

// Whether meshoptimizer-compressed bufferViews decode (EXT_meshopt_compression).
#if defined(PRISM_HAS_MESHOPT)
inline constexpr bool meshopt_decoder = true;
#else
inline constexpr bool meshopt_decoder = false;
#endif

// The extensions this loader honours (others in extensionsRequired are an
// error; in extensionsUsed, one warning each).
inline bool supported_extension(const std::string& e) {
  static const char* known[] = {"KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_specular",
                                "KHR_materials_anisotropy", "KHR_materials_clearcoat", "KHR_materials_iridescence",
                                "KHR_materials_sheen",
                                "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_dispersion",
                                "KHR_materials_unlit", "KHR_materials_variants", "KHR_texture_transform",
                                "KHR_lights_punctual", "EXT_mesh_gpu_instancing", "KHR_mesh_quantization"};
  for (const char* k : known)
    if (e == k) return true;
  return (webp_decoder && e == "EXT_texture_webp") || (draco_decoder && e == "KHR_draco_mesh_compression") ||
         (meshopt_decoder && e == "EXT_meshopt_compression");
}
// Extensions that change nothing a path tracer renders.
inline bool harmless_extension(const std::string& e) { return e == "KHR_xmp" || e == "KHR_xmp_json_ld"; }

// The GLB container (tinygltf 2.7 ignores the version and reports the rest
// as "Invalid glTF binary."): 12-byte header, JSON chunk, optional BIN chunk.
inline void check_glb(const Document& doc, const std::vector<unsigned char>& f, size_t& json_at, size_t& json_size) {
  auto u32 = [&](size_t at) {
    return uint32_t(f[at]) | uint32_t(f[at + 1]) << 8 | uint32_t(f[at + 2]) << 16 | uint32_t(f[at + 3]) << 24;
  };
  auto hex = [](uint32_t v) {
    char b[16];
    std::snprintf(b, sizeof b, "0x%08X", v);
    return std::string(b);
  };
  size_t n = f.size();
  if (n < 12) doc.fail("GLB header", "truncated: the file has " + std::to_string(n) + " bytes, the header 12");
  if (u32(4) != 2) doc.fail("GLB header", "version " + std::to_string(u32(4)) + " is not 2");
  if (u32(8) != n)
    doc.fail("GLB header", "length " + std::to_string(u32(8)) + " does not match the file size " + std::to_string(n) +
                               (u32(8) > n ? " (truncated file?)" : ""));
  if (n < 20) doc.fail("GLB chunk 0 (JSON)", "missing: the file ends after the header");
  size_t len = u32(12);
  if (u32(16) != 0x4E4F534A) doc.fail("GLB chunk 0", "type " + hex(u32(16)) + " is not JSON (0x4E4F534A)");
  if (len == 0) doc.fail("GLB chunk 0 (JSON)", "length 0");
  if (len > n - 20)
    doc.fail("GLB chunk 0 (JSON)", "length " + std::to_string(len) + " runs past the end of the file (" +
                                       std::to_string(n - 20) + " bytes after the chunk header)");
  json_at = 20;
  json_size = len;
  size_t at = 20 + len;
  if (at == n) return;
  if (n - at < 8) doc.fail("GLB chunk 1", "truncated: " + std::to_string(n - at) + " bytes after the JSON chunk");
  size_t bin = u32(at);
  if (u32(at + 4) != 0x004E4942) doc.fail("GLB chunk 1", "type " + hex(u32(at + 4)) + " is not BIN (0x004E4942)");
  if (bin > n - at - 8)
    doc.fail("GLB chunk 1 (BIN)", "length " + std::to_string(bin) + " runs past the end of the file (" +
                                      std::to_string(n - at - 8) + " bytes after the chunk header)");
}

// A uri decoded as tinygltf decodes it (its dlib::urldecode: '+' is a space).
inline std::string url_decode(const std::string& s) {
  auto hex = [](char c) {
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : 0;
  };
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%' && s.size() > i + 2) {
      out += char(hex(s[i + 1]) << 4 | hex(s[i + 2]));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

// What tinygltf checks with a message naming no element, checked first
// here: external buffer files, and the indices it follows while parsing.
// A JSON syntax error is left to tinygltf to report. Returns the JSON to
// parse instead when it had to be changed (else empty): tinygltf, built
// without Draco, refuses an index accessor with no bufferView, which is how
// KHR_draco_mesh_compression writes it, so such an accessor gets the
// primitive's Draco bufferView (meshes.hpp decodes the indices from there
// and never reads the accessor's bytes).
inline std::string preflight(const Document& doc, const char* text, size_t size, const std::string& base_dir) {
  using json = nlohmann::json;
  json j = json::parse(text, text + size, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return {};
  bool changed = false;
  auto array = [&](const char* key) {
    auto it = j.find(key);
    return it != j.end() && it->is_array() ? &*it : nullptr;
  };
  auto length = [&](const char* key) {
    const json* a = array(key);
    return a ? a->size() : size_t(0);
  };
  // An integer member, or `fallback` when absent or not an integer.
  auto integer = [](const json& o, const char* key, int64_t fallback) {
    auto it = o.find(key);
    return it != o.end() && it->is_number_integer() ? it->get<int64_t>() : fallback;
  };
  auto check = [&](int64_t i, size_t n, const std::string& element, const char* kind) {
    if (i < 0 || uint64_t(i) >= n)
      doc.fail(element, std::string(kind) + " index " + std::to_string(i) + " out of range (" + std::to_string(n) + " " +
                            kind + "s)");
  };
  if (json* buffers = array("buffers"))
    for (size_t b = 0; b < buffers->size(); ++b) {
      json& buf = (*buffers)[b];
      // An EXT_meshopt_compression fallback buffer may have no data and no
      // uri, which tinygltf would take for the GLB's binary chunk (or
      // refuse): it gets one byte of its own, and the bufferViews that
      // refer to it are decoded into buffers of their own (meshopt.hpp).
      if (buf.is_object() && !buf.contains("uri") && buf.contains("extensions") && buf["extensions"].is_object() &&
          buf["extensions"].contains("EXT_meshopt_compression")) {
        const json& m = buf["extensions"]["EXT_meshopt_compression"];
        if (m.is_object() && m.contains("fallback") && m["fallback"] == true) {
          buf["uri"] = "data:application/octet-stream;base64,AA==";
          buf["byteLength"] = 1;
          changed = true;
          continue;
        }
      }
      if (!buf.is_object() || !buf.contains("uri") || !buf["uri"].is_string()) continue;
      std::string uri = buf["uri"].get<std::string>();
      if (uri.empty() || uri.rfind("data:", 0) == 0) continue;
      std::string where = idx("buffers", int(b)) + " ('" + uri + "')";
      std::error_code ec;
      std::filesystem::path file = std::filesystem::path(base_dir) / url_decode(uri);
      if (!std::filesystem::is_regular_file(file, ec)) doc.fail(where, "file not found");
      int64_t want = integer(buf, "byteLength", -1);
      auto have = std::filesystem::file_size(file, ec);
      if (!ec && want >= 0 && uint64_t(want) != have)
        doc.fail(where, "the file has " + std::to_string(have) + " bytes, byteLength says " + std::to_string(want));
    }
  const json* views = array("bufferViews");
  if (const json* meshes = array("meshes"))
    for (size_t m = 0; m < meshes->size(); ++m) {
      const json& mesh = (*meshes)[m];
      if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
      for (size_t p = 0; p < mesh["primitives"].size(); ++p) {
        const json& prim = mesh["primitives"][p];
        std::string pw = idx("meshes", int(m)) + ".primitives[" + std::to_string(p) + "]";
        // tinygltf silently drops such a primitive (and renumbers the rest).
        if (!prim.is_object()) doc.fail(pw, "is not an object");
        if (!prim.contains("attributes") || !prim["attributes"].is_object())
          doc.fail(pw + ".attributes", "missing or not an object (every primitive needs POSITION)");
        for (const auto& [name, a] : prim["attributes"].items())
          if (!a.is_number_integer()) doc.fail(pw + ".attributes." + name, "is not an accessor index");
        if (!prim.contains("indices")) continue;
        std::string where = pw + ".indices";
        int64_t a = integer(prim, "indices", -1);
        check(a, length("accessors"), where, "accessor");
        json& acc = (*array("accessors"))[size_t(a)];
        int64_t v = acc.is_object() ? integer(acc, "bufferView", -1) : -1;
        if (v < 0 && draco_decoder && acc.is_object() && prim.contains("extensions") && prim["extensions"].is_object() &&
            prim["extensions"].contains("KHR_draco_mesh_compression")) {
          const json& d = prim["extensions"]["KHR_draco_mesh_compression"];
          int64_t dv = d.is_object() ? integer(d, "bufferView", -1) : -1;
          check(dv, length("bufferViews"), pw + ".extensions.KHR_draco_mesh_compression.bufferView", "bufferView");
          acc["bufferView"] = dv;
          v = dv;
          changed = true;
        }
        if (v < 0) doc.fail(where + " (" + idx("accessors", int(a)) + ")", "has no bufferView (indices need one)");
        check(v, length("bufferViews"), where + " (" + idx("accessors", int(a)) + ").bufferView", "bufferView");
      }
    }
  if (const json* animations = array("animations"))
    for (size_t a = 0; a < animations->size(); ++a) {
      const json& an = (*animations)[a];
      if (!an.is_object() || !an.contains("channels") || !an["channels"].is_array()) continue;
      for (size_t c = 0; c < an["channels"].size(); ++c) {
        // tinygltf silently drops such a channel too.
        const json& ch = an["channels"][c];
        std::string cw = idx("animations", int(a)) + ".channels[" + std::to_string(c) + "]";
        if (!ch.is_object()) doc.fail(cw, "is not an object");
        if (!ch.contains("sampler") || !ch["sampler"].is_number_integer())
          doc.fail(cw + ".sampler", "missing or not an index");
        if (!ch.contains("target") || !ch["target"].is_object()) continue;
        const json& t = ch["target"];
        if (t.contains("node") && !t["node"].is_number_integer()) doc.fail(cw + ".target.node", "is not an index");
        if (!t.contains("path") || !t["path"].is_string()) doc.fail(cw + ".target.path", "missing or not a string");
      }
    }
  if (const json* images = array("images"))
    for (size_t i = 0; i < images->size(); ++i) {
      const json& im = (*images)[i];
      if (!im.is_object() || !im.contains("bufferView")) continue;
      std::string where = idx("images", int(i)) + ".bufferView";
      int64_t v = integer(im, "bufferView", -1);
      check(v, length("bufferViews"), where, "bufferView");
      const json& view = (*views)[size_t(v)];
      check(view.is_object() ? integer(view, "buffer", -1) : -1, length("buffers"),
            idx("bufferViews", int(v)) + ".buffer", "buffer");
    }
  return changed ? j.dump() : std::string();
}

// Reads doc.path into doc.model (tinygltf), after the container and
// preflight checks; each image's encoded bytes go to `pending`.
inline void load_model(Document& doc, PendingImages& pending) {
  std::error_code ec;
  if (!std::filesystem::exists(doc.path, ec)) throw Error(doc.path + ": no such file");
  if (std::filesystem::is_directory(doc.path, ec)) throw Error(doc.path + ": is a directory, not a glTF file");
  std::vector<unsigned char> file;
  {
    FILE* f = std::fopen(doc.path.c_str(), "rb");
    if (!f) throw Error(doc.path + ": cannot be opened");
    unsigned char chunk[65536];
    for (size_t got; (got = std::fread(chunk, 1, sizeof chunk, f)) > 0;) file.insert(file.end(), chunk, chunk + got);
    bool bad = std::ferror(f);
    std::fclose(f);
    if (bad) throw Error(doc.path + ": read error");
  }
  std::string ext = std::filesystem::path(doc.path).extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  // Sniff the container rather than trust the extension.
  bool binary = file.size() >= 4 && std::memcmp(file.data(), "glTF", 4) == 0;
  if (ext == ".glb" && !binary) doc.fail("GLB header", "wrong magic (expected 'glTF')");
  if (file.size() > std::numeric_limits<uint32_t>::max()) doc.fail(binary ? "GLB header" : "JSON", "file larger than 4 GB");
  std::string base_dir = std::filesystem::path(doc.path).parent_path().string();
  size_t json_at = 0, json_size = file.size();
  if (binary) check_glb(doc, file, json_at, json_size);
  std::string patched = preflight(doc, reinterpret_cast<const char*>(file.data()) + json_at, json_size, base_dir);
  if (!patched.empty()) {
    if (!binary) {
      file.assign(patched.begin(), patched.end());
    } else {  // the same GLB with the new JSON chunk (padded with spaces to 4 bytes)
      while (patched.size() % 4) patched += ' ';
      std::vector<unsigned char> glb(file.begin(), file.begin() + 12);
      auto put32 = [&](size_t at, uint32_t v) {
        for (int k = 0; k < 4; ++k) glb[at + size_t(k)] = (unsigned char)(v >> (8 * k));
      };
      glb.resize(20);
      put32(12, uint32_t(patched.size()));
      std::memcpy(glb.data() + 16, "JSON", 4);
      glb.insert(glb.end(), patched.begin(), patched.end());
      glb.insert(glb.end(), file.begin() + std::ptrdiff_t(json_at + json_size), file.end());
      put32(8, uint32_t(glb.size()));
      file = std::move(glb);
    }
  }

  tinygltf::TinyGLTF loader;
  pending.model = &doc.model;
  loader.SetImageLoader(&defer_image, &pending);
  std::string err, warn_text;
  bool ok = false;
  try {
    ok = binary ? loader.LoadBinaryFromMemory(&doc.model, &err, &warn_text, file.data(), unsigned(file.size()), base_dir)
                : loader.LoadASCIIFromString(&doc.model, &err, &warn_text, reinterpret_cast<const char*>(file.data()),
                                             unsigned(file.size()), base_dir);
  } catch (const std::bad_alloc&) {
    doc.fail("JSON", "out of memory while parsing");
  } catch (const std::exception& e) {  // tinygltf lets some of nlohmann's through
    err = e.what();
  }
  if (!ok) {
    std::string msg = err.empty() ? warn_text : err;
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
    for (auto& c : msg)
      if (c == '\n') c = ';';
    throw Error(doc.path + ": " + (msg.empty() ? std::string("not a valid glTF file") : msg));
  }
  if (!doc.model.asset.version.empty() && doc.model.asset.version.rfind("2.", 0) != 0)
    doc.fail("asset.version", "'" + doc.model.asset.version + "' is not glTF 2.x");
}

// extensionsRequired that prism does not support fail; extensionsUsed warn.
inline void check_extensions(Document& doc) {
  for (const auto& e : doc.model.extensionsRequired) {
    if (e == "KHR_texture_basisu")  // no KTX2 decoder in Debian; optional use falls back to "source"
      doc.fail("extensionsRequired",
               "extension 'KHR_texture_basisu' is required, but prism cannot decode KTX2 (Basis Universal) images; "
               "a file that gives PNG or JPEG fallbacks in each texture's 'source' loads when the extension is only "
               "in extensionsUsed");
    if (!supported_extension(e) && !harmless_extension(e))
      doc.fail("extensionsRequired", "extension '" + e + "' is required but prism does not support it");
  }
  for (const auto& e : doc.model.extensionsUsed) {
    if (e == "KHR_texture_basisu")
      doc.warn("extension 'KHR_texture_basisu': KTX2 images are not decoded; textures use their PNG or JPEG "
               "fallback ('source') where they give one");
    else if (!supported_extension(e) && !harmless_extension(e))
      doc.warn("extension '" + e + "' is used by the file but ignored by prism");
  }
}

}  // namespace prism::gltf_detail
