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
// instance's AreaEmission. Images are decoded once each, in parallel, and
// shared. Errors throw prism::Error naming the file, the element
// (`meshes[3].primitives[0].attributes.POSITION`) and what is wrong.
#pragma once
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <tuple>
#include <vector>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>
#include "prism/prism.hpp"
#include "prism/io/image_io.hpp"

namespace prism {

struct GltfOptions {
  int scene = -1;   // the glTF scene to load; -1: the file's default (else scene 0)
  double time = 0;  // animations are sampled at this time (seconds)
  // Motion blur: a shutter open from `time` to `time + shutter` seconds. A
  // mesh node that the animations move in that interval becomes a moving
  // instance with the node's world transforms at both ends as its keys
  // (AnimatedTransform: linear translation and stretch, slerp rotation).
  // Cameras and punctual lights stay where they are at `time`.
  double shutter = 0;
  // Kulla-Conty energy compensation on every material's rough lobes
  // (MetalRoughMaterial::multiple_scattering; docs/bxdfs.md). Off by default:
  // glTF's reference viewers render single scattering.
  bool multiple_scattering = false;
};

// A camera of the file, placed by its node. camera_to_world maps prism's
// camera space (+x right, +y up, +z forward) to the world.
struct GltfCamera {
  std::string name;
  bool orthographic = false;
  Transform camera_to_world;
  Float yfov = 0;          // perspective: vertical field of view, radians
  Float aspect_ratio = 0;  // perspective: 0 if the file leaves it to the viewer
  Float ymag = 0;          // orthographic: half the window height
  Float xmag = 0;
};

template <class S>
using gltf_bxdf_set = bxdf_set<MetalRoughBxDF<S>>;

template <class S, class Set = gltf_bxdf_set<S>>
struct GltfScene {
  Scene<S, Set> scene;           // not built: add lights, then call build()
  std::vector<GltfCamera> cameras;  // in the order the node tree meets them
  std::vector<std::string> warnings;
  Bounds3f bounds;               // world bounds of every instance
  size_t mesh_triangles = 0;     // summed over the file's meshes, each once
  size_t scene_triangles = 0;    // summed over every instance in the scene
  size_t punctual_lights = 0;    // KHR_lights_punctual lights placed
  size_t emissive_instances = 0;
  size_t moving_instances = 0;   // instances that move during the shutter (GltfOptions::shutter)
  size_t images = 0, image_bytes = 0;
  bool has_lights() const { return punctual_lights + emissive_instances > 0; }
};

namespace gltf_detail {

inline std::string idx(const char* array, int i) { return std::string(array) + "[" + std::to_string(i) + "]"; }

// The extensions this loader honours (others in extensionsRequired are an
// error; in extensionsUsed, one warning each).
inline bool supported_extension(const std::string& e) {
  static const char* known[] = {"KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_specular",
                                "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_dispersion",
                                "KHR_texture_transform",
                                "KHR_lights_punctual", "EXT_mesh_gpu_instancing", "KHR_mesh_quantization"};
  for (const char* k : known)
    if (e == k) return true;
  return false;
}
// Extensions that change nothing a path tracer renders.
inline bool harmless_extension(const std::string& e) { return e == "KHR_xmp" || e == "KHR_xmp_json_ld"; }

// Encoded image bytes kept by the image loader callback, decoded later in
// parallel.
struct PendingImages {
  std::vector<std::vector<unsigned char>> encoded;  // by image index
  const tinygltf::Model* model = nullptr;           // being parsed: its buffers and bufferViews are in
};

inline bool defer_image(tinygltf::Image* image, const int image_idx, std::string* err, std::string* /*warn*/,
                        int /*req_width*/, int /*req_height*/, const unsigned char* bytes, int size, void* user) {
  auto* pending = static_cast<PendingImages*>(user);
  if (image_idx < 0) return false;
  // tinygltf 2.7 hands over an image's bufferView without checking its byte
  // range against the buffer (it checked both indices).
  if (image->bufferView >= 0 && pending->model) {
    const auto& bv = pending->model->bufferViews[size_t(image->bufferView)];
    const auto& buf = pending->model->buffers[size_t(bv.buffer)];
    if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset) {
      if (err)
        *err += "images[" + std::to_string(image_idx) + "]: bufferViews[" + std::to_string(image->bufferView) +
                "] byte range [" + std::to_string(bv.byteOffset) + ", " + std::to_string(bv.byteOffset + bv.byteLength) +
                ") runs past the end of buffers[" + std::to_string(bv.buffer) + "] (" + std::to_string(buf.data.size()) +
                " bytes)\n";
      return false;
    }
  }
  if (pending->encoded.size() <= size_t(image_idx)) pending->encoded.resize(size_t(image_idx) + 1);
  pending->encoded[size_t(image_idx)].assign(bytes, bytes + std::max(size, 0));
  image->width = image->height = image->component = 0;
  return true;
}

template <class S, class Set>
class Loader {
 public:
  Loader(std::string path, const GltfOptions& opt) : m_path(std::move(path)), m_opt(opt) {}

  GltfScene<S, Set> load() {
    load_model();
    check_extensions();
    decode_images();
    int scene = m_opt.scene >= 0 ? m_opt.scene : (m_model.defaultScene >= 0 ? m_model.defaultScene : 0);
    if (m_model.scenes.empty()) {
      if (m_opt.scene >= 0) fail("scenes", "the file has no scenes, so scene " + std::to_string(m_opt.scene) + " does not exist");
      if (m_model.defaultScene >= 0)
        fail("scene", "index " + std::to_string(m_model.defaultScene) + " out of range (the file has no scenes)");
      warn("the file has no scenes: nothing to render");
      return std::move(m_out);
    }
    if (scene >= int(m_model.scenes.size()))
      fail(m_opt.scene >= 0 ? std::string("scene") : std::string("scene"),
           "index " + std::to_string(scene) + " out of range (" + std::to_string(m_model.scenes.size()) + " scenes)");
    count_mesh_triangles();
    prepare_animation();
    const auto& sc = m_model.scenes[size_t(scene)];
    std::vector<uint8_t> on_path(m_model.nodes.size(), 0);
    for (size_t i = 0; i < sc.nodes.size(); ++i) {
      int n = sc.nodes[i];
      check_index(n, m_model.nodes.size(), idx("scenes", scene) + ".nodes[" + std::to_string(i) + "]", "node");
      visit(n, Matrix4d{}, Matrix4d{}, on_path, 0);
    }
    return std::move(m_out);
  }

 private:
  [[noreturn]] void fail(const std::string& element, const std::string& what) const {
    throw Error(m_path + ": " + element + ": " + what);
  }
  void warn(const std::string& what) { m_out.warnings.push_back(m_path + ": " + what); }
  void check_index(int i, size_t n, const std::string& element, const char* kind) const {
    if (i < 0 || size_t(i) >= n)
      fail(element, std::string(kind) + " index " + std::to_string(i) + " out of range (" + std::to_string(n) + " " +
                        kind + "s)");
  }

