// prism-render: renders a glTF 2.0 scene (.gltf or .glb), or the built-in
// default scene (a Cornell box) when none is given, to PNG, EXR and/or PFM.
// Exit codes: 0 success, 2 bad options, a bad scene or unwritable output.
// Built with MPI (PRISM_WITH_MPI) and started by mpirun with several ranks,
// the ranks share the work (--split) and rank 0 writes the outputs
// (prism/render/mpi.hpp, docs/distributed.md).
#include <unistd.h>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <type_traits>
#include <vector>
#include <CLI/CLI.hpp>
#include <prism/prism.hpp>
#include <prism/accel/sbvh.hpp>  // --spatial-splits
#include <prism/io/gltf.hpp>
#include <prism/io/image_io.hpp>
#if defined(PRISM_HAS_MPI)
#include <prism/render/mpi.hpp>
#endif

namespace {

std::atomic<bool> g_cancel{false};

// Under MPI with several ranks: this process's rank and the rank count.
int g_rank = 0, g_ranks = 1;
bool distributed() { return g_ranks > 1; }
// Under MPI, an error before the render is kept until every rank has said
// whether it got that far (sync_before_render), so that it is reported once
// (by the lowest failing rank) and no rank waits for one that gave up.
std::string g_pending_error;
bool g_synced = false;

int fail(const std::string& msg) {
  if (distributed()) g_pending_error = msg;
  else std::fprintf(stderr, "prism-render: error: %s\n", msg.c_str());
  return 2;
}

// An error that every rank meets alike (bad options): rank 0 reports it and
// no rank needs to hear from the others.
int fail_everywhere(const std::string& msg) {
  g_synced = true;
  if (g_rank == 0) std::fprintf(stderr, "prism-render: error: %s\n", msg.c_str());
  return 2;
}

// Collective under MPI: every rank calls it exactly once, either just before
// rendering (code 0) or having failed before (code != 0). Returns whether all
// ranks are ready to render.
bool sync_before_render([[maybe_unused]] int code) {
#if defined(PRISM_HAS_MPI)
  if (!distributed()) return true;
  g_synced = true;
  int first = prism::mpi::first_failed_rank(code == 0);
  if (first == g_rank) {
    std::fprintf(stderr, "prism-render: rank %d: error: %s\n", g_rank, g_pending_error.c_str());
    std::fflush(stderr);
  }
  return first < 0;
#else
  return true;
#endif
}

std::string lowercase_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// Checks that an output path can be written before spending time rendering.
std::string check_output(const std::string& path) {
  std::string ext = lowercase_extension(path);
  if (ext != ".png" && ext != ".exr" && ext != ".pfm")
    return "output '" + path + "': unknown format '" + ext + "' (use .png, .exr or .pfm)";
  std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return "output '" + path + "': directory '" + dir.string() + "' does not exist";
  if (::access(dir.c_str(), W_OK) != 0) return "output '" + path + "': directory '" + dir.string() + "' is not writable";
  if (std::filesystem::is_directory(path, ec)) return "output '" + path + "' is a directory";
  if (std::filesystem::exists(path, ec) && ::access(path.c_str(), W_OK) != 0)
    return "output '" + path + "' is not writable";
  return {};
}

class ProgressBar {
 public:
  explicit ProgressBar(bool enabled) : m_enabled(enabled), m_start(std::chrono::steady_clock::now()) {}
  void update(int done, int total) {
    if (!m_enabled) return;
    double f = double(done) / double(total);
    double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    double eta = f > 0 ? elapsed * (1 - f) / f : 0;
    constexpr int width = 40;
    int filled = int(f * width);
    std::string bar(size_t(filled), '=');
    if (filled < width) bar += '>' + std::string(size_t(width - filled - 1), ' ');
    std::fprintf(stderr, "\r[%s] %3d%%  elapsed %5.1fs  ETA %5.1fs", bar.c_str(), int(f * 100), elapsed, eta);
    if (done == total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }

 private:
  bool m_enabled;
  std::chrono::steady_clock::time_point m_start;
};

// Everything after option parsing, for one colour model S.
struct Job {
  int width, height, spp, threads, max_depth;
  uint64_t seed;
  std::vector<std::string> outputs;
  std::string integrator, filter;
  bool quiet;
  std::string sampler = "independent";
  float exposure_ev = 0;
  std::string tone_map = "clamp";
  float aperture = 0, focus_distance = 3.75f;
  int camera = -1;
  double time = 0;
  double shutter = 0;  // seconds the shutter stays open from `time` (motion blur)
  int deformation_keys = 5;  // glTF skinned and morphing meshes: vertex keys over the shutter
  prism::TextureFilter texture_filter = prism::TextureFilter::bilinear;
  bool multiple_scattering = false;  // glTF materials: energy compensation (GltfOptions)
  std::string variant;  // glTF KHR_materials_variants: the variant to load (empty: the defaults)
  std::string env;
  float env_scale = 1;
  bool aovs = false;  // EXR outputs get albedo, normal, depth and variance layers
  std::string light_sampler = "auto";  // auto, power, uniform or bvh
  std::string split = "samples";  // under MPI: how the ranks share the work
  double target_error = 0;  // adaptive sampling (0: off): target relative error per pixel
  int min_spp = 16, max_spp = 1024;
  std::string spp_map;  // adaptive: the per-pixel sample counts as an image
  bool force_full = false;        // --instantiation full
  bool colour_auto = false;       // neither --rgb nor --spectral: the scene decides
  std::string default_scene = "cornell";
  float split_budget = prism::BVHBuildOptions{}.split_budget;  // --split-budget: BVHBuildOptions::split_budget
  bool spatial_splits = false;    // --spatial-splits: BVHBuildOptions::spatial_splits
  std::string instantiation;      // the summary's instantiation line
};

// What the render reports, with or without MPI.
struct Outcome {
  prism::RenderStats st;
  int threads = 1;
  std::vector<std::string> rank_lines;  // under MPI: one line per rank
  double imbalance = 1, wait_seconds = 0, reduce_seconds = 0;
};

prism::LightSelection light_selection(const std::string& name) {
  if (name == "power") return prism::LightSelection::power;
  if (name == "uniform") return prism::LightSelection::uniform;
  if (name == "bvh") return prism::LightSelection::bvh;
  return prism::LightSelection::automatic;
}

// Renders scene through camera and writes the outputs.
template <class SceneT, class Camera>
int render_and_write(const Job& job, const char* model, const SceneT& scene, Camera camera) {
  using namespace prism;
  try {
    camera.set_shutter(Shutter{Float(job.time), Float(job.time + job.shutter)});
  } catch (const Error& e) {
    return fail(e.what());
  }
  if (!sync_before_render(0)) return 2;
  Film film(job.width, job.height);
  std::signal(SIGINT, [](int) { g_cancel = true; });
  ProgressBar bar(!job.quiet && g_rank == 0 && ::isatty(STDERR_FILENO));
  RenderOptions opt;
  opt.spp = job.target_error > 0 ? job.max_spp : job.spp;
  opt.seed = job.seed;
  std::vector<uint32_t> counts;
  if (job.target_error > 0) {
    opt.adaptive_target = job.target_error;
    opt.adaptive_min_spp = job.min_spp;
    opt.adaptive_counts = &counts;
  }
  opt.threads = job.threads > 0 ? job.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  opt.cancel = &g_cancel;
  opt.sampler = job.sampler == "sobol"        ? SamplerKind::sobol
                : job.sampler == "stratified" ? SamplerKind::stratified
                                              : SamplerKind::independent;
  opt.progress = [&](int done, int total) { bar.update(done, total); };
  AovFilm aov_film;
  if (job.aovs) {
    aov_film = AovFilm(job.width, job.height);
    opt.aovs = &aov_film;
  }
  PathOptions popt;
  popt.max_depth = job.max_depth;
  auto with_integrator = [&](const auto& integrator, const auto& pixel_filter) {
    Outcome out;
    out.threads = opt.threads;
#if defined(PRISM_HAS_MPI)
    if (distributed()) {
      // A rank that throws from here on stops the whole job, naming itself.
      return prism::mpi::run_or_abort("prism-render", [&] {
        auto split = job.split == "tiles" ? prism::mpi::Split::tiles : prism::mpi::Split::samples;
        prism::mpi::DistributedStats d = prism::mpi::render(scene, camera, integrator, film, opt, split, pixel_filter);
        out.st = d.total;
        out.reduce_seconds = d.reduce_seconds;
        out.wait_seconds = d.wait_seconds;
        out.imbalance = d.imbalance();
        for (size_t r = 0; r < d.ranks.size(); ++r) {
          const auto& q = d.ranks[r];
          char buf[200];
          std::snprintf(buf, sizeof buf, "rank %zu: %d threads, %.3f s, %llu samples, %llu light paths, %.3f M rays",
                        r, q.threads, q.seconds, (unsigned long long)q.samples, (unsigned long long)q.light_paths,
                        double(q.rays) * 1e-6);
          out.rank_lines.push_back(buf);
        }
        return out;
      });
    }
#endif
    out.st = render(scene, camera, integrator, film, opt, pixel_filter);
    return out;
  };
  auto go = [&](const auto& pixel_filter) {
    return job.integrator == "bsdf" ? with_integrator(BSDFPathIntegrator(popt), pixel_filter)
                                    : with_integrator(PathIntegrator(popt), pixel_filter);
  };
  Outcome result = go(make_filter(job.filter));
  const RenderStats& st = result.st;
  if (g_rank != 0) return st.cancelled ? 130 : 0;  // rank 0 writes and reports
  Image img = to_image(film);
  PngOptions png{std::exp2(job.exposure_ev), job.tone_map == "neutral" ? ToneMap::neutral : ToneMap::clamp};
  for (const auto& o : job.outputs) {
    try {
      if (job.aovs && lowercase_extension(o) == ".exr") write_exr_with_aovs(o, film, aov_film);
      else write_image(o, img, png);
    } catch (const Error& e) {
      return fail(e.what());
    }
  }
  if (!job.spp_map.empty() && !counts.empty()) {
    // Sample counts as grey levels: n / max_spp, so white is the cap (PNG:
    // linear values, sRGB-encoded; EXR and PFM hold n itself).
    const bool png_map = lowercase_extension(job.spp_map) == ".png";
    Image map{job.width, job.height, std::vector<float>(counts.size() * 3)};
    for (size_t i = 0; i < counts.size(); ++i)
      for (int c = 0; c < 3; ++c)
        map.rgb[i * 3 + size_t(c)] = png_map ? float(counts[i]) / float(job.max_spp) : float(counts[i]);
    try {
      write_image(job.spp_map, map, PngOptions{});
    } catch (const Error& e) {
      return fail(e.what());
    }
  }
  std::string shutter_note;
  if (job.shutter > 0) {
    char buf[160];
    size_t deforming = 0;
    for (const auto& in : scene.accel().instances()) deforming += in.kind == prism::Instance::Kind::deforming_mesh;
    std::snprintf(buf, sizeof buf, ", shutter [%g, %g], %zu moving instances, %zu deforming%s", job.time,
                  job.time + job.shutter, scene.accel().motions().size(), deforming,
                  camera.placement().is_moving() ? ", moving camera" : "");
    shutter_note = buf;
  }
  std::string lights = std::string(prism::light_selection_name(scene.light_selection())) + " light selection";
  if (job.light_sampler == "auto") lights += " (auto)";
  std::string workers = std::to_string(result.threads) + " threads";
  if (distributed())
    workers = std::to_string(g_ranks) + " ranks x " + std::to_string(result.threads) + " threads (" + job.split +
              " split)";
  // Camera samples and, beside them, the caustic pass's light paths (one per
  // camera sample when it runs), so that samples/s compares with renderers
  // that have no such pass.
  char light_paths[96] = "";
  if (st.light_paths > 0)
    std::snprintf(light_paths, sizeof light_paths, " + %.3f M light paths/s (caustic pass)",
                  double(st.light_paths) / st.seconds * 1e-6);
  std::printf(
      "prism-render: %dx%d, %d spp%s, %s, %s, %s sampler, %s filter, %s, %s: %.2f s, %.3f M samples/s%s, %.3f M "
      "rays/s, %llu dropped%s%s\n",
      job.width, job.height, job.target_error > 0 ? job.max_spp : job.spp,
      job.target_error > 0 ? " at most (adaptive)" : "", model, job.integrator.c_str(), job.sampler.c_str(), job.filter.c_str(),
      lights.c_str(), workers.c_str(), st.seconds,
      double(st.samples) / st.seconds * 1e-6, light_paths, double(st.rays) / st.seconds * 1e-6,
      (unsigned long long)st.dropped,
      st.cancelled ? " (cancelled)" : "", shutter_note.c_str());
  if (job.target_error > 0)
    std::printf(
        "prism-render: adaptive, target relative error %g: %llu samples (mean %.1f spp of %d to %d), %d rounds, "
        "estimated relative error max %.4g (pixels below the cap), mean %.4g, %llu pixels at the cap above the "
        "target\n",
        job.target_error, (unsigned long long)st.samples, double(st.samples) / (double(job.width) * job.height),
        std::min(job.min_spp, job.max_spp), job.max_spp, st.adaptive_rounds, st.adaptive_max_error,
        st.adaptive_mean_error, (unsigned long long)st.adaptive_capped);
  std::printf("prism-render: instantiation: %s\n", job.instantiation.c_str());
  if (distributed()) {
    for (const auto& line : result.rank_lines) std::printf("prism-render:   %s\n", line.c_str());
    std::printf("prism-render: balance (slowest rank / mean) %.3f, rank 0 waited %.3f s, reduction %.3f s\n",
                result.imbalance, result.wait_seconds, result.reduce_seconds);
  }
  return st.cancelled ? 130 : 0;
}

// The built-in scene in the instantiation (colour model S, BxDF set Set)
// that run() picked.
template <class S, class Set>
int run_default(const Job& job, const char* model, const prism::CornellBoxOptions& box) {
  using namespace prism;
  Scene<S, Set> scene;
  PerspectiveCamera camera;
  try {
    build_cornell_box(scene, box);
    scene.set_light_selection(light_selection(job.light_sampler));
    BVHBuildOptions bo;
    bo.split_budget = job.split_budget;
    bo.spatial_splits = job.spatial_splits ? prism::spatial_split_builder : nullptr;
    scene.build(bo);
    DefaultSceneDesc desc;
    desc.lens_radius = job.aperture;
    desc.focus_distance = job.focus_distance;
    camera = default_camera(job.width, job.height, desc);
  } catch (const Error& e) {
    return fail(e.what());
  }
  return render_and_write(job, model, scene, camera);
}

// A glTF scene: its camera (--camera N, else the first, else one framing the
// scene's bounds), its lights, --env, and a white environment when it has no
// light of any kind (no punctual light, no emissive surface) and no --env
// (--env none: never).
template <class S, class Set>
int run_gltf(Job job, const char* model, prism::GltfScene<S, Set>& g) {
  using namespace prism;
  if (job.camera >= int(g.cameras.size()))
    return fail("--camera " + std::to_string(job.camera) + ": the scene has " + std::to_string(g.cameras.size()) +
                " cameras");
  try {
    if (job.env == "none") {
      // No environment, whatever the scene has.
    } else if (!job.env.empty()) {
      g.scene.add_light(ImageInfiniteLight<S>(read_environment(job.env), job.env_scale));
    } else if (!g.has_lights()) {
      // A scene lit by its own emitters keeps exactly their light.
      if (!job.quiet && g_rank == 0)
        std::fprintf(stderr,
                     "prism-render: the scene has no light (no punctual light, no emissive surface): adding a "
                     "white environment (--env none: none)\n");
      g.scene.add_light(UniformInfiniteLight<S>(RGB(1)));
    }
    g.scene.set_light_selection(light_selection(job.light_sampler));
    BVHBuildOptions bo;
    bo.split_budget = job.split_budget;
    bo.spatial_splits = job.spatial_splits ? prism::spatial_split_builder : nullptr;
    g.scene.build(bo);
  } catch (const Error& e) {
    return fail(e.what());
  }
  {
    // The loader maps every glTF material to MetalRoughMaterial (which never
    // needs spectra), so the set was chosen before loading: metal_rough, or
    // full when forced; the colour model is RGB unless --spectral.
    SceneFeatures f = scene_features(g.scene);
    Instantiation inst{spectrum_traits<S>::is_spectral ? ColourModel::spectral : ColourModel::rgb,
                       job.force_full ? BxDFSetKind::full : BxDFSetKind::metal_rough};
    job.instantiation = describe(inst, f) + (job.force_full ? " [forced: --instantiation full]" : " [auto]");
  }
  // Texture filtering over the pixel's footprint, seen from this camera at
  // this many samples per pixel (--texture-filter trilinear or ewa).
  auto footprint = [&](const auto& cam) {
    if (job.texture_filter == TextureFilter::trilinear || job.texture_filter == TextureFilter::ewa)
      g.scene.set_pixel_footprint(PixelFootprint(cam, job.target_error > 0 ? job.max_spp : job.spp));
  };
  try {
    if (job.camera >= 0 || !g.cameras.empty()) {
      const GltfCamera& c = g.cameras[size_t(std::max(job.camera, 0))];
      auto place = [&](auto cam) {  // camera motion blur: the node's motion over the shutter
        if (c.motion) cam.set_motion(*c.motion);
        footprint(cam);
        return cam;
      };
      if (c.orthographic)
        return render_and_write(job, model, g.scene,
                                place(OrthographicCamera(c.camera_to_world, 2 * c.ymag, job.width, job.height)));
      return render_and_write(job, model, g.scene,
                              place(PerspectiveCamera(c.camera_to_world, c.yfov, job.width, job.height, job.aperture,
                                                      job.focus_distance)));
    }
    PerspectiveCamera framing = gltf_framing_camera(g.bounds, job.width, job.height, job.aperture, job.focus_distance);
    footprint(framing);
    return render_and_write(job, model, g.scene, framing);
  } catch (const Error& e) {
    return fail(e.what());
  }
}

template <class S, template <class> class SetT>
int run_gltf_file(const Job& job, const char* model, const std::string& path) {
  using Set = SetT<S>;
  prism::GltfOptions gopt;
  gopt.time = job.time;
  gopt.shutter = job.shutter;
  gopt.deformation_keys = job.deformation_keys;
  gopt.multiple_scattering = job.multiple_scattering;
  gopt.variant = job.variant;
  gopt.texture_filter = job.texture_filter;
  try {
    auto g = prism::load_gltf<S, Set>(path, gopt);
    // A material that RGB cannot render exactly (a dispersive volume): load
    // it again for spectral rendering unless --rgb was asked for.
    if constexpr (std::is_same_v<S, prism::RGB>)
      if (job.colour_auto && g.scene.needs_spectral()) return run_gltf_file<prism::Spectral, SetT>(job, "spectral", path);
    if (!job.quiet && g_rank == 0)
      for (const auto& w : g.warnings) std::fprintf(stderr, "prism-render: warning: %s\n", w.c_str());
    if (!job.quiet && g_rank == 0 && !g.variants.empty()) {
      std::string names;
      for (const auto& n : g.variants) names += (names.empty() ? "'" : ", '") + n + "'";
      std::fprintf(stderr, "prism-render: material variant %s (the file's: %s; pick one with --variant)\n",
                   g.variant.empty() ? "none (the default materials)" : ("'" + g.variant + "'").c_str(), names.c_str());
    }
    return run_gltf<S, Set>(job, model, g);
  } catch (const prism::Error& e) {
    return fail(e.what());
  }
}

int run(int argc, char** argv);

}  // namespace

int main(int argc, char** argv) {
#if defined(PRISM_HAS_MPI)
  if (prism::mpi::launched_by_mpi()) {
    prism::mpi::Session session(&argc, &argv);
    g_rank = prism::mpi::rank();
    g_ranks = prism::mpi::size();
    int rc = run(argc, argv);
    // A rank that failed before reaching the render still meets the others.
    if (distributed() && !g_synced) sync_before_render(rc == 0 ? 2 : rc);
    std::fflush(stdout);
    return rc;
  }
#endif
  return run(argc, argv);
}

namespace {

int run(int argc, char** argv) {
  CLI::App app{"prism-render: physically based path tracing with prism"};
  std::string scene_path;
  Job job;
  job.width = job.height = 512;
  job.spp = 64;
  job.threads = 0;
  job.max_depth = 64;
  job.seed = 0;
  job.integrator = "path";
  job.filter = "box";
  job.quiet = false;
  bool spectral = false, rgb = false;
  app.add_option("scene", scene_path, "glTF 2.0 scene (.gltf or .glb); default: the built-in Cornell box");
  app.add_option("--camera", job.camera, "glTF camera index (default: the scene's first, else one framing the scene)")
      ->check(CLI::Range(0, 1 << 30));
  app.add_option("--time", job.time, "Time when the shutter opens: glTF animations are sampled then (seconds)");
  app.add_option("--shutter", job.shutter,
                 "Motion blur: the shutter stays open this long after --time; glTF nodes that animations move "
                 "become moving instances (a moving camera node blurs the whole view), and the default scene's "
                 "tall box moves (0: no blur)")
      ->check(CLI::Range(0.0, 1e30));
  app.add_option("--deformation-keys", job.deformation_keys,
                 "Deformation blur: glTF skinned and morphing meshes are posed at this many times over the "
                 "shutter, their vertices moving in straight lines between them (default 5)")
      ->check(CLI::Range(2, 1024));
  app.add_option("--env", job.env,
                 "Equirectangular environment map (.hdr, .exr or .pfm) lighting a glTF scene; 'none': no "
                 "environment (default: a white one only for a scene without any light)");
  app.add_option("--env-scale", job.env_scale, "Multiplier of the environment map")->check(CLI::Range(0.f, 1e30f));
  app.add_option("--width", job.width, "Image width in pixels")->check(CLI::Range(1, 65536));
  app.add_option("--height", job.height, "Image height in pixels")->check(CLI::Range(1, 65536));
  app.add_option("--spp", job.spp, "Samples per pixel")->check(CLI::Range(1, 1 << 24));
  app.add_option("--seed", job.seed, "Random seed");
  app.add_option("--threads", job.threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 4096));
  app.add_option("--max-depth", job.max_depth, "Maximum path depth")->check(CLI::Range(0, 1 << 20));
  app.add_option("--out,-o", job.outputs, "Output image (.png, .exr, .pfm); may repeat")->take_all();
  app.add_option("--variant", job.variant,
                 "glTF KHR_materials_variants: load this named material variant (default: the file's default "
                 "materials)");
  std::string texture_filter = "bilinear";
  app.add_option("--texture-filter", texture_filter,
                 "glTF textures over a pixel's footprint: point, bilinear (the sampler's filter, default), trilinear "
                 "or ewa (MIP maps; docs/gltf.md)")
      ->check(CLI::IsMember({"point", "bilinear", "trilinear", "ewa"}));
  app.add_flag("--multiple-scattering", job.multiple_scattering,
               "glTF materials: Kulla-Conty energy compensation of rough lobes (off: single scattering)");
  app.add_option("--integrator", job.integrator, "path (NEE + MIS) or bsdf (BSDF sampling only)")
      ->check(CLI::IsMember({"path", "bsdf"}));
  app.add_option("--filter", job.filter,
                 "Pixel filter: box (1 pixel), gaussian (radius 1.5, sigma 0.5), triangle (radius 1) or mitchell "
                 "(radius 2, B = C = 1/3)")
      ->check(CLI::IsMember({"box", "gaussian", "triangle", "mitchell"}));
  auto* spectral_flag = app.add_flag("--spectral", spectral,
                                     "Spectral rendering (4 sampled wavelengths, XYZ film); default when the scene "
                                     "uses dispersion or measured spectra");
  app.add_flag("--rgb", rgb, "RGB rendering; default when the scene renders exactly in RGB")->excludes(spectral_flag);
  app.add_option("--sampler", job.sampler,
                 "independent (PCG32), stratified (multi-jittered) or sobol (Owen-scrambled; best at power-of-2 spp)")
      ->check(CLI::IsMember({"independent", "stratified", "sobol"}));
  app.add_option("--exposure", job.exposure_ev, "PNG exposure in stops (EV): pixel values times 2^EV")
      ->check(CLI::Range(-64.f, 64.f));
  app.add_option("--tonemap", job.tone_map, "PNG tone mapping: clamp, or neutral (Khronos PBR Neutral)")
      ->check(CLI::IsMember({"clamp", "neutral"}));
  app.add_option("--aperture", job.aperture, "Thin-lens aperture radius in scene units (0: pinhole)");
  app.add_option("--focus-distance", job.focus_distance, "Distance of the plane in focus");
  app.add_flag("--aov", job.aovs,
               "EXR outputs get layers for a denoiser: albedo.RGB, N.XYZ (world-space shading normal), Z (depth) "
               "and variance.RGB (one more ray per sample)");
  app.add_option("--light-sampler", job.light_sampler,
                 "How next-event estimation chooses a light: power (by emitted power), uniform, bvh (a light BVH "
                 "weighing lights by their importance for each point) or auto (bvh from 8 lights with bounds, else "
                 "power)")
      ->check(CLI::IsMember({"auto", "power", "uniform", "bvh"}));
  app.add_option("--split", job.split,
                 "Under mpirun: how the ranks share the work: samples (each rank a range of every pixel's samples) "
                 "or tiles (each rank every n-th tile)")
      ->check(CLI::IsMember({"samples", "tiles"}));
  app.add_option("--target-error", job.target_error,
                 "Adaptive sampling: sample each pixel until the estimated relative error of its mean is below "
                 "this (e.g. 0.05), between --min-spp and --max-spp samples; --spp is then unused "
                 "(docs/adaptive.md). Not with mpirun")
      ->check(CLI::Range(1e-6, 1e6));
  app.add_option("--min-spp", job.min_spp, "Adaptive sampling: samples every pixel takes first")
      ->check(CLI::Range(2, 1 << 24));
  app.add_option("--max-spp", job.max_spp, "Adaptive sampling: the most samples a pixel takes")
      ->check(CLI::Range(1, 1 << 24));
  app.add_option("--spp-map", job.spp_map,
                 "Adaptive sampling: write each pixel's sample count to this image (.png: count / --max-spp as grey; "
                 ".exr, .pfm: the count)");
  std::string instantiation = "auto";
  app.add_option("--instantiation", instantiation,
                 "Which compiled renderer renders the scene: auto (the smallest that renders it exactly: colour "
                 "model and BxDF set; docs/instantiation.md) or full (every built-in BxDF)")
      ->check(CLI::IsMember({"auto", "full"}));
  app.add_option("--default-scene", job.default_scene,
                 "The built-in scene: cornell (the Cornell box with a glass prism, gold and frosted glass) or "
                 "cornell-diffuse (its diffuse walls, boxes and a white sphere only)")
      ->check(CLI::IsMember({"cornell", "cornell-diffuse"}));
  app.add_option("--split-budget", job.split_budget,
                 "Triangle pre-splitting: extra BVH references as a fraction of the triangles, spent on long "
                 "thin or large diagonal slivers only (0: off; default 0.3; docs/performance.md)")
      ->check(CLI::Range(0.f, 16.f));
  app.add_flag("--spatial-splits", job.spatial_splits,
               "Spatial splits in the BVH builder too (SBVH, after pre-splitting): a slower build, faster rays "
               "on scenes of overlapping slivers. They spend --split-budget's references as well, so need a "
               "budget above 0 (docs/performance.md)");
  app.add_flag("--quiet,-q", job.quiet, "No progress bar");
#if defined(PRISM_HAS_MPI)
  // Threads per rank by default: the node's cores shared among its ranks.
  // (Collective, so before anything can fail.)
  int node_threads = distributed() ? prism::mpi::threads_per_rank(0) : 0;
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    g_synced = true;
    if (g_rank == 0) std::printf("%s", app.help().c_str());
    return 0;
  } catch (const CLI::ParseError& e) {
    std::string msg = e.what();
    for (auto& c : msg)
      if (c == '\n') c = ' ';
    return fail_everywhere(msg);
  }
#if defined(PRISM_HAS_MPI)
  if (job.threads == 0 && distributed()) job.threads = node_threads;
#endif
  if (job.outputs.empty()) job.outputs.push_back("default.png");
  job.texture_filter = *prism::parse_texture_filter(texture_filter);  // checked by IsMember
  if (job.texture_filter != prism::TextureFilter::bilinear && scene_path.empty() && g_rank == 0 && !job.quiet)
    std::fprintf(stderr, "prism-render: --texture-filter applies to glTF textures; the default scene has none\n");
  if (job.target_error > 0 && distributed())
    return fail_everywhere("--target-error (adaptive sampling) does not run under mpirun: its rounds need the "
                           "whole image in one process; run prism-render without mpirun");
  if (!job.spp_map.empty() && !(job.target_error > 0)) return fail_everywhere("--spp-map needs --target-error");
  if (job.target_error > 0 && job.min_spp > job.max_spp)
    return fail_everywhere("--min-spp " + std::to_string(job.min_spp) + " exceeds --max-spp " +
                           std::to_string(job.max_spp));
  if (!job.spp_map.empty() && g_rank == 0)
    if (auto err = check_output(job.spp_map); !err.empty()) return fail(err);
  if (job.aovs && std::none_of(job.outputs.begin(), job.outputs.end(),
                               [](const std::string& o) { return lowercase_extension(o) == ".exr"; }))
    return fail_everywhere("--aov needs an .exr output (--out image.exr)");
  // Only rank 0 writes, so only its outputs are checked.
  if (g_rank == 0)
    for (const auto& o : job.outputs)
      if (auto err = check_output(o); !err.empty()) return fail(err);

