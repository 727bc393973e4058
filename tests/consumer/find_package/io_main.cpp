// Links prism::io from the installed package: its link interface must bring in
// stb_image_write (Debian's libstb) and tinyexr.
#include <cstdio>
#include <vector>
#include <stb/stb_image_write.h>
#include <tinyexr.h>
#include "prism/math/float.hpp"

#if !defined(PRISM_HAS_IO) || PRISM_HAS_IO != 1
#error "prism::io should define PRISM_HAS_IO=1"
#endif

int main() {
  unsigned char px[4] = {255, 0, 0, 255};
  size_t bytes = 0;
  auto sink = [](void* ctx, void*, int size) { *static_cast<size_t*>(ctx) += size_t(size); };
  if (!stbi_write_png_to_func(sink, &bytes, 1, 1, 4, px, 4) || bytes == 0) {
    std::printf("stbi_write_png_to_func failed\n");
    return 1;
  }
  if (IsEXR("/nonexistent/prism-consumer.exr") == TINYEXR_SUCCESS) {
    std::printf("IsEXR accepted a missing file\n");
    return 1;
  }
  std::printf("prism::io consumer: ok (%zu PNG bytes)\n", bytes);
  return 0;
}