  void load_model() {
    std::error_code ec;
    if (!std::filesystem::exists(m_path, ec)) throw Error(m_path + ": no such file");
    if (std::filesystem::is_directory(m_path, ec)) throw Error(m_path + ": is a directory, not a glTF file");
    std::vector<unsigned char> file;
    {
      FILE* f = std::fopen(m_path.c_str(), "rb");
      if (!f) throw Error(m_path + ": cannot be opened");
      unsigned char chunk[65536];
      for (size_t got; (got = std::fread(chunk, 1, sizeof chunk, f)) > 0;) file.insert(file.end(), chunk, chunk + got);
      bool bad = std::ferror(f);
      std::fclose(f);
      if (bad) throw Error(m_path + ": read error");
    }
    std::string ext = std::filesystem::path(m_path).extension().string();
    for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    // Sniff the container rather than trust the extension.
    bool binary = file.size() >= 4 && std::memcmp(file.data(), "glTF", 4) == 0;
    if (ext == ".glb" && !binary) fail("GLB header", "wrong magic (expected 'glTF')");
    if (file.size() > std::numeric_limits<uint32_t>::max()) fail(binary ? "GLB header" : "JSON", "file larger than 4 GB");
    std::string base_dir = std::filesystem::path(m_path).parent_path().string();
    size_t json_at = 0, json_size = file.size();
    if (binary) check_glb(file, json_at, json_size);
    preflight(reinterpret_cast<const char*>(file.data()) + json_at, json_size, base_dir);

    tinygltf::TinyGLTF loader;
    m_pending.model = &m_model;
    loader.SetImageLoader(&defer_image, &m_pending);
    std::string err, warn_text;
    bool ok = false;
    try {
      ok = binary ? loader.LoadBinaryFromMemory(&m_model, &err, &warn_text, file.data(), unsigned(file.size()), base_dir)
                  : loader.LoadASCIIFromString(&m_model, &err, &warn_text, reinterpret_cast<const char*>(file.data()),
                                               unsigned(file.size()), base_dir);
    } catch (const std::bad_alloc&) {
      fail("JSON", "out of memory while parsing");
    } catch (const std::exception& e) {  // tinygltf lets some of nlohmann's through
      err = e.what();
    }
    if (!ok) {
      std::string msg = err.empty() ? warn_text : err;
      while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
      for (auto& c : msg)
        if (c == '\n') c = ';';
      throw Error(m_path + ": " + (msg.empty() ? std::string("not a valid glTF file") : msg));
    }
    if (!m_model.asset.version.empty() && m_model.asset.version.rfind("2.", 0) != 0)
      fail("asset.version", "'" + m_model.asset.version + "' is not glTF 2.x");
  }

  // The GLB container (tinygltf 2.7 ignores the version and reports the rest
  // as "Invalid glTF binary."): 12-byte header, JSON chunk, optional BIN chunk.
  void check_glb(const std::vector<unsigned char>& f, size_t& json_at, size_t& json_size) const {
    auto u32 = [&](size_t at) {
      return uint32_t(f[at]) | uint32_t(f[at + 1]) << 8 | uint32_t(f[at + 2]) << 16 | uint32_t(f[at + 3]) << 24;
    };
    auto hex = [](uint32_t v) {
      char b[16];
      std::snprintf(b, sizeof b, "0x%08X", v);
      return std::string(b);
    };
    size_t n = f.size();
    if (n < 12) fail("GLB header", "truncated: the file has " + std::to_string(n) + " bytes, the header 12");
    if (u32(4) != 2) fail("GLB header", "version " + std::to_string(u32(4)) + " is not 2");
    if (u32(8) != n)
      fail("GLB header", "length " + std::to_string(u32(8)) + " does not match the file size " + std::to_string(n) +
                             (u32(8) > n ? " (truncated file?)" : ""));
    if (n < 20) fail("GLB chunk 0 (JSON)", "missing: the file ends after the header");
    size_t len = u32(12);
    if (u32(16) != 0x4E4F534A) fail("GLB chunk 0", "type " + hex(u32(16)) + " is not JSON (0x4E4F534A)");
    if (len == 0) fail("GLB chunk 0 (JSON)", "length 0");
    if (len > n - 20)
      fail("GLB chunk 0 (JSON)", "length " + std::to_string(len) + " runs past the end of the file (" +
                                     std::to_string(n - 20) + " bytes after the chunk header)");
    json_at = 20;
    json_size = len;
    size_t at = 20 + len;
    if (at == n) return;
    if (n - at < 8) fail("GLB chunk 1", "truncated: " + std::to_string(n - at) + " bytes after the JSON chunk");
    size_t bin = u32(at);
    if (u32(at + 4) != 0x004E4942) fail("GLB chunk 1", "type " + hex(u32(at + 4)) + " is not BIN (0x004E4942)");
    if (bin > n - at - 8)
      fail("GLB chunk 1 (BIN)", "length " + std::to_string(bin) + " runs past the end of the file (" +
                                    std::to_string(n - at - 8) + " bytes after the chunk header)");
  }

  // What tinygltf checks with a message naming no element, checked first
  // here: external buffer files, and the indices it follows while parsing.
  // A JSON syntax error is left to tinygltf to report.
  void preflight(const char* text, size_t size, const std::string& base_dir) const {
    using json = nlohmann::json;
    json j = json::parse(text, text + size, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return;
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
        fail(element, std::string(kind) + " index " + std::to_string(i) + " out of range (" + std::to_string(n) + " " +
                          kind + "s)");
    };
    if (const json* buffers = array("buffers"))
      for (size_t b = 0; b < buffers->size(); ++b) {
        const json& buf = (*buffers)[b];
        if (!buf.is_object() || !buf.contains("uri") || !buf["uri"].is_string()) continue;
        std::string uri = buf["uri"].get<std::string>();
        if (uri.empty() || uri.rfind("data:", 0) == 0) continue;
        std::string where = idx("buffers", int(b)) + " ('" + uri + "')";
        std::error_code ec;
        std::filesystem::path file = std::filesystem::path(base_dir) / url_decode(uri);
        if (!std::filesystem::is_regular_file(file, ec)) fail(where, "file not found");
        int64_t want = integer(buf, "byteLength", -1);
        auto have = std::filesystem::file_size(file, ec);
        if (!ec && want >= 0 && uint64_t(want) != have)
          fail(where, "the file has " + std::to_string(have) + " bytes, byteLength says " + std::to_string(want));
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
          if (!prim.is_object()) fail(pw, "is not an object");
          if (!prim.contains("attributes") || !prim["attributes"].is_object())
            fail(pw + ".attributes", "missing or not an object (every primitive needs POSITION)");
          for (const auto& [name, a] : prim["attributes"].items())
            if (!a.is_number_integer()) fail(pw + ".attributes." + name, "is not an accessor index");
          if (!prim.contains("indices")) continue;
          std::string where = pw + ".indices";
          int64_t a = integer(prim, "indices", -1);
          check(a, length("accessors"), where, "accessor");
          const json& acc = (*array("accessors"))[size_t(a)];
          int64_t v = acc.is_object() ? integer(acc, "bufferView", -1) : -1;
          if (v < 0) fail(where + " (" + idx("accessors", int(a)) + ")", "has no bufferView (indices need one)");
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
          if (!ch.is_object()) fail(cw, "is not an object");
          if (!ch.contains("sampler") || !ch["sampler"].is_number_integer()) fail(cw + ".sampler", "missing or not an index");
          if (!ch.contains("target") || !ch["target"].is_object()) continue;
          const json& t = ch["target"];
          if (t.contains("node") && !t["node"].is_number_integer()) fail(cw + ".target.node", "is not an index");
          if (!t.contains("path") || !t["path"].is_string()) fail(cw + ".target.path", "missing or not a string");
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
  }
  // A uri decoded as tinygltf decodes it (its dlib::urldecode: '+' is a space).
  static std::string url_decode(const std::string& s) {
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

  void check_extensions() {
    for (const auto& e : m_model.extensionsRequired)
      if (!supported_extension(e) && !harmless_extension(e))
        fail("extensionsRequired", "extension '" + e + "' is required but prism does not support it");
    for (const auto& e : m_model.extensionsUsed)
      if (!supported_extension(e) && !harmless_extension(e))
        warn("extension '" + e + "' is used by the file but ignored by prism");
  }

  // Decodes every referenced image once, on all cores; 16-bit PNGs stay 16-bit
  // unless every value fits 8 bits.
  void decode_images() {
    size_t n = m_model.images.size();
    m_images.assign(n, nullptr);
    std::vector<std::string> errors(n);
    std::atomic<size_t> next{0};
    auto work = [&] {
      for (size_t i; (i = next.fetch_add(1)) < n;) {
        if (i >= m_pending.encoded.size() || m_pending.encoded[i].empty()) {
          const auto& im = m_model.images[i];
          bool external = !im.uri.empty() && im.uri.rfind("data:", 0) != 0;
          errors[i] = im.uri.empty() && im.bufferView < 0 ? "has neither a uri nor a bufferView"
                      : external                          ? "file not found, unreadable or empty"
                                                          : "no image data";
          continue;
        }
        const auto& bytes = m_pending.encoded[i];
        if (bytes.size() > size_t(std::numeric_limits<int>::max())) {
          errors[i] = "image too large";
          continue;
        }
        errors[i] = image_format_problem(bytes);
        if (!errors[i].empty()) continue;
        try {
          DecodedImage px = decode_image(bytes.data(), bytes.size(), {.max_pixels_log2 = 28});
          if (!px.error.empty()) {
            errors[i] = px.over_limit ? px.error : "cannot decode: " + px.error;
            continue;
          }
          if (!px.u16.empty()) {
            auto img = std::make_shared<TextureImage>(TextureImage::from_u16(px.width, px.height, px.channels, std::move(px.u16)));
            img->shrink_to_smallest();
            m_images[i] = img;
          } else {
            m_images[i] = std::make_shared<TextureImage>(TextureImage::from_u8(px.width, px.height, px.channels, std::move(px.u8)));
          }
        } catch (const std::exception& e) {
          errors[i] = e.what();
        }
      }
    };
    unsigned threads = std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(n)));
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    m_pending.encoded.clear();
    for (size_t i = 0; i < n; ++i) {
      // An image no texture uses is not an error worth failing the scene for.
      if (!errors[i].empty()) m_image_errors[i] = errors[i];
      if (m_images[i]) {
        ++m_out.images;
        m_out.image_bytes += m_images[i]->bytes();
      }
    }
  }