  job.force_full = instantiation == "full";
  using prism::RGB;
  using prism::Spectral;
  if (!scene_path.empty()) {
    // glTF materials render exactly in RGB, except dispersive volumes
    // (run_gltf_file switches to spectral for them unless --rgb is given).
    job.colour_auto = !spectral && !rgb;
    if (job.force_full)
      return spectral ? run_gltf_file<Spectral, prism::full_bxdf_set>(job, "spectral", scene_path)
                      : run_gltf_file<RGB, prism::full_bxdf_set>(job, "rgb", scene_path);
    return spectral ? run_gltf_file<Spectral, prism::metal_rough_bxdf_set>(job, "spectral", scene_path)
                    : run_gltf_file<RGB, prism::metal_rough_bxdf_set>(job, "rgb", scene_path);
  }
  if (!job.env.empty() && job.env != "none") return fail("--env needs a glTF scene");
  if (job.default_scene != "cornell" && job.default_scene != "cornell-diffuse")
    return fail("--default-scene " + job.default_scene + ": unknown (use cornell or cornell-diffuse)");
  // The instantiation: the smallest that renders the scene exactly
  // (render/instantiation.hpp): the colour model as asked, else RGB unless a
  // material needs spectra (docs/spectral.md); the smallest compiled BxDF set
  // holding every BxDF the scene uses. A probe in the full set tells.
  prism::CornellBoxOptions box =
      job.default_scene == "cornell-diffuse" ? prism::diffuse_cornell_box_options() : prism::CornellBoxOptions{};
  box.box_motion = job.shutter > 0;  // the tall box moves between times 0 and 1
  prism::SceneFeatures features;
  try {
    prism::Scene<RGB, prism::full_bxdf_set<RGB>> probe;
    build_cornell_box(probe, box);
    probe.build();
    features = prism::scene_features(probe);
  } catch (const prism::Error& e) {
    return fail(e.what());
  }
  std::optional<prism::ColourModel> requested;
  if (spectral) requested = prism::ColourModel::spectral;
  if (rgb) requested = prism::ColourModel::rgb;
  prism::Instantiation inst =
      prism::pick_instantiation(features, requested, {prism::BxDFSetKind::diffuse, prism::BxDFSetKind::full});
  if (job.force_full) inst.bxdfs = prism::BxDFSetKind::full;
  job.instantiation = describe(inst, features) + (job.force_full ? " [forced: --instantiation full]" : " [auto]");
  const bool diffuse = inst.bxdfs == prism::BxDFSetKind::diffuse;
  if (inst.colour == prism::ColourModel::spectral)
    return diffuse ? run_default<Spectral, prism::diffuse_bxdf_set<Spectral>>(job, "spectral", box)
                   : run_default<Spectral, prism::full_bxdf_set<Spectral>>(job, "spectral", box);
  return diffuse ? run_default<RGB, prism::diffuse_bxdf_set<RGB>>(job, "rgb", box)
                 : run_default<RGB, prism::full_bxdf_set<RGB>>(job, "rgb", box);
}

}  // namespace
