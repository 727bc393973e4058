// Compares two PFM images: exit 0 when every pixel value above 1e-3 agrees
// within a relative 1e-5 (distributed against single-process renders differ
// by summation order only), or with --bitwise when they are identical.
// Usage: pfm_compare a.pfm b.pfm [--bitwise]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <prism/io/image_io.hpp>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: pfm_compare a.pfm b.pfm [--bitwise]\n");
    return 2;
  }
  const bool bitwise = argc > 3 && std::strcmp(argv[3], "--bitwise") == 0;
  try {
    prism::Image a = prism::read_pfm(argv[1]), b = prism::read_pfm(argv[2]);
    if (a.width != b.width || a.height != b.height) {
      std::printf("sizes differ: %dx%d and %dx%d\n", a.width, a.height, b.width, b.height);
      return 1;
    }
    double worst = 0;
    size_t differing = 0, compared = 0;
    for (size_t i = 0; i < a.rgb.size(); ++i) {
      double p = a.rgb[i], q = b.rgb[i];
      if (p != q) ++differing;
      double m = std::max(std::abs(p), std::abs(q));
      if (m > 1e-3) {
        ++compared;
        worst = std::max(worst, std::abs(p - q) / m);
      }
    }
    std::printf("%zu values, %zu above 1e-3, %zu differ, max relative difference %.3g\n", a.rgb.size(), compared,
                differing, worst);
    if (compared == 0) {
      std::printf("the images are black\n");
      return 1;
    }
    if (bitwise) return differing == 0 ? 0 : 1;
    // 1e-5 relative: ranks sum the same float samples in double in another order; the PFM rounds to float (≤ 1 ulp)
    return worst <= 1e-5 ? 0 : 1;
  } catch (const prism::Error& e) {
    std::printf("%s\n", e.what());
    return 1;
  }
}