  // glTF images are PNG or JPEG; stb_image would also guess at BMP, GIF, TGA,
  // PSD, HDR, PIC and PNM. Checks the signature, and that a PNG's chunks and
  // a JPEG's end-of-image marker are all there, so stb_image never decodes a
  // truncated file (it reads past the end as zeros).
  static std::string image_format_problem(const std::vector<unsigned char>& b) {
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (b.size() >= 8 && std::memcmp(b.data(), png, 8) == 0) {
      for (size_t at = 8;;) {
        if (b.size() - at < 12) return "truncated PNG (no IEND chunk)";
        size_t len = size_t(b[at]) << 24 | size_t(b[at + 1]) << 16 | size_t(b[at + 2]) << 8 | size_t(b[at + 3]);
        if (len > b.size() - at - 12)
          return "truncated PNG (the chunk at byte " + std::to_string(at) + " runs past the end)";
        const unsigned char* type = b.data() + at + 4;
        if (at == 8 && std::memcmp(type, "IHDR", 4) != 0) return "corrupt PNG (the first chunk is not IHDR)";
        if (std::memcmp(type, "IEND", 4) == 0) return {};
        at += 12 + len;
      }
    }
    if (b.size() >= 4 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) {
      for (size_t k = b.size() - 1; k >= 3; --k)  // EOI, possibly followed by padding
        if (b[k - 1] == 0xFF && b[k] == 0xD9) return {};
      return "truncated JPEG (no end-of-image marker)";
    }
    return "unsupported image format (glTF images are PNG or JPEG)";
  }

  // ---- accessors ----

