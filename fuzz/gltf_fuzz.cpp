// libFuzzer target for prism's glTF loader (include/prism/io/gltf.hpp and
// the headers under include/prism/io/gltf/).
// Each input is written to a file in a private temporary folder, as .glb when
// it starts with the GLB magic's first byte 'g', else as .gltf, then loaded
// and built. prism::Error is the expected way to reject bad input; anything
// else (a crash, a sanitizer report, another exception type, a hang) is a bug.
// Built and run by scripts/fuzz.sh.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <prism/io/gltf.hpp>

namespace {
// The folder is removed at exit (a crash leaves it behind, with the input).
// Never destroyed itself: the atexit handler runs after static destructors
// registered later.
const std::string& temp_dir() {
  static const std::string* dir = [] {
    std::string tmpl = (std::filesystem::temp_directory_path() / "prism_gltf_fuzz_XXXXXX").string();
    if (!mkdtemp(tmpl.data())) std::abort();
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(temp_dir(), ec);
    });
    return new std::string(tmpl);
  }();
  return *dir;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  bool glb = size > 0 && data[0] == 'g';
  std::string path = temp_dir() + (glb ? "/input.glb" : "/input.gltf");
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  try {
    auto loaded = prism::load_gltf<prism::RGB>(path);
    loaded.scene.build();
  } catch (const prism::Error& e) {
    // Every message must name the file.
    std::string msg = e.what();
    if (msg.find(path) == std::string::npos) {
      std::fprintf(stderr, "prism::Error without the file name: %s\n", e.what());
      std::abort();
    }
    // load_gltf turns stray standard exceptions into this: a bug to find.
    // (A prefix: the message quotes the input, which the fuzzer controls.)
    if (msg.rfind(path + ": internal error while loading: ", 0) == 0) {
      std::fprintf(stderr, "%s\n", e.what());
      std::abort();
    }
  }
  // Any other exception escapes and libFuzzer reports it as a crash.
  std::remove(path.c_str());
  return 0;
}