  static int component_size(int type) {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_BYTE:
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
      case TINYGLTF_COMPONENT_TYPE_SHORT:
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
      case TINYGLTF_COMPONENT_TYPE_INT:
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
      default: return 0;
    }
  }
  static int type_components(int type) {
    switch (type) {
      case TINYGLTF_TYPE_SCALAR: return 1;
      case TINYGLTF_TYPE_VEC2: return 2;
      case TINYGLTF_TYPE_VEC3: return 3;
      case TINYGLTF_TYPE_VEC4: return 4;
      case TINYGLTF_TYPE_MAT2: return 4;
      case TINYGLTF_TYPE_MAT3: return 9;
      case TINYGLTF_TYPE_MAT4: return 16;
      default: return 0;
    }
  }
  static double read_component(const unsigned char* p, int type, bool normalized) {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t v;
        std::memcpy(&v, p, 1);
        return normalized ? std::max(double(v) / 127.0, -1.0) : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? double(*p) / 255.0 : double(*p);
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? std::max(double(v) / 32767.0, -1.0) : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? double(v) / 65535.0 : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_INT: {
        int32_t v;
        std::memcpy(&v, p, 4);
        return double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float v;
        std::memcpy(&v, p, 4);
        return double(v);
      }
      default: return 0;
    }
  }

  // The bytes of a bufferView, checked against its buffer.
  struct ViewBytes {
    const unsigned char* data = nullptr;
    size_t size = 0, stride = 0;
  };
  ViewBytes view_bytes(int view, const std::string& element) const {
    check_index(view, m_model.bufferViews.size(), element + ".bufferView", "bufferView");
    const auto& bv = m_model.bufferViews[size_t(view)];
    std::string where = idx("bufferViews", view);
    check_index(bv.buffer, m_model.buffers.size(), where + ".buffer", "buffer");
    const auto& buf = m_model.buffers[size_t(bv.buffer)];
    if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
      fail(where, "byte range [" + std::to_string(bv.byteOffset) + ", " + std::to_string(bv.byteOffset + bv.byteLength) +
                      ") runs past the end of " + idx("buffers", bv.buffer) + " (" + std::to_string(buf.data.size()) +
                      " bytes)");
    return {buf.data.data() + bv.byteOffset, bv.byteLength, bv.byteStride};
  }

  // Reads an accessor as doubles, `comps` per element (checked against its
  // type). Handles strides, normalized integers, missing bufferViews (zeros)
  // and sparse substitution; every byte range is checked.
  std::vector<double> read_accessor(int a, const std::string& element, int comps_wanted,
                                    std::initializer_list<int> allowed_types = {}) const {
    check_index(a, m_model.accessors.size(), element, "accessor");
    const auto& acc = m_model.accessors[size_t(a)];
    std::string where = element + " (" + idx("accessors", a) + ")";
    int csize = component_size(acc.componentType);
    if (csize == 0) fail(where, "invalid componentType " + std::to_string(acc.componentType));
    int comps = type_components(acc.type);
    if (comps == 0) fail(where, "invalid type");
    if (comps != comps_wanted)
      fail(where, "has " + std::to_string(comps) + " components per element, expected " + std::to_string(comps_wanted));
    if (allowed_types.size() &&
        std::find(allowed_types.begin(), allowed_types.end(), acc.componentType) == allowed_types.end())
      fail(where, "componentType " + std::to_string(acc.componentType) + " is not allowed here");
    size_t count = acc.count;
    if (count == 0) fail(where, "count 0 (an accessor holds at least one element)");
    if (count > (size_t(1) << 31)) fail(where, "count " + std::to_string(count) + " is implausibly large");
    size_t elem = size_t(csize) * size_t(comps);
    ViewBytes view;
    size_t stride = elem;
    if (acc.bufferView != -1) {  // checked before allocating `out`
      view = view_bytes(acc.bufferView, where);
      stride = view.stride ? view.stride : elem;
      if (view.stride && view.stride < elem)
        fail(where, "byteStride " + std::to_string(view.stride) + " is smaller than an element");
      // byteOffset + stride * (count - 1) + elem <= size, without overflow.
      if (count > 0 && (acc.byteOffset > view.size || elem > view.size - acc.byteOffset ||
                        (count - 1) > (view.size - acc.byteOffset - elem) / stride))
        fail(where, "byteOffset " + std::to_string(acc.byteOffset) + " + " + std::to_string(count) +
                        " elements runs past the end of " + idx("bufferViews", acc.bufferView) + " (" +
                        std::to_string(view.size) + " bytes)");
    } else if (count > (size_t(1) << 24)) {
      // Without a bufferView the elements are zeros (plus sparse ones): no
      // buffer bounds the count, so cap it before allocating.
      fail(where, "count " + std::to_string(count) + " is implausibly large for an accessor without a bufferView");
    }
    std::vector<double> out(count * size_t(comps), 0.0);
    if (acc.bufferView != -1) {
      for (size_t i = 0; i < count; ++i) {
        const unsigned char* p = view.data + acc.byteOffset + stride * i;
        for (int c = 0; c < comps; ++c)
          out[i * size_t(comps) + size_t(c)] = read_component(p + size_t(c) * size_t(csize), acc.componentType, acc.normalized);
      }
    }
    if (acc.sparse.isSparse) {
      const auto& sp = acc.sparse;
      std::string sw = where + ".sparse";
      if (sp.count < 0 || size_t(sp.count) > count) fail(sw, "count " + std::to_string(sp.count) + " exceeds the accessor's count");
      int isize = component_size(sp.indices.componentType);
      if (isize == 0 || sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
          sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE || sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
          sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_INT)
        fail(sw + ".indices", "invalid componentType");
      ViewBytes ib = view_bytes(sp.indices.bufferView, sw + ".indices");
      ViewBytes vb = view_bytes(sp.values.bufferView, sw + ".values");
      size_t n = size_t(sp.count);
      if (sp.indices.byteOffset < 0 || size_t(sp.indices.byteOffset) + n * size_t(isize) > ib.size)
        fail(sw + ".indices", "runs past the end of its bufferView");
      if (sp.values.byteOffset < 0 || size_t(sp.values.byteOffset) + n * elem > vb.size)
        fail(sw + ".values", "runs past the end of its bufferView");
      for (size_t k = 0; k < n; ++k) {
        double di = read_component(ib.data + size_t(sp.indices.byteOffset) + k * size_t(isize), sp.indices.componentType, false);
        if (!(di >= 0) || di >= double(count)) fail(sw + ".indices", "index " + std::to_string(size_t(di)) + " out of range");
        size_t i = size_t(di);
        const unsigned char* p = vb.data + size_t(sp.values.byteOffset) + k * elem;
        for (int c = 0; c < comps; ++c)
          out[i * size_t(comps) + size_t(c)] = read_component(p + size_t(c) * size_t(csize), acc.componentType, acc.normalized);
      }
    }
    return out;
  }

  // ---- meshes ----

  void count_mesh_triangles() {
    for (size_t m = 0; m < m_model.meshes.size(); ++m) {
      size_t tris = 0;
      for (size_t p = 0; p < m_model.meshes[m].primitives.size(); ++p) tris += primitive_triangles(int(m), int(p));
      m_mesh_tris.push_back(tris);
      m_out.mesh_triangles += tris;
    }
  }
  size_t primitive_triangles(int m, int p) const {
    const auto& prim = m_model.meshes[size_t(m)].primitives[size_t(p)];
    size_t n = 0;
    if (prim.indices >= 0) {
      if (size_t(prim.indices) < m_model.accessors.size()) n = m_model.accessors[size_t(prim.indices)].count;
    } else {
      auto it = prim.attributes.find("POSITION");
      if (it != prim.attributes.end() && it->second >= 0 && size_t(it->second) < m_model.accessors.size())
        n = m_model.accessors[size_t(it->second)].count;
    }
    switch (prim.mode) {
      case TINYGLTF_MODE_TRIANGLES: return n / 3;
      case TINYGLTF_MODE_TRIANGLE_STRIP:
      case TINYGLTF_MODE_TRIANGLE_FAN: return n >= 3 ? n - 2 : 0;
      default: return 0;
    }
  }

  // The prism meshes (with materials) of a glTF mesh, built once.
  struct Part {
    uint32_t mesh;
    uint32_t material;
    int gltf_material;
  };
  const std::vector<Part>& mesh_parts(int m) {
    auto found = m_mesh_cache.find(m);
    if (found != m_mesh_cache.end()) return found->second;
    std::vector<Part> parts;
    const auto& mesh = m_model.meshes[size_t(m)];
    if (mesh.primitives.empty()) fail(idx("meshes", m) + ".primitives", "is empty (a mesh needs at least one primitive)");
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      const auto& prim = mesh.primitives[p];
      std::string where = idx("meshes", m) + ".primitives[" + std::to_string(p) + "]";
      if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
          prim.mode != TINYGLTF_MODE_TRIANGLE_FAN) {
        if (prim.mode < 0 || prim.mode > 6) fail(where + ".mode", "invalid mode " + std::to_string(prim.mode));
        if (!m_warned_points) warn(where + ": points and lines are not rendered (skipped; further ones not reported)");
        m_warned_points = true;
        continue;
      }
      // Primitives with the same accessors share one prism mesh.
      auto attr = [&](const char* name) {
        auto it = prim.attributes.find(name);
        return it == prim.attributes.end() ? -1 : it->second;
      };
      auto key = std::make_tuple(attr("POSITION"), attr("NORMAL"), attr("TEXCOORD_0"), attr("TEXCOORD_1"),
                                 attr("TANGENT"), attr("COLOR_0"), prim.indices, prim.mode);
      uint32_t mesh_id;
      auto shared = m_prim_cache.find(key);
      if (shared != m_prim_cache.end()) {
        mesh_id = shared->second;
      } else {
        TriangleMesh tm = build_primitive(prim, where);
        if (tm.triangle_count() == 0) fail(where, "has no triangle (too few vertices or indices)");
        mesh_id = m_out.scene.add_mesh(std::move(tm));
        m_prim_cache.emplace(key, mesh_id);
      }
      if (prim.material != -1) check_index(prim.material, m_model.materials.size(), where + ".material", "material");
      parts.push_back({mesh_id, material(prim.material), prim.material});
    }
    return m_mesh_cache.emplace(m, std::move(parts)).first->second;
  }

  TriangleMesh build_primitive(const tinygltf::Primitive& prim, const std::string& where) {
    TriangleMesh tm;
    auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end()) fail(where + ".attributes", "has no POSITION");
    std::string pw = where + ".attributes.POSITION";
    auto pos = read_accessor(it->second, pw, 3);
    size_t nv = pos.size() / 3;
    tm.positions.resize(nv);
    for (size_t i = 0; i < nv; ++i) {
      double x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || std::abs(x) > 1e30 || std::abs(y) > 1e30 ||
          std::abs(z) > 1e30)
        fail(pw, "element " + std::to_string(i) + " is not finite");
      tm.positions[i] = Point3f(Float(x), Float(y), Float(z));
    }
    // Indices (or the implicit 0..n-1), then strips and fans to triangles.
    std::vector<uint32_t> idxs;
    if (prim.indices != -1) {
      auto raw = read_accessor(prim.indices, where + ".indices", 1,
                               {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
      idxs.resize(raw.size());
      for (size_t i = 0; i < raw.size(); ++i) {
        if (raw[i] >= double(nv))
          fail(where + ".indices", "element " + std::to_string(i) + " = " + std::to_string(size_t(raw[i])) +
                                       " is past the vertex count " + std::to_string(nv));
        idxs[i] = uint32_t(raw[i]);
      }
    } else {
      idxs.resize(nv);
      for (size_t i = 0; i < nv; ++i) idxs[i] = uint32_t(i);
    }
    if (prim.mode == TINYGLTF_MODE_TRIANGLES) {
      idxs.resize(idxs.size() / 3 * 3);
      tm.indices = std::move(idxs);
    } else if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (size_t i = 2; i < idxs.size(); ++i) {
        // Every other triangle swaps two vertices to keep the winding.
        if (i % 2 == 0) tm.indices.insert(tm.indices.end(), {idxs[i - 2], idxs[i - 1], idxs[i]});
        else tm.indices.insert(tm.indices.end(), {idxs[i - 1], idxs[i - 2], idxs[i]});
      }
    } else {
      for (size_t i = 2; i < idxs.size(); ++i) tm.indices.insert(tm.indices.end(), {idxs[i - 1], idxs[i], idxs[0]});
    }
    // Degenerate triangles (repeated indices) would only cost time.
    auto optional_attr = [&](const char* name, int comps, auto&& store) {
      auto a = prim.attributes.find(name);
      if (a == prim.attributes.end()) return;
      std::string aw = where + ".attributes." + name;
      auto v = read_accessor(a->second, aw, comps);
      if (v.size() / size_t(comps) != nv)
        fail(aw, "has " + std::to_string(v.size() / size_t(comps)) + " elements, POSITION has " + std::to_string(nv));
      for (double d : v)
        if (!std::isfinite(d)) fail(aw, "holds a non-finite value");
      store(v);
    };
    optional_attr("NORMAL", 3, [&](const std::vector<double>& v) {
      tm.normals.resize(nv);
      for (size_t i = 0; i < nv; ++i) tm.normals[i] = Normal3f(Float(v[3 * i]), Float(v[3 * i + 1]), Float(v[3 * i + 2]));
    });
    optional_attr("TEXCOORD_0", 2, [&](const std::vector<double>& v) {
      tm.uvs.resize(nv);
      for (size_t i = 0; i < nv; ++i) tm.uvs[i] = Point2f{Float(v[2 * i]), Float(v[2 * i + 1])};
    });
    optional_attr("TEXCOORD_1", 2, [&](const std::vector<double>& v) {
      tm.uvs1.resize(nv);
      for (size_t i = 0; i < nv; ++i) tm.uvs1[i] = Point2f{Float(v[2 * i]), Float(v[2 * i + 1])};
    });
    optional_attr("TANGENT", 4, [&](const std::vector<double>& v) {
      tm.tangents.resize(nv);
      for (size_t i = 0; i < nv; ++i)
        tm.tangents[i] = {Float(v[4 * i]), Float(v[4 * i + 1]), Float(v[4 * i + 2]), v[4 * i + 3] < 0 ? Float(-1) : Float(1)};
    });
    auto color = prim.attributes.find("COLOR_0");
    if (color != prim.attributes.end()) {
      int a = color->second;
      check_index(a, m_model.accessors.size(), where + ".attributes.COLOR_0", "accessor");
      int comps = m_model.accessors[size_t(a)].type == TINYGLTF_TYPE_VEC4 ? 4 : 3;
      optional_attr("COLOR_0", comps, [&](const std::vector<double>& v) {
        tm.colors.resize(nv);
        for (size_t i = 0; i < nv; ++i)
          tm.colors[i] = {Float(v[size_t(comps) * i]), Float(v[size_t(comps) * i + 1]), Float(v[size_t(comps) * i + 2]),
                          comps == 4 ? Float(v[size_t(comps) * i + 3]) : Float(1)};
      });
    }
    return tm;
  }

  // ---- materials and textures ----

  static const tinygltf::Value* ext(const tinygltf::ExtensionMap& m, const char* name) {
    auto it = m.find(name);
    return it == m.end() || !it->second.IsObject() ? nullptr : &it->second;
  }
  static double number(const tinygltf::Value* v, const char* key, double fallback) {
    if (!v || !v->Has(key)) return fallback;
    const auto& x = v->Get(key);
    return x.IsNumber() ? x.GetNumberAsDouble() : fallback;
  }
  std::array<double, 3> vec3(const tinygltf::Value* v, const char* key, std::array<double, 3> fallback) const {
    if (!v || !v->Has(key)) return fallback;
    const auto& x = v->Get(key);
    if (!x.IsArray() || x.ArrayLen() != 3) return fallback;
    for (int i = 0; i < 3; ++i)
      if (x.Get(i).IsNumber()) fallback[size_t(i)] = x.Get(i).GetNumberAsDouble();
    return fallback;
  }
  void check_finite_number(double v, const std::string& element) const {
    if (!std::isfinite(v)) fail(element, "is not finite");
  }

  // A textureInfo-like object from an extension's JSON value.
  struct TexRef {
    int index = -1, texcoord = 0;
    const tinygltf::ExtensionMap* extensions = nullptr;
    const tinygltf::Value* json = nullptr;
  };
  static TexRef ref(const tinygltf::TextureInfo& t) { return {t.index, t.texCoord, &t.extensions, nullptr}; }
  static TexRef ref(const tinygltf::Value* v, const char* key) {
    TexRef r;
    if (!v || !v->Has(key) || !v->Get(key).IsObject()) return r;
    const auto& o = v->Get(key);
    r.index = int(number(&o, "index", -1));
    r.texcoord = int(number(&o, "texCoord", 0));
    r.json = &o;
    return r;
  }

  std::optional<ImageTexture> texture(const TexRef& r, bool srgb, const std::string& where) {
    if (r.index == -1 && !r.json) return std::nullopt;  // -1: tinygltf's "absent"
    check_index(r.index, m_model.textures.size(), where + ".index", "texture");
    const auto& tex = m_model.textures[size_t(r.index)];
    std::string tw = idx("textures", r.index);
    int source = tex.source;
    if (source == -1) {
      warn(tw + ": no source image (extensions such as KHR_texture_basisu are not supported): texture ignored");
      return std::nullopt;
    }
    check_index(source, m_model.images.size(), tw + ".source", "image");
    if (!m_images[size_t(source)]) {
      auto e = m_image_errors.find(size_t(source));
      fail(idx("images", source) + (m_model.images[size_t(source)].uri.empty()
                                        ? std::string()
                                        : " ('" + m_model.images[size_t(source)].uri + "')"),
           e == m_image_errors.end() ? "not loaded" : e->second);
    }
    ImageTexture t;
    t.image = m_images[size_t(source)];
    t.encoding = srgb ? ColorEncoding::srgb : ColorEncoding::linear;
    t.texcoord = r.texcoord;
    if (t.texcoord < 0 || t.texcoord > 1) {
      warn(where + ": texCoord " + std::to_string(t.texcoord) + " is not supported (TEXCOORD_0 used)");
      t.texcoord = 0;
    }
    if (tex.sampler != -1) {
      check_index(tex.sampler, m_model.samplers.size(), tw + ".sampler", "sampler");
      const auto& s = m_model.samplers[size_t(tex.sampler)];
      auto wrap = [&](int w, const char* which) {
        switch (w) {
          case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return WrapMode::clamp_to_edge;
          case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return WrapMode::mirrored_repeat;
          case TINYGLTF_TEXTURE_WRAP_REPEAT: return WrapMode::repeat;
          default: fail(idx("samplers", tex.sampler) + "." + which, "invalid wrap mode " + std::to_string(w));
        }
      };
      t.wrap_s = wrap(s.wrapS, "wrapS");
      t.wrap_t = wrap(s.wrapT, "wrapT");
      t.filter = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST ? FilterMode::nearest : FilterMode::linear;
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
          fail(where + ".extensions.KHR_texture_transform." + key, "must be an array of two numbers");
        return Point2f{Float(x.Get(0).GetNumberAsDouble()), Float(x.Get(1).GetNumberAsDouble())};
      };
      t.transform.offset = vec2("offset", {0, 0});
      t.transform.scale = vec2("scale", {1, 1});
      t.transform.rotation = Float(number(tt, "rotation", 0));
      if (tt->Has("texCoord")) t.texcoord = std::clamp(int(number(tt, "texCoord", 0)), 0, 1);
      if (!std::isfinite(t.transform.rotation) || !std::isfinite(t.transform.offset.x) || !std::isfinite(t.transform.offset.y) ||
          !std::isfinite(t.transform.scale.x) || !std::isfinite(t.transform.scale.y))
        fail(where + ".extensions.KHR_texture_transform", "holds a non-finite value");
    }
    return t;
  }

  uint32_t material(int i) {
    auto found = m_material_cache.find(i);
    if (found != m_material_cache.end()) return found->second;
    MetalRoughMaterial mat;
    mat.multiple_scattering = m_opt.multiple_scattering;
    if (i < 0) {
      mat.name = "glTF default material";
    } else {
      const auto& g = m_model.materials[size_t(i)];
      std::string where = idx("materials", i);
      mat.name = g.name.empty() ? where : g.name;
      const auto& pbr = g.pbrMetallicRoughness;
      if (pbr.baseColorFactor.size() != 4) fail(where + ".pbrMetallicRoughness.baseColorFactor", "must have 4 numbers");
      for (double c : pbr.baseColorFactor) check_finite_number(c, where + ".pbrMetallicRoughness.baseColorFactor");
      mat.base_color = RGB(Float(pbr.baseColorFactor[0]), Float(pbr.baseColorFactor[1]), Float(pbr.baseColorFactor[2]));
      mat.alpha = Float(pbr.baseColorFactor[3]);
      check_finite_number(pbr.metallicFactor, where + ".pbrMetallicRoughness.metallicFactor");
      check_finite_number(pbr.roughnessFactor, where + ".pbrMetallicRoughness.roughnessFactor");
      mat.metallic = Float(pbr.metallicFactor);
      mat.roughness = Float(pbr.roughnessFactor);
      if (g.alphaMode == "MASK") mat.alpha_mode = AlphaMode::mask;
      else if (g.alphaMode == "BLEND") mat.alpha_mode = AlphaMode::blend;
      else if (g.alphaMode != "OPAQUE") fail(where + ".alphaMode", "'" + g.alphaMode + "' is not OPAQUE, MASK or BLEND");
      check_finite_number(g.alphaCutoff, where + ".alphaCutoff");
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
      check_finite_number(g.normalTexture.scale, where + ".normalTexture.scale");
      textures->normal_scale = Float(g.normalTexture.scale);
      if (const auto* e = ext(g.extensions, "KHR_materials_ior")) {
        mat.ior = Float(number(e, "ior", 1.5));
        check_finite_number(mat.ior, where + ".extensions.KHR_materials_ior.ior");
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_specular")) {
        std::string ew = where + ".extensions.KHR_materials_specular";
        mat.specular = Float(number(e, "specularFactor", 1));
        auto c = vec3(e, "specularColorFactor", {1, 1, 1});
        mat.specular_color = RGB(Float(c[0]), Float(c[1]), Float(c[2]));
        set(textures->specular, texture(ref(e, "specularTexture"), false, ew + ".specularTexture"));
        set(textures->specular_color, texture(ref(e, "specularColorTexture"), true, ew + ".specularColorTexture"));
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
        check_finite_number(thickness, ew + ".thicknessFactor");
        if (thickness < 0) fail(ew + ".thicknessFactor", "is negative");
        mat.thickness = Float(thickness);
        double distance = number(vol, "attenuationDistance", std::numeric_limits<double>::infinity());
        if (std::isnan(distance) || !(distance > 0)) fail(ew + ".attenuationDistance", "must be positive");
        auto c = vec3(vol, "attenuationColor", {1, 1, 1});
        for (double v : c)
          if (!(v >= 0 && v <= 1)) fail(ew + ".attenuationColor", "must have 3 numbers in [0, 1]");
        mat.attenuation = VolumeAbsorption{RGB(Float(c[0]), Float(c[1]), Float(c[2])),
                                           std::isfinite(distance) ? Float(distance) : infinity};
      }
      if (const auto* e = ext(g.extensions, "KHR_materials_dispersion")) {
        std::string ew = where + ".extensions.KHR_materials_dispersion.dispersion";
        double d = number(e, "dispersion", 0);
        check_finite_number(d, ew);
        if (d < 0) fail(ew, "is negative");
        mat.dispersion = Float(d);
        if (d > 0 && !mat.is_volume() && !m_warned_dispersion) {
          m_warned_dispersion = true;
          warn(where + ": KHR_materials_dispersion acts only inside a volume (KHR_materials_volume with thicknessFactor > 0 and "
                       "transmission): ignored");
        }
      }
      if (any) mat.textures = textures;
    }
    uint32_t id = m_out.scene.add_material(mat);
    m_material_cache.emplace(i, id);
    return id;
  }

  std::optional<AreaEmission> emission(int i) {
    if (i < 0) return std::nullopt;
    auto found = m_emission_cache.find(i);
    if (found != m_emission_cache.end()) return found->second;
    const auto& g = m_model.materials[size_t(i)];
    std::string where = idx("materials", i);
    std::optional<AreaEmission> out;
    std::array<double, 3> f{0, 0, 0};
    if (!g.emissiveFactor.empty()) {
      if (g.emissiveFactor.size() != 3) fail(where + ".emissiveFactor", "must have 3 numbers");
      for (int k = 0; k < 3; ++k) f[size_t(k)] = g.emissiveFactor[size_t(k)];
    }
    double strength = 1;
    if (const auto* e = ext(g.extensions, "KHR_materials_emissive_strength")) strength = number(e, "emissiveStrength", 1);
    for (double v : f) check_finite_number(v, where + ".emissiveFactor");
    check_finite_number(strength, where + ".extensions.KHR_materials_emissive_strength.emissiveStrength");
    if (strength < 0) fail(where + ".extensions.KHR_materials_emissive_strength.emissiveStrength", "is negative");
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

  // ---- nodes ----

  struct Channel {
    int sampler;
    const tinygltf::Animation* anim;
    std::string path;
    int anim_index;
  };
  void prepare_animation() {
    for (size_t a = 0; a < m_model.animations.size(); ++a) {
      const auto& an = m_model.animations[a];
      for (size_t c = 0; c < an.channels.size(); ++c) {
        const auto& ch = an.channels[c];
        std::string where = idx("animations", int(a)) + ".channels[" + std::to_string(c) + "]";
        if (ch.target_node < 0) continue;  // targets nothing (or an extension)
        check_index(ch.target_node, m_model.nodes.size(), where + ".target.node", "node");
        check_index(ch.sampler, an.samplers.size(), where + ".sampler", "sampler");
        if (ch.target_path == "translation" || ch.target_path == "rotation" || ch.target_path == "scale")
          m_channels[ch.target_node].push_back({ch.sampler, &an, ch.target_path, int(a)});
      }
    }
  }
  // The animated value of a channel at time t.
  std::vector<double> sample_channel(const Channel& ch, int comps, double t) const {
    const auto& s = ch.anim->samplers[size_t(ch.sampler)];
    std::string where = idx("animations", ch.anim_index) + ".samplers[" + std::to_string(ch.sampler) + "]";
    auto times = read_accessor(s.input, where + ".input", 1);
    auto values = read_accessor(s.output, where + ".output", comps);
    bool cubic = s.interpolation == "CUBICSPLINE";
    size_t per_key = cubic ? 3 : 1;
    if (times.empty() || values.size() != times.size() * per_key * size_t(comps))
      fail(where, "input and output counts do not match");
    auto value = [&](size_t k) {
      size_t base = (k * per_key + (cubic ? 1 : 0)) * size_t(comps);
      return std::vector<double>(values.begin() + long(base), values.begin() + long(base) + comps);
    };
    if (t <= times.front()) return value(0);
    if (t >= times.back()) return value(times.size() - 1);
    size_t k = size_t(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
    double t0 = times[k], t1 = times[k + 1];
    double u = t1 > t0 ? (t - t0) / (t1 - t0) : 0;
    auto a = value(k), b = value(k + 1);
    if (s.interpolation == "STEP") return a;
    if (cubic) {
      double dt = t1 - t0, u2 = u * u, u3 = u2 * u;
      std::vector<double> r(static_cast<size_t>(comps));
      for (int c = 0; c < comps; ++c) {
        double out_tan = values[(k * 3 + 2) * size_t(comps) + size_t(c)] * dt;
        double in_tan = values[((k + 1) * 3) * size_t(comps) + size_t(c)] * dt;
        r[size_t(c)] = (2 * u3 - 3 * u2 + 1) * a[size_t(c)] + (u3 - 2 * u2 + u) * out_tan +
                       (-2 * u3 + 3 * u2) * b[size_t(c)] + (u3 - u2) * in_tan;
      }
      return r;
    }
    if (ch.path == "rotation") {  // slerp
      double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
      if (d < 0) {
        for (auto& x : b) x = -x;
        d = -d;
      }
      std::vector<double> r(4);
      if (d > 0.9995) {
        for (int c = 0; c < 4; ++c) r[size_t(c)] = a[size_t(c)] + u * (b[size_t(c)] - a[size_t(c)]);
      } else {
        double th = std::acos(d), s0 = std::sin((1 - u) * th) / std::sin(th), s1 = std::sin(u * th) / std::sin(th);
        for (int c = 0; c < 4; ++c) r[size_t(c)] = s0 * a[size_t(c)] + s1 * b[size_t(c)];
      }
      return r;
    }
    std::vector<double> r(static_cast<size_t>(comps));
    for (int c = 0; c < comps; ++c) r[size_t(c)] = a[size_t(c)] + u * (b[size_t(c)] - a[size_t(c)]);
    return r;
  }

  Matrix4d local_matrix(int n, double time) const {
    const auto& node = m_model.nodes[size_t(n)];
    std::string where = idx("nodes", n);
    auto it = m_channels.find(n);
    if (!node.matrix.empty() && it == m_channels.end()) {
      if (node.matrix.size() != 16) fail(where + ".matrix", "must have 16 numbers");
      Matrix4d m;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) m.m[size_t(4 * i + j)] = node.matrix[size_t(4 * j + i)];  // column-major
      for (double v : m.m) check_finite_number(v, where + ".matrix");
      return m;
    }
    std::array<double, 3> t{0, 0, 0}, s{1, 1, 1};
    std::array<double, 4> q{0, 0, 0, 1};
    auto copy = [&](const std::vector<double>& v, auto& dst, const char* what) {
      if (v.empty()) return;
      if (v.size() != dst.size()) fail(where + "." + what, "has " + std::to_string(v.size()) + " numbers");
      for (size_t i = 0; i < dst.size(); ++i) {
        check_finite_number(v[i], where + "." + what);
        dst[i] = v[i];
      }
    };
    copy(node.translation, t, "translation");
    copy(node.rotation, q, "rotation");
    copy(node.scale, s, "scale");
    if (it != m_channels.end())
      for (const Channel& ch : it->second) {
        if (ch.path == "translation") copy(sample_channel(ch, 3, time), t, "translation (animated)");
        else if (ch.path == "rotation") copy(sample_channel(ch, 4, time), q, "rotation (animated)");
        else copy(sample_channel(ch, 3, time), s, "scale (animated)");
      }
    return Matrix4d::trs(t, q, s);
  }

  // parent and parent_end: the parent's world transform when the shutter
  // opens and when it closes (the same without motion blur).
  void visit(int n, const Matrix4d& parent, const Matrix4d& parent_end, std::vector<uint8_t>& on_path, int depth) {
    std::string where = idx("nodes", n);
    if (on_path[size_t(n)]) fail(where, "is its own ancestor (the node hierarchy has a cycle)");
    if (depth > 4096) fail(where, "the node hierarchy is deeper than 4096 levels");
    on_path[size_t(n)] = 1;
    const auto& node = m_model.nodes[size_t(n)];
    Matrix4d world = parent * local_matrix(n, m_opt.time);
    Matrix4d world_end =
        m_opt.shutter > 0 && !m_channels.empty() ? parent_end * local_matrix(n, m_opt.time + m_opt.shutter) : world;
    if (node.mesh != -1) {
      check_index(node.mesh, m_model.meshes.size(), where + ".mesh", "mesh");
      place_mesh(n, node, world, world_end);
    }
    if (node.camera != -1) {
      check_index(node.camera, m_model.cameras.size(), where + ".camera", "camera");
      place_camera(node.camera, world);
    }
    if (const auto* e = ext(node.extensions, "KHR_lights_punctual")) {
      int l = int(number(e, "light", -1));
      check_index(l, m_model.lights.size(), where + ".extensions.KHR_lights_punctual.light", "light");
      place_light(l, world);
    }
    for (size_t c = 0; c < node.children.size(); ++c) {
      int child = node.children[c];
      check_index(child, m_model.nodes.size(), where + ".children[" + std::to_string(c) + "]", "node");
      visit(child, world, world_end, on_path, depth + 1);
    }
    on_path[size_t(n)] = 0;
  }

  void place_mesh(int n, const tinygltf::Node& node, const Matrix4d& world, const Matrix4d& world_end) {
    std::vector<Matrix4d> transforms, transforms_end;
    if (const auto* e = ext(node.extensions, "EXT_mesh_gpu_instancing")) {
      std::string ew = idx("nodes", n) + ".extensions.EXT_mesh_gpu_instancing.attributes";
      const tinygltf::Value* attrs = e->Has("attributes") ? &e->Get("attributes") : nullptr;
      std::vector<double> t, r, s;
      size_t count = 0;
      bool have = false;
      auto get = [&](const char* key, int comps, std::vector<double>& dst) {
        if (!attrs || !attrs->Has(key)) return;
        dst = read_accessor(int(number(attrs, key, -1)), ew + "." + key, comps);
        size_t c = dst.size() / size_t(comps);
        if (have && c != count) fail(ew + "." + key, "count differs from the other instancing attributes");
        count = c;
        have = true;
      };
      get("TRANSLATION", 3, t);
      get("ROTATION", 4, r);
      get("SCALE", 3, s);
      for (size_t i = 0; i < count; ++i) {
        std::array<double, 3> ti{0, 0, 0}, si{1, 1, 1};
        std::array<double, 4> qi{0, 0, 0, 1};
        if (!t.empty()) ti = {t[3 * i], t[3 * i + 1], t[3 * i + 2]};
        if (!r.empty()) qi = {r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]};
        if (!s.empty()) si = {s[3 * i], s[3 * i + 1], s[3 * i + 2]};
        transforms.push_back(world * Matrix4d::trs(ti, qi, si));
        transforms_end.push_back(world_end * Matrix4d::trs(ti, qi, si));
      }
      if (!have) {
        transforms.push_back(world);
        transforms_end.push_back(world_end);
      }
    } else {
      transforms.push_back(world);
      transforms_end.push_back(world_end);
    }
    const auto& parts = mesh_parts(node.mesh);
    for (size_t i = 0; i < transforms.size(); ++i) {
      const Matrix4d& m = transforms[i];
      for (double v : m.m)
        if (!std::isfinite(v)) fail(idx("nodes", n), "world transform is not finite");
      for (double v : transforms_end[i].m)
        if (!std::isfinite(v)) fail(idx("nodes", n), "world transform at the shutter's close is not finite");
      Transform xf(m.to_float());
      if (!xf.invertible()) {
        warn(idx("nodes", n) + ": singular transform (zero scale): instance skipped");
        continue;
      }
      std::optional<AnimatedTransform> motion;
      if (transforms_end[i] != m) {
        Transform xf_end(transforms_end[i].to_float());
        if (!xf_end.invertible()) {
          warn(idx("nodes", n) + ": singular transform at the shutter's close: motion blur ignored");
        } else {
          try {
            motion = AnimatedTransform(TransformKey::decompose(xf), TransformKey::decompose(xf_end), Float(m_opt.time),
                                       Float(m_opt.time + m_opt.shutter), "motion");
          } catch (const Error& e) {
            fail(idx("nodes", n), e.what());
          }
        }
      }
      for (const Part& p : parts) {
        auto em = emission(p.gltf_material);
        if (motion && !em) {
          m_out.scene.add_instance(p.mesh, p.material, *motion);
          m_out.bounds = union_bounds(m_out.bounds, motion->motion_bounds(mesh_bounds(p.mesh), motion->start_time(),
                                                                          motion->end_time()));
          ++m_out.moving_instances;
          continue;
        }
        if (motion && em && !m_warned_moving_emitter) {
          warn(idx("nodes", n) + ": an emissive mesh moves during the shutter; area lights stay still: drawn where "
                                 "it is when the shutter opens");
          m_warned_moving_emitter = true;
        }
        m_out.scene.add_instance(p.mesh, p.material, xf, em);
        if (em) ++m_out.emissive_instances;
        m_out.bounds = union_bounds(m_out.bounds, xf(mesh_bounds(p.mesh)));
      }
      m_out.scene_triangles += m_mesh_tris[size_t(node.mesh)];
    }
  }
  Bounds3f mesh_bounds(uint32_t mesh) {
    auto it = m_bounds_cache.find(mesh);
    if (it != m_bounds_cache.end()) return it->second;
    Bounds3f b;
    for (const auto& p : m_out.scene.accel().meshes()[mesh].positions) b = union_bounds(b, p);
    m_bounds_cache.emplace(mesh, b);
    return b;
  }

  void place_camera(int c, const Matrix4d& world) {
    const auto& cam = m_model.cameras[size_t(c)];
    std::string where = idx("cameras", c);
    GltfCamera out;
    out.name = cam.name.empty() ? where : cam.name;
    // glTF cameras look down -z; prism's camera space looks down +z.
    Matrix4d flip;
    flip.m[10] = -1;
    // Remove the node's scale: a camera's frame is rigid.
    Matrix4d w = world;
    for (size_t j = 0; j < 3; ++j) {
      double l = std::sqrt(w.m[j] * w.m[j] + w.m[4 + j] * w.m[4 + j] + w.m[8 + j] * w.m[8 + j]);
      if (!(l > 0)) fail(where, "its node's transform is singular");
      for (size_t i = 0; i < 3; ++i) w.m[4 * i + j] /= l;
    }
    out.camera_to_world = Transform((w * flip).to_float());
    if (cam.type == "perspective") {
      out.yfov = Float(cam.perspective.yfov);
      out.aspect_ratio = Float(cam.perspective.aspectRatio);
      if (!(out.yfov > 0) || !(out.yfov < pi)) fail(where + ".perspective.yfov", "must be in (0, pi)");
    } else if (cam.type == "orthographic") {
      out.orthographic = true;
      out.xmag = Float(cam.orthographic.xmag);
      out.ymag = Float(cam.orthographic.ymag);
      if (!(std::abs(out.ymag) > 0) || !std::isfinite(out.ymag)) fail(where + ".orthographic.ymag", "must be non-zero and finite");
      out.ymag = std::abs(out.ymag);
    } else {
      fail(where + ".type", "'" + cam.type + "' is not perspective or orthographic");
    }
    m_out.cameras.push_back(out);
  }

  void place_light(int l, const Matrix4d& world) {
    const auto& g = m_model.lights[size_t(l)];
    std::string where = idx("extensions.KHR_lights_punctual.lights", l);
    RGB color(1);
    if (!g.color.empty()) {
      if (g.color.size() != 3) fail(where + ".color", "must have 3 numbers");
      color = RGB(Float(g.color[0]), Float(g.color[1]), Float(g.color[2]));
    }
    if (!color.is_finite() || color.r < 0 || color.g < 0 || color.b < 0) fail(where + ".color", "must be finite and >= 0");
    if (!std::isfinite(g.intensity) || g.intensity < 0) fail(where + ".intensity", "must be finite and >= 0");
    // Photometric to radiometric: candela (point, spot) and lux (directional)
    // over 683 lm/W; an RGB of (1, 1, 1) has luminance Y = 1 (docs/gltf.md).
    Float scale = Float(g.intensity / 683.0);
    auto o = world.apply_point({0, 0, 0});
    auto z = world.apply_point({0, 0, -1});
    Point3f p{Float(o[0]), Float(o[1]), Float(o[2])};
    Vector3f d{Float(z[0] - o[0]), Float(z[1] - o[1]), Float(z[2] - o[2])};
    try {
      if (g.type == "point") {
        m_out.scene.add_light(PointLight<S>(p, color, scale));
      } else if (g.type == "spot") {
        m_out.scene.add_light(SpotLight<S>(p, d, color, scale, Float(g.spot.innerConeAngle), Float(g.spot.outerConeAngle)));
      } else if (g.type == "directional") {
        m_out.scene.add_light(DistantLight<S>(d, color, scale));
      } else {
        fail(where + ".type", "'" + g.type + "' is not point, spot or directional");
      }
    } catch (const Error& e) {
      if (std::string(e.what()).rfind(m_path, 0) == 0) throw;
      fail(where, e.what());
    }
    ++m_out.punctual_lights;
  }

  std::string m_path;
  GltfOptions m_opt;
  bool m_warned_moving_emitter = false;
  tinygltf::Model m_model;
  PendingImages m_pending;
  std::vector<std::shared_ptr<const TextureImage>> m_images;
  std::map<size_t, std::string> m_image_errors;
  GltfScene<S, Set> m_out;
  std::vector<size_t> m_mesh_tris;
  std::map<int, std::vector<Part>> m_mesh_cache;
  std::map<std::tuple<int, int, int, int, int, int, int, int>, uint32_t> m_prim_cache;
  std::map<uint32_t, Bounds3f> m_bounds_cache;
  std::map<int, uint32_t> m_material_cache;
  std::map<int, std::optional<AreaEmission>> m_emission_cache;
  std::map<int, std::vector<Channel>> m_channels;
  bool m_warned_points = false, m_warned_dispersion = false;
};

}  // namespace gltf_detail

// The camera for a scene without one: the bounds' centre seen from +z
// (glTF's front), the bounding sphere framed with a 40 degree vertical field
// of view (narrower horizontally for portrait images).
inline PerspectiveCamera gltf_framing_camera(const Bounds3f& bounds, int width, int height, Float lens_radius = 0,
                                             Float focus_distance = 1) {
  Bounds3f b = bounds.empty() ? Bounds3f(Point3f(0, 0, 0)) : bounds;
  Point3f c = b.min + (b.max - b.min) * Float(0.5);
  Float r = std::max(length(b.max - b.min) / 2, Float(1e-3));
  Float fov = Float(40) * pi / 180;
  Float aspect = Float(width) / Float(height);
  Float half = std::min(fov / 2, std::atan(std::tan(fov / 2) * aspect));
  Float dist = r / std::sin(half) * Float(1.05);
  Transform to_world = look_at_camera_to_world(c + Vector3f(0, 0, dist), c, Vector3f(0, 1, 0));
  return PerspectiveCamera(to_world, fov, width, height, lens_radius, focus_distance);
}

// Loads a .gltf or .glb file. The scene is not built: add lights (an
// environment), set options, then call scene.build(). Throws prism::Error.
template <class S, class Set = gltf_bxdf_set<S>>
GltfScene<S, Set> load_gltf(const std::string& path, const GltfOptions& opt = {}) {
  if (!std::isfinite(opt.time)) throw Error(path + ": the animation time must be finite");
  if (!(opt.shutter >= 0) || !std::isfinite(opt.shutter))
    throw Error(path + ": the shutter interval must be finite and non-negative, got " + std::to_string(opt.shutter));
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
